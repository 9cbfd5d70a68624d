"""Skeleton models, forward kinematics and the joint-angle conventions of conventions.md."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mimucap.core import rotation as rot
from mimucap.core import skeleton as sk

TEN = sk.load_model("ten_segment")
FIFTEEN = sk.load_model("fifteen_segment")
FACING = sk.q_world_from_body_facing(0.7)
FORWARD = rot.rotate(FACING, [1.0, 0.0, 0.0])
UP = np.array([0.0, 0.0, 1.0])
RIGHT = rot.rotate(FACING, [0.0, 0.0, 1.0])


def pose(model, angles, facing=FACING):
    return sk.segment_orientations_from_joint_angles(model, facing, angles)


def segment_vector(model, orientations, name, height=1.75):
    fk = sk.forward_kinematics(model, orientations, height)
    return fk[name].distal_m - fk[name].proximal_m


def test_models_have_the_seed_segments_and_joints():
    assert TEN.segment_names == (
        "pelvis", "thorax", "upper_arm_l", "forearm_l", "upper_arm_r", "forearm_r",
        "thigh_l", "shank_l", "thigh_r", "shank_r",
    )
    assert set(TEN.joint_names) == {"lumbar", "shoulder_l", "shoulder_r", "elbow_l", "elbow_r", "hip_l", "hip_r", "knee_l", "knee_r"}
    assert set(FIFTEEN.segment_names) - set(TEN.segment_names) == {"head", "hand_l", "hand_r", "foot_l", "foot_r"}
    assert {"neck", "wrist_l", "wrist_r", "ankle_l", "ankle_r"} <= set(FIFTEEN.joint_names)


def test_body_frame_facing_north_is_x_north_y_up_z_east():
    q = sk.q_world_from_body_facing(0.0)
    np.testing.assert_allclose(rot.to_matrix(q), [[0, 0, 1], [1, 0, 0], [0, 1, 0]], atol=1e-12)
    # A quarter turn counter-clockwise seen from above faces west.
    np.testing.assert_allclose(rot.rotate(sk.q_world_from_body_facing(np.pi / 2), [1, 0, 0]), [-1, 0, 0], atol=1e-12)


def test_npose_heights_follow_the_anthropometric_ratios():
    height = 1.80
    orientations = {name: FACING for name in FIFTEEN.segment_names}
    fk = sk.forward_kinematics(FIFTEEN, orientations, height)
    # Published ratios (Winter 2009): hip 0.530 H, knee 0.285 H, ankle 0.039 H, top of head 1.0 H.
    assert fk["thigh_r"].proximal_m[2] == pytest.approx(0.530 * height)
    assert fk["shank_r"].proximal_m[2] == pytest.approx(0.285 * height)
    assert fk["foot_r"].proximal_m[2] == pytest.approx(0.039 * height)
    assert fk["head"].distal_m[2] == pytest.approx(1.0 * height)
    assert np.dot(fk["upper_arm_r"].proximal_m - fk["upper_arm_l"].proximal_m, RIGHT) > 0.3
    lengths = sk.segment_lengths(FIFTEEN, height)
    assert lengths["thigh_l"] == pytest.approx(0.245 * height)
    for name, pose_ in fk.items():
        assert np.linalg.norm(pose_.distal_m - pose_.proximal_m) == pytest.approx(lengths[name])


def test_joint_angles_are_zero_in_the_npose_for_every_sequence():
    orientations = {name: FACING for name in FIFTEEN.segment_names}
    for sequence in sk.SHOULDER_SEQUENCES:
        angles = sk.joint_angles_deg(FIFTEEN, orientations, sequence)
        assert list(angles) == sk.joint_angle_columns(FIFTEEN, sequence)
        np.testing.assert_allclose(list(angles.values()), 0.0, atol=1e-9)


@pytest.mark.parametrize(
    ("joint", "segment", "direction"),
    [("hip_r", "thigh_r", FORWARD), ("hip_l", "thigh_l", FORWARD), ("shoulder_r", "upper_arm_r", FORWARD),
     ("knee_r", "shank_r", -FORWARD), ("knee_l", "shank_l", -FORWARD), ("elbow_r", "forearm_r", FORWARD),
     ("lumbar", "thorax", FORWARD)],
)
def test_positive_flexion_moves_the_segment_the_clinical_way(joint, segment, direction):
    orientations = pose(FIFTEEN, {joint: [45.0, 0.0, 0.0]})
    vector = segment_vector(FIFTEEN, orientations, segment)
    assert np.dot(vector, direction) > 0.5 * np.linalg.norm(vector)
    assert sk.joint_angles_deg(FIFTEEN, orientations)[f"{joint}_flexion_deg"] == pytest.approx(45.0)


def test_positive_adduction_moves_limbs_towards_the_midline_on_both_sides():
    right = segment_vector(TEN, pose(TEN, {"hip_r": [0.0, 20.0, 0.0]}), "thigh_r")
    left = segment_vector(TEN, pose(TEN, {"hip_l": [0.0, 20.0, 0.0]}), "thigh_l")
    assert np.dot(right, RIGHT) < -0.1  # the right thigh's distal end moves left
    assert np.dot(left, RIGHT) > 0.1  # the left thigh's distal end moves right


def test_internal_rotation_turns_the_front_of_the_limb_medially():
    for side, medial in (("r", -RIGHT), ("l", RIGHT)):
        orientations = pose(TEN, {f"hip_{side}": [0.0, 0.0, 30.0]})
        anterior = rot.rotate(orientations[f"thigh_{side}"], [1.0, 0.0, 0.0])
        assert np.dot(anterior, medial) > 0.4


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-60.0, 60.0), min_size=3, max_size=3), st.sampled_from(["hip", "knee", "shoulder", "elbow", "ankle", "wrist"]))
def test_mirrored_movement_gives_equal_left_and_right_numbers(angles, kind):
    right = pose(FIFTEEN, {f"{kind}_r": angles})
    # Mirror the right-side pose across the body's sagittal plane and swap sides.
    q_body = FACING
    mirrored = {}
    for name, q in right.items():
        q_in_body = rot.multiply(rot.conjugate(q_body), q)
        other = name[:-1] + {"l": "r", "r": "l"}[name[-1]] if name[-2:] in ("_l", "_r") else name
        mirrored[other] = rot.multiply(q_body, sk.mirror_sagittal(q_in_body))
    a_right = sk.joint_angles_deg(FIFTEEN, right)
    a_left = sk.joint_angles_deg(FIFTEEN, mirrored)
    for axis in ("flexion", "adduction", "rotation"):
        assert a_left[f"{kind}_l_{axis}_deg"] == pytest.approx(a_right[f"{kind}_r_{axis}_deg"], abs=1e-9)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-80.0, 80.0), min_size=3, max_size=3), st.sampled_from(FIFTEEN.joint_names), st.floats(-3.1, 3.1))
def test_joint_angles_invert_the_posing_function(angles, joint, heading):
    orientations = pose(FIFTEEN, {joint: angles}, sk.q_world_from_body_facing(heading))
    result = sk.joint_angles_deg(FIFTEEN, orientations)
    axes = ("flexion", "adduction", "rotation")
    np.testing.assert_allclose([result[f"{joint}_{a}_deg"] for a in axes], angles, atol=1e-8)


def test_shoulder_sequences_name_abduction_and_flexion_planes():
    abducted = sk.joint_angles_deg(TEN, pose(TEN, {"shoulder_r": [0.0, -90.0, 0.0]}), "yxy")
    assert abducted["shoulder_r_plane_of_elevation_deg"] == pytest.approx(0.0, abs=1e-9)
    assert abducted["shoulder_r_elevation_deg"] == pytest.approx(90.0)
    flexed = sk.joint_angles_deg(TEN, pose(TEN, {"shoulder_l": [90.0, 0.0, 0.0]}), "yxy")
    assert flexed["shoulder_l_plane_of_elevation_deg"] == pytest.approx(90.0)
    assert flexed["shoulder_l_elevation_deg"] == pytest.approx(90.0)
    xzy = sk.joint_angles_deg(TEN, pose(TEN, {"shoulder_r": [30.0, -50.0, 0.0]}), "xzy")
    assert xzy["shoulder_r_adduction_deg"] < -40.0
    assert "shoulder_r_flexion_deg" in xzy and "hip_r_flexion_deg" in xzy


def test_joint_angles_do_not_depend_on_the_facing_direction():
    angles = {"hip_r": [25.0, 5.0, -10.0], "knee_r": [40.0, 0.0, 3.0], "shoulder_l": [10.0, -30.0, 5.0]}
    a = sk.joint_angles_deg(TEN, pose(TEN, angles, sk.q_world_from_body_facing(0.0)))
    b = sk.joint_angles_deg(TEN, pose(TEN, angles, sk.q_world_from_body_facing(2.5)))
    for key in a:
        assert a[key] == pytest.approx(b[key], abs=1e-9)


def test_bad_models_and_inputs_are_refused(tmp_path):
    with pytest.raises(ValueError, match="unknown skeleton model"):
        sk.load_model("octopus")
    with pytest.raises(ValueError, match="not a MimuCap skeleton model"):
        sk.model_from_dict({"segments": []}, "my model")
    with pytest.raises(ValueError, match="my model: segment 'thorax' lists parent 'spine' before it is defined"):
        data = json.loads(json.dumps(sk.BUILT_IN_MODELS["ten_segment"]))
        data["segments"][1]["parent"] = "spine"
        sk.model_from_dict(data, "my model")
    with pytest.raises(ValueError, match="missing: thorax"):
        sk.forward_kinematics(TEN, {"pelvis": FACING}, 1.7)
    with pytest.raises(ValueError, match="height"):
        sk.segment_lengths(TEN, 7.0)
    with pytest.raises(ValueError, match="no joint"):
        pose(TEN, {"neck": [0.0, 0.0, 0.0]})
    with pytest.raises(ValueError, match="shoulder sequence"):
        sk.joint_angle_columns(TEN, "zyz")
