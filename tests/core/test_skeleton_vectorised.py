"""The vectorised forward kinematics and joint angles give the per-segment, per-joint numbers.

References here walk the tree one segment at a time and decompose one joint at a time, as
the conventions describe them (conventions.md: joint rotation ``q_prox⁻¹ ⊗ q_dist``, left
side mirrored, intrinsic Z-X'-Y'' with the knee, lumbar and neck flexion negated; ISB
shoulder sequences).
"""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.core import skeleton as sk

MODELS = [sk.load_model(name) for name in sk.MODEL_NAMES]


def _reference_fk(model, q, height, root):
    proximal, distal = {}, {}
    for seg in model.segments:
        if seg.parent is None:
            proximal[seg.name] = np.broadcast_to(root, q[seg.name].shape[:-1] + (3,))
        else:
            offset = rot.rotate(q[seg.parent], np.array(seg.attach_ratio) * height)
            proximal[seg.name] = proximal[seg.parent] + offset
        along = np.array(seg.direction) * seg.length_ratio * height
        distal[seg.name] = proximal[seg.name] + rot.rotate(q[seg.name], along)
    return proximal, distal


def _reference_angles(model, q, sequence):
    angles = {}
    for joint in model.joints:
        q_joint = rot.multiply(rot.conjugate(q[joint.proximal]), q[joint.distal])
        if joint.side == "l":
            q_joint = q_joint * np.array([1.0, -1.0, -1.0, 1.0])
        if joint.kind == "shoulder" and sequence == "xzy":
            values = np.degrees(rot.to_euler(q_joint, "XZY"))
        elif joint.kind == "shoulder" and sequence == "yxy":
            y_pi = np.array([0.0, 0.0, 1.0, 0.0])
            values = np.degrees(rot.to_euler(rot.multiply(rot.multiply(rot.conjugate(y_pi), q_joint), y_pi), "YXY"))
        else:
            values = np.degrees(rot.to_euler(q_joint, "ZXY"))
            values = values * np.array([sk.FLEXION_SIGN.get(joint.kind, 1.0), 1.0, 1.0])
        angles[joint.name] = values
    return angles


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.name)
@pytest.mark.parametrize("shape", [(), (7,), (2, 3)])
def test_stacked_forward_kinematics_walks_the_tree_like_the_reference(model, shape):
    rng = np.random.default_rng(len(shape) + len(model.segments))
    q = {name: rot.normalize(rng.normal(size=shape + (4,))) for name in model.segment_names}
    root = rng.normal(size=shape + (3,))
    stacked = np.stack([q[name] for name in model.segment_names])
    proximal, distal = sk.forward_kinematics_stacked(model, stacked, 1.68, root)
    assert proximal.shape == distal.shape == (len(model.segments),) + shape + (3,)
    ref_proximal, ref_distal = _reference_fk(model, q, 1.68, root)
    poses = sk.forward_kinematics(model, q, 1.68, root)
    for i, name in enumerate(model.segment_names):
        np.testing.assert_allclose(proximal[i], ref_proximal[name], rtol=0, atol=1e-12)
        np.testing.assert_allclose(distal[i], ref_distal[name], rtol=0, atol=1e-12)
        np.testing.assert_array_equal(poses[name].proximal_m, proximal[i])
        np.testing.assert_array_equal(poses[name].distal_m, distal[i])


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.name)
@pytest.mark.parametrize("sequence", sk.SHOULDER_SEQUENCES)
def test_stacked_joint_angles_decompose_each_joint_like_the_reference(model, sequence):
    rng = np.random.default_rng(11)
    q = {name: rot.normalize(rng.normal(size=(9, 4))) for name in model.segment_names}
    expected = _reference_angles(model, q, sequence)
    stacked = sk.joint_angles_deg_stacked(model, np.stack([q[name] for name in model.segment_names]), sequence)
    assert stacked.shape == (len(model.joints), 9, 3)
    columns = sk.joint_angles_deg(model, q, sequence)
    assert list(columns) == sk.joint_angle_columns(model, sequence)
    for j, joint in enumerate(model.joints):
        np.testing.assert_allclose(stacked[j], expected[joint.name], rtol=0, atol=1e-9, err_msg=joint.name)
        names = [c for c in sk.joint_angle_columns(model, sequence) if c.startswith(joint.name + "_")]
        np.testing.assert_array_equal(np.stack([columns[c] for c in names], axis=-1), stacked[j])


def test_joint_angles_of_a_partial_pose_cover_the_joints_present():
    model = sk.load_model("fifteen_segment")
    rng = np.random.default_rng(4)
    q = {name: rot.normalize(rng.normal(size=4)) for name in model.segment_names if name not in ("thorax", "foot_r")}
    columns = sk.joint_angles_deg(model, q)
    present = {joint.name for joint in model.joints if joint.proximal in q and joint.distal in q}
    assert {c.rsplit("_", 2)[0] for c in columns} == present
    expected = _reference_angles(model, {**q, "thorax": q["pelvis"], "foot_r": q["shank_r"]}, "zxy")
    for name in present:
        np.testing.assert_allclose([columns[f"{name}_{a}_deg"] for a in ("flexion", "adduction", "rotation")],
                                   expected[name], atol=1e-9)
    assert sk.joint_angles_deg(model, {"pelvis": q["pelvis"]}) == {}


def test_stacked_functions_refuse_orientations_out_of_model_order():
    model = sk.load_model("ten_segment")
    with pytest.raises(ValueError, match="model order"):
        sk.forward_kinematics_stacked(model, np.tile(rot.identity(), (3, 1)), 1.7)
    with pytest.raises(ValueError, match="model order"):
        sk.joint_angles_deg_stacked(model, rot.identity((4,)))
    with pytest.raises(ValueError, match="height"):
        sk.forward_kinematics_stacked(model, rot.identity((10,)), 3.1)
