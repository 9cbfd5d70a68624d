"""Body calibration: simulated suits with known mountings, sign checks on physically built
poses, quality verdicts on deliberately bad poses, bad input, display modes, and the
OpenSense recordings (heading from the pelvis sensor)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mimucap.core import bodycal as bc
from mimucap.core import rotation as rot
from mimucap.core import skeleton as sk

TEN = sk.load_model("ten_segment")
FIFTEEN = sk.load_model("fifteen_segment")
RATE_HZ = 100.0
N_POSE = (0.0, 0.99)
T_POSE = (2.0, 2.99)
EX, EY, EZ = np.eye(3)


def deg_between(q1, q2):
    return np.degrees(rot.angle_between(q1, q2))


def random_mountings(model, seed):
    rng = np.random.default_rng(seed)
    return {s: rot.normalize(rng.normal(size=4)) for s in model.segment_names}


def motion_angles(model, t, seed):
    """Smooth random joint angles (deg) for every joint, zero at t = 0."""
    rng = np.random.default_rng(seed)
    angles = {}
    for joint in model.joint_names:
        amp = rng.uniform(10.0, 40.0, 3)
        freq = rng.uniform(0.3, 1.0, 3)
        phase = rng.uniform(0.0, 2 * np.pi, 3)
        a = amp * (np.sin(2 * np.pi * freq * t[:, None] + phase) - np.sin(phase)) * np.sin(np.pi * t / t[-1])[:, None]
        if joint.startswith(("knee", "elbow")):
            a[:, 0] = np.abs(a[:, 0])
        angles[joint] = a
    return angles


def suit_recording(heading_rad, mountings, model=TEN, arms="both", arm_plane_deg=(0.0, 0.0),
                   arm_angle_deg=90.0, motion_seed=3, arm_tilt_deg=0.0, arm_twist_deg=0.0):
    """N-pose (0–1 s), arm raise (1–2 s), T-pose (2–3 s), back down and random motion (3–6 s).

    ``arm_plane_deg`` (left, right): the raise plane turned forward from the frontal plane by
    that angle (0 = sideways, 90 = forward). ``arm_tilt_deg`` tilts the raise plane (leaning).
    ``arm_twist_deg``: internal rotation of each arm about its own long axis during the raise.
    Returns ``t``, sensor orientations, mapping (segment → sensor), truth segment orientations.
    """
    t = np.arange(0.0, 6.0, 1.0 / RATE_HZ)
    raise_level = np.clip(t - 1.0, 0.0, 1.0) * (t < 3.0)
    moving = t >= 3.0
    q_body = sk.q_world_from_body_facing(heading_rad)
    q_root = np.broadcast_to(q_body, (t.size, 4)).copy()
    tau = t[moving] - 3.0
    q_root[moving] = rot.multiply(q_body, rot.from_rotvec(np.column_stack(
        (0.1 * np.sin(tau), 0.4 * tau, 0.05 * np.sin(2 * tau)))))
    angles = {j: np.zeros((t.size, 3)) for j in model.joint_names}
    for j, a in motion_angles(model, t[moving] - 3.0 + 1e-9, motion_seed).items():
        angles[j][moving] = a
    seg = sk.segment_orientations_from_joint_angles(model, q_root, angles)
    # Arms: built physically in the body frame (not through joint angles): the arm hangs
    # (-y) and turns about an axis in the horizontal plane, perpendicular to the raise plane.
    for index, (side, segs) in enumerate((("l", ("upper_arm_l", "forearm_l")), ("r", ("upper_arm_r", "forearm_r")))):
        if arms not in ("both", {"l": "left", "r": "right"}[side]):
            continue
        plane = np.radians(arm_plane_deg[index])
        # Sideways raise of the right arm: -90° about +x; of the left arm: +90° about +x.
        sign = -1.0 if side == "r" else 1.0
        axis_body = np.cos(plane) * EX + sign * np.sin(plane) * EZ
        tilt = np.radians(arm_tilt_deg)
        axis_body = np.cos(tilt) * axis_body + np.sin(tilt) * EY
        q_arm_body = rot.multiply(rot.from_axis_angle(axis_body, sign * np.radians(arm_angle_deg) * raise_level),
                                  rot.from_axis_angle(EY, -sign * np.radians(arm_twist_deg) * raise_level))
        for s in segs:
            seg[s] = np.where((t < 3.0)[:, None], rot.multiply(q_body, q_arm_body), seg[s])
    sensors = {f"S{i:02d}": rot.multiply(seg[s], mountings[s]) for i, s in enumerate(model.segment_names)}
    mapping = {s: f"S{i:02d}" for i, s in enumerate(model.segment_names)}
    return t, sensors, mapping, seg


def mounting_errors(cal, mountings):
    return {s: float(deg_between(cal.q_segment_from_sensor[s], mountings[s])) for s in cal.sensors}


# --------------------------------------------------------------------------------------------
# Simulated suits
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("heading_deg", [0.0, 73.0, 180.0, -121.0])
@pytest.mark.parametrize("arms", ["both", "left", "right"])
def test_npose_tpose_recovers_random_mountings_for_any_heading(heading_deg, arms):
    mountings = random_mountings(TEN, seed=int(heading_deg) % 97 + len(arms))
    t, sensors, mapping, _ = suit_recording(np.radians(heading_deg), mountings, arms=arms)
    cal = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE, arms=arms)
    assert max(mounting_errors(cal, mountings).values()) < 0.5
    assert deg_between(cal.q_world_from_body, sk.q_world_from_body_facing(np.radians(heading_deg))) < 0.5
    assert cal.quality.verdict == "good"
    assert len(cal.quality.arms) == (2 if arms == "both" else 1)
    for arm in cal.quality.arms:
        assert arm.rotation_angle_deg == pytest.approx(90.0, abs=0.1)
        assert arm.raise_angle_deg == pytest.approx(90.0, abs=0.1)
        assert arm.axis_tilt_deg < 0.1 and arm.axis_vs_swing_deg < 0.1
        assert arm.swing_residual_deg < 0.1 and arm.axis_residual_deg < 0.1


@settings(max_examples=25, deadline=None)
@given(heading=st.floats(-np.pi, np.pi), seed=st.integers(0, 10_000),
       arms=st.sampled_from(["both", "left", "right"]), estimator=st.sampled_from(["swing", "rotation_axis"]))
def test_any_heading_and_any_mounting_are_recovered(heading, seed, arms, estimator):
    mountings = random_mountings(TEN, seed=seed)
    t, sensors, mapping, _ = suit_recording(heading, mountings, arms=arms, motion_seed=seed)
    cal = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE, arms=arms,
                                   settings=bc.BodyCalSettings(forward_from=estimator))
    assert max(mounting_errors(cal, mountings).values()) < 0.5
    assert cal.quality.verdict == "good"


def test_auto_arms_uses_the_raised_arm_only():
    mountings = random_mountings(TEN, seed=5)
    t, sensors, mapping, _ = suit_recording(1.0, mountings, arms="right")
    cal = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)
    assert [a.side for a in cal.quality.arms] == ["right"]
    assert max(mounting_errors(cal, mountings).values()) < 0.5


def test_joint_angles_within_one_degree_of_truth_during_motion():
    mountings = random_mountings(TEN, seed=11)
    t, sensors, mapping, truth = suit_recording(0.4, mountings)
    cal = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)
    moving = t >= 3.0
    live = bc.segment_orientations(cal, {s: q[moving] for s, q in sensors.items()})
    estimated = sk.joint_angles_deg(TEN, live)
    expected = sk.joint_angles_deg(TEN, {s: q[moving] for s, q in truth.items()})
    assert set(estimated) == set(expected) and len(estimated) == 27
    worst = max(np.abs(estimated[c] - expected[c]).max() for c in expected)
    assert worst < 1.0
    assert max(np.abs(expected[c]).max() for c in expected) > 20.0  # the motion is not trivial


def test_joint_angles_do_not_depend_on_the_heading_at_calibration():
    mountings = random_mountings(TEN, seed=13)
    results = []
    for heading in (0.0, 2.0, -2.9):
        t, sensors, mapping, _ = suit_recording(heading, mountings)
        cal = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)
        moving = t >= 3.0
        results.append(sk.joint_angles_deg(TEN, bc.segment_orientations(cal, {s: q[moving] for s, q in sensors.items()})))
    for other in results[1:]:
        for column, values in results[0].items():
            np.testing.assert_allclose(other[column], values, atol=1e-6)


def test_noisy_orientations_and_sway_still_calibrate_within_a_degree():
    rng = np.random.default_rng(21)
    mountings = random_mountings(TEN, seed=21)
    t, sensors, mapping, _ = suit_recording(-0.8, mountings)
    noisy = {s: rot.multiply(rot.from_rotvec(rng.normal(scale=np.radians(0.3), size=(t.size, 3))), q)
             for s, q in sensors.items()}
    cal = bc.calibrate_npose_tpose(t, noisy, mapping, N_POSE, T_POSE)
    assert max(mounting_errors(cal, mountings).values()) < 1.0
    assert cal.quality.verdict == "good"


def test_both_arms_cancel_a_symmetric_raise_plane_error():
    """Both arms raised 15° forward of the frontal plane (scaption): each arm's axis is off
    by 15° in opposite directions, their mean is right, and the disagreement is reported."""
    mountings = random_mountings(TEN, seed=8)
    t, sensors, mapping, _ = suit_recording(0.3, mountings, arm_plane_deg=(15.0, 15.0))
    both = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE, arms="both")
    right = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE, arms="right")
    assert max(mounting_errors(both, mountings).values()) < 0.5
    assert max(mounting_errors(right, mountings).values()) == pytest.approx(15.0, abs=0.5)
    assert both.quality.left_right_disagreement_deg == pytest.approx(30.0, abs=0.5)
    assert both.quality.verdict == "poor"
    assert any("disagree by 30" in p for p in both.quality.problems)


def test_any_up_axis_gives_the_same_calibration():
    """The same suit in a Y-up world (OpenSim ground) with up declared as +y."""
    mountings = random_mountings(TEN, seed=17)
    t, sensors, mapping, _ = suit_recording(1.2, mountings)
    q_yup_from_enu = rot.from_matrix(np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]))
    yup = {s: rot.multiply(q_yup_from_enu, q) for s, q in sensors.items()}
    cal = bc.calibrate_npose_tpose(t, yup, mapping, N_POSE, T_POSE, up_world=(0.0, 1.0, 0.0))
    assert max(mounting_errors(cal, mountings).values()) < 0.5
    np.testing.assert_allclose(rot.rotate(cal.q_world_from_body, EY), EY, atol=1e-9)


def test_heading_mode_from_a_named_sensor_axis():
    """The pelvis sensor is mounted with its −z axis pointing forward (a sensor on the back,
    face outwards): heading from S00:−z recovers every mounting."""
    mountings = random_mountings(TEN, seed=19)
    # R_pelvis_from_sensor with sensor -z = pelvis x (forward), sensor x = pelvis y (up).
    r_seg_from_sensor = np.column_stack((EY, -EZ, -EX))
    assert np.isclose(np.linalg.det(r_seg_from_sensor), 1.0)
    mountings["pelvis"] = rot.from_matrix(r_seg_from_sensor)
    for heading in (0.0, 2.5):
        t, sensors, mapping, _ = suit_recording(heading, mountings)
        cal = bc.calibrate_heading(t, sensors, mapping, mapping["pelvis"], -EZ, npose_s=N_POSE)
        assert max(mounting_errors(cal, mountings).values()) < 0.5
        assert cal.quality.method == "heading"
        assert cal.quality.heading_axis_tilt_deg == pytest.approx(0.0, abs=1e-6)
        assert cal.quality.verdict == "good"


def test_heading_mode_refuses_a_vertical_axis():
    mountings = random_mountings(TEN, seed=19)
    mountings["pelvis"] = rot.identity()  # sensor y = up
    t, sensors, mapping, _ = suit_recording(0.0, mountings)
    with pytest.raises(bc.CalibrationRefused, match="from horizontal"):
        bc.calibrate_heading(t, sensors, mapping, mapping["pelvis"], EY)


@pytest.mark.parametrize("turn_deg", [0.0, 135.0, -100.0])
def test_the_suit_simulator_subject_calibrated_at_any_heading(turn_deg):
    """The simulated suit: 15 units with random mountings; the subject turns on the spot,
    stands in N-pose (with quiet-standing sway), raises both arms to 88°, then walks.
    Noise-free orientations (the simulator's truth)."""
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.core.simulate.suit import SuitSimulator
    from mimucap.core.simulate.truth import SuitBlock

    simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=15, seed=9, errors="ideal"))
    blocks = []
    if turn_deg:
        simulator.set_activity("turn", angle_deg=turn_deg, turns=1, turn_s=2.0, pause_s=0.5)
    blocks.append(simulator.advance(3.0))
    simulator.set_activity("npose")
    blocks.append(simulator.advance(3.0))
    simulator.set_activity("tpose", arms="both")
    blocks.append(simulator.advance(4.0))
    simulator.set_activity("walk")
    blocks.append(simulator.advance(5.0))
    truth = SuitBlock.concatenate(blocks).truth
    t, sensors = truth.t_s, truth.q_world_from_sensor
    mapping = {simulator.mounting[sid].segment: sid for sid in sensors}
    cal = bc.calibrate_npose_tpose(t, sensors, mapping, (4.0, 5.9), (8.5, 9.9))
    assert cal.quality.verdict == "good"
    for segment, sid in mapping.items():
        assert deg_between(cal.q_segment_from_sensor[segment], simulator.mounting[sid].q_segment_from_sensor) < 0.5
    in_npose = (t >= 4.0) & (t <= 5.9)
    pelvis = rot.average(truth.q_world_from_segment["pelvis"][in_npose])
    assert deg_between(cal.q_world_from_body, pelvis) < 0.5
    walking = t >= 10.5
    estimated = sk.joint_angles_deg(FIFTEEN, bc.segment_orientations(cal, {s: q[walking] for s, q in sensors.items()}))
    assert len(estimated) == 3 * len(FIFTEEN.joint_names)
    for column, values in estimated.items():
        np.testing.assert_allclose(values, truth.joint_angles_deg[column][walking], atol=1.0, err_msg=column)
    assert truth.joint_angles_deg["knee_r_flexion_deg"][walking].max() > 40.0


# --------------------------------------------------------------------------------------------
# Signs and mirror symmetry on physically built poses
# --------------------------------------------------------------------------------------------

def calibrated_pose(segment_rotations_body, heading=0.9, model=TEN, seed=29):
    """Calibrate a suit, then give each named segment the rotation (in the body frame) and
    return the joint angles measured through the sensors."""
    mountings = random_mountings(model, seed)
    t, sensors, mapping, _ = suit_recording(heading, mountings, model=model)
    cal = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)
    q_body = sk.q_world_from_body_facing(heading)
    q_world_from_segment = {s: q_body for s in model.segment_names}
    # Children inherit their parent's rotation unless given their own.
    for segment in model.segments:
        if segment.name in segment_rotations_body:
            q_world_from_segment[segment.name] = rot.multiply(q_body, segment_rotations_body[segment.name])
        elif segment.parent is not None:
            q_world_from_segment[segment.name] = q_world_from_segment[segment.parent]
    q_sensors = {mapping[s]: rot.multiply(q, mountings[s]) for s, q in q_world_from_segment.items()}
    return sk.joint_angles_deg(model, bc.segment_orientations(cal, q_sensors))


FORWARD_90 = rot.from_axis_angle(EZ, np.radians(90.0))   # distal end (−y) swings to +x (forward)
BACKWARD_60 = rot.from_axis_angle(EZ, np.radians(-60.0))  # distal end swings backwards



def test_static_alignment_gives_the_orientation_of_a_sensor_at_rest():
    """Mean specific force and calibrated field of a still sensor → its orientation in ENU with
    magnetic north along +y (turned to true north by a declination)."""
    rng = np.random.default_rng(8)
    field = np.array([0.0, 22.0, -41.0])  # north and down, µT
    for _ in range(5):
        q_true = rot.normalize(rng.normal(size=4))
        acc = rot.rotate(rot.conjugate(q_true), np.array([0.0, 0.0, 9.81])) + rng.normal(0, 0.02, (200, 3))
        mag = rot.rotate(rot.conjugate(q_true), field) + rng.normal(0, 0.3, (200, 3))
        assert deg_between(bc.static_alignment(acc, mag), q_true) < 0.3
        # magnetic north 10° east of true north: the sensor's true heading is 10° less than its
        # magnetic one, i.e. turned clockwise (negative about up)
        turned = rot.multiply(rot.from_axis_angle(EZ, np.radians(-10.0)), q_true)
        assert deg_between(bc.static_alignment(acc, mag, np.radians(10.0)), turned) < 0.3
    with pytest.raises(ValueError, match="vertical"):
        bc.static_alignment(np.tile([0.0, 0.0, 9.81], (5, 1)), np.tile([0.0, 0.0, -45.0], (5, 1)))
    # a magnet near the sensor: the field's magnitude is off the calibration's
    assert deg_between(bc.static_alignment(acc, mag, field_uT=46.5), q_true) < 0.3
    with pytest.raises(ValueError, match="disturbed"):
        bc.static_alignment(acc, mag * 1.3, field_uT=46.5)
    with pytest.raises(ValueError, match="non-finite"):
        bc.static_alignment(np.full((3, 3), np.nan), np.ones((3, 3)))
    with pytest.raises(ValueError, match="windows"):
        bc.static_alignment(np.zeros((0, 3)), np.zeros((0, 3)))


def test_given_npose_orientations_replace_the_tracked_ones_in_the_segment_rotations(recording):
    """A sensor whose tracked N-pose orientation carries a heading error (a filter still
    settling) gets its segment rotation from the orientation given for it; the other sensors
    and the body frame are those of the tracks."""
    t, q, mapping, _ = recording
    plain = bc.calibrate_npose_tpose(t, q, mapping, N_POSE, T_POSE)
    sensor = mapping["forearm_l"]
    window = (t >= N_POSE[0]) & (t <= N_POSE[1])
    off = rot.multiply(rot.from_axis_angle(EZ, np.radians(5.0)), q[sensor])  # 5° heading error in the track
    tracked = bc.calibrate_npose_tpose(t, {**q, sensor: off}, mapping, N_POSE, T_POSE)
    given = bc.calibrate_npose_tpose(t, {**q, sensor: off}, mapping, N_POSE, T_POSE,
                                     npose_orientations={sensor: rot.average(q[sensor][window])})
    assert deg_between(tracked.q_segment_from_sensor["forearm_l"], plain.q_segment_from_sensor["forearm_l"]) > 4.5
    assert deg_between(given.q_segment_from_sensor["forearm_l"], plain.q_segment_from_sensor["forearm_l"]) < 1e-6
    for segment in mapping:
        if segment != "forearm_l":
            assert deg_between(given.q_segment_from_sensor[segment], plain.q_segment_from_sensor[segment]) < 1e-6
    assert given.details["npose_track_vs_given_deg"][sensor] == pytest.approx(5.0, abs=0.01)
    with pytest.raises(ValueError, match=f"N-pose orientation of sensor {sensor}"):
        bc.calibrate_npose_tpose(t, q, mapping, N_POSE, T_POSE, npose_orientations={sensor: [1.0, 0.0, 0.0]})

def test_hip_flexion_is_positive_with_the_thigh_forward():
    angles = calibrated_pose({"thigh_r": FORWARD_90, "thigh_l": FORWARD_90})
    assert angles["hip_r_flexion_deg"] == pytest.approx(90.0, abs=0.01)
    assert angles["hip_l_flexion_deg"] == pytest.approx(90.0, abs=0.01)


def test_knee_flexion_is_positive_with_the_shank_behind():
    angles = calibrated_pose({"shank_r": BACKWARD_60, "shank_l": BACKWARD_60})
    assert angles["knee_r_flexion_deg"] == pytest.approx(60.0, abs=0.01)
    assert angles["knee_l_flexion_deg"] == pytest.approx(60.0, abs=0.01)
    assert angles["hip_r_flexion_deg"] == pytest.approx(0.0, abs=0.01)


def test_elbow_flexion_is_positive_with_the_forearm_forward():
    angles = calibrated_pose({"forearm_r": FORWARD_90, "forearm_l": FORWARD_90})
    assert angles["elbow_r_flexion_deg"] == pytest.approx(90.0, abs=0.01)
    assert angles["elbow_l_flexion_deg"] == pytest.approx(90.0, abs=0.01)


def test_mirrored_movement_gives_equal_left_and_right_numbers():
    """A random pose of the right limbs and its mirror image (across the sagittal plane,
    M R M with M = diag(1, 1, −1)) on the left limbs."""
    rng = np.random.default_rng(31)
    mirror = np.diag([1.0, 1.0, -1.0])
    rotations = {}
    for right, left in (("upper_arm_r", "upper_arm_l"), ("forearm_r", "forearm_l"),
                        ("thigh_r", "thigh_l"), ("shank_r", "shank_l")):
        r = rot.to_matrix(rot.from_rotvec(rng.normal(scale=0.6, size=3)))
        rotations[right] = rot.from_matrix(r)
        rotations[left] = rot.from_matrix(mirror @ r @ mirror)
    angles = calibrated_pose(rotations)
    for joint in ("shoulder", "elbow", "hip", "knee"):
        for axis in ("flexion", "adduction", "rotation"):
            right, left = angles[f"{joint}_r_{axis}_deg"], angles[f"{joint}_l_{axis}_deg"]
            assert left == pytest.approx(right, abs=1e-6)
    assert max(abs(float(v)) for v in angles.values()) > 10.0


# --------------------------------------------------------------------------------------------
# Quality verdicts on bad poses
# --------------------------------------------------------------------------------------------

def test_moving_during_the_npose_is_refused_naming_the_sensor():
    mountings = random_mountings(TEN, seed=37)
    t, sensors, mapping, _ = suit_recording(0.0, mountings)
    wobble = np.where((t < 1.0)[:, None], rot.from_axis_angle(EX, np.radians(8.0) * np.sin(6 * t)), rot.identity())
    sensors[mapping["thigh_l"]] = rot.multiply(wobble, sensors[mapping["thigh_l"]])
    with pytest.raises(bc.CalibrationRefused, match=f"sensor {mapping['thigh_l']} moved during the N-pose") as info:
        bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)
    assert info.value.figures["max_deviation_deg"] > 3.0


def test_moving_arm_during_the_tpose_is_refused():
    mountings = random_mountings(TEN, seed=38)
    t, sensors, mapping, _ = suit_recording(0.0, mountings)
    wobble = np.where(((t > 2.0) & (t < 3.0))[:, None], rot.from_axis_angle(EY, np.radians(10.0) * np.sin(5 * t)), rot.identity())
    sensors[mapping["upper_arm_r"]] = rot.multiply(wobble, sensors[mapping["upper_arm_r"]])
    with pytest.raises(bc.CalibrationRefused, match="moved during the T-pose"):
        bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)


def test_slight_sway_is_acceptable_with_a_note():
    mountings = random_mountings(TEN, seed=39)
    t, sensors, mapping, _ = suit_recording(0.0, mountings)
    sway = np.where((t < 1.0)[:, None], rot.from_axis_angle(EX, np.radians(2.0) * np.sin(2 * np.pi * t)), rot.identity())
    sensors[mapping["pelvis"]] = rot.multiply(sway, sensors[mapping["pelvis"]])
    cal = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)
    assert cal.quality.verdict == "acceptable"
    assert any(mapping["pelvis"] in p and "still" in p for p in cal.quality.problems)


def test_arm_not_raised_is_refused():
    mountings = random_mountings(TEN, seed=41)
    t, sensors, mapping, _ = suit_recording(0.0, mountings, arm_angle_deg=10.0)
    with pytest.raises(bc.CalibrationRefused, match="was not raised"):
        bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)
    with pytest.raises(bc.CalibrationRefused, match="right arm .* was not raised"):
        bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE, arms="right")


@pytest.mark.parametrize(("angle", "verdict"), [(90.0, "good"), (62.0, "acceptable"), (45.0, "poor")])
def test_arm_rotation_angle_grades_the_verdict(angle, verdict):
    mountings = random_mountings(TEN, seed=43)
    t, sensors, mapping, _ = suit_recording(0.5, mountings, arm_angle_deg=angle)
    cal = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)
    assert cal.quality.verdict == verdict
    assert max(mounting_errors(cal, mountings).values()) < 0.5  # the axis is still right


def test_arms_raised_forward_instead_of_sideways_are_refused():
    mountings = random_mountings(TEN, seed=47)
    t, sensors, mapping, _ = suit_recording(0.0, mountings, arm_plane_deg=(90.0, 90.0))
    with pytest.raises(bc.CalibrationRefused, match="disagree by 180°"):
        bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)
    t, sensors, mapping, _ = suit_recording(0.0, mountings, arm_plane_deg=(0.0, 90.0))
    with pytest.raises(bc.CalibrationRefused, match="disagree by 90°"):
        bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)


ROTATION_AXIS = bc.BodyCalSettings(forward_from="rotation_axis")


@pytest.mark.parametrize("twist_deg", [40.0, -90.0])
def test_turning_the_arms_about_their_own_axis_does_not_bias_the_swing(twist_deg):
    """Humeral rotation during the raise (40° internal; −90°: palms forward in the T-pose).
    The arm's long axis still ends straight out to the side: the swing estimate is exact with
    one arm or both; the seed's rotation axis tilts and turns (by the reported
    ``axis_vs_swing_deg``, over 15°), so one arm alone misleads it; both arms' errors are
    mirror images and cancel."""
    mountings = random_mountings(TEN, seed=79)
    t, sensors, mapping, _ = suit_recording(2.0, mountings, arm_twist_deg=twist_deg)
    for arms in ("both", "right", "left"):
        cal = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE, arms=arms)
        assert max(mounting_errors(cal, mountings).values()) < 0.5
        for arm in cal.quality.arms:
            assert arm.raise_angle_deg == pytest.approx(90.0, abs=0.1)
            assert arm.rotation_angle_deg > 95.0
            assert arm.axis_tilt_deg > 15.0 and arm.axis_vs_swing_deg > 15.0
        assert cal.quality.verdict == "acceptable"
        assert any("turned about its own long axis" in p for p in cal.quality.problems)
    one = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE, arms="right", settings=ROTATION_AXIS)
    assert mounting_errors(one, mountings)["pelvis"] == pytest.approx(one.quality.arms[0].axis_vs_swing_deg, abs=0.1)
    if twist_deg == 40.0:
        both = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE, settings=ROTATION_AXIS)
        assert max(mounting_errors(both, mountings).values()) < 0.5
        assert both.quality.verdict == "poor"  # the two rotation axes disagree


@pytest.mark.parametrize(("tilt", "verdict"), [(8.0, "good"), (22.0, "acceptable"), (40.0, "poor")])
def test_rotation_axis_estimator_grades_the_axis_tilt(tilt, verdict):
    """Arms turned about an axis tilted from horizontal (a cone, not a vertical plane): the
    seed's estimator removes the vertical part and keeps the heading."""
    mountings = random_mountings(TEN, seed=53)
    t, sensors, mapping, _ = suit_recording(0.0, mountings, arm_tilt_deg=tilt)
    cal = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE, settings=ROTATION_AXIS)
    for arm in cal.quality.arms:
        assert arm.axis_tilt_deg == pytest.approx(tilt, abs=0.1)
    assert cal.quality.verdict == verdict
    assert max(mounting_errors(cal, mountings).values()) < 0.5


def test_swing_estimator_on_a_cone_sees_arms_off_the_frontal_plane():
    """The same cone ends each arm out of the frontal plane (mirror images): the swing
    estimates of the two arms disagree, their mean is right."""
    mountings = random_mountings(TEN, seed=53)
    t, sensors, mapping, _ = suit_recording(0.0, mountings, arm_tilt_deg=22.0)
    cal = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)
    assert max(mounting_errors(cal, mountings).values()) < 0.5
    assert cal.quality.left_right_disagreement_deg > 20.0
    assert cal.quality.verdict == "poor"


# --------------------------------------------------------------------------------------------
# Bad input
# --------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def recording():
    mountings = random_mountings(TEN, seed=59)
    return suit_recording(0.0, mountings)


def test_unknown_sensor_in_the_mapping(recording):
    t, sensors, mapping, _ = recording
    with pytest.raises(ValueError, match="unknown sensor 'S99' in the mapping .for segment pelvis"):
        bc.calibrate_npose_tpose(t, sensors, {**mapping, "pelvis": "S99"}, N_POSE, T_POSE)


def test_segment_without_a_sensor_and_sensor_used_twice(recording):
    t, sensors, mapping, _ = recording
    with pytest.raises(ValueError, match="segment 'thorax' has no sensor"):
        bc.calibrate_npose_tpose(t, sensors, {**mapping, "thorax": ""}, N_POSE, T_POSE)
    with pytest.raises(ValueError, match="mapped to two segments"):
        bc.calibrate_npose_tpose(t, sensors, {**mapping, "thorax": mapping["pelvis"]}, N_POSE, T_POSE)
    with pytest.raises(ValueError, match="unknown segment 'tail'"):
        bc.check_mapping({"tail": "S00"}, list(sensors), TEN.segment_names)


@pytest.mark.parametrize(("npose", "tpose", "message"), [
    ((-1.0, 0.5), T_POSE, "N-pose window -1:0.5 s lies outside the recording"),
    (N_POSE, (5.5, 7.0), "T-pose window 5.5:7 s lies outside the recording"),
    ((0.5, 0.2), T_POSE, "not an interval"),
    ((0.0, 2.5), T_POSE, "must start after the N-pose"),
    ((0.001, 0.002), T_POSE, "holds no sample"),
])
def test_bad_pose_windows(recording, npose, tpose, message):
    t, sensors, mapping, _ = recording
    with pytest.raises(ValueError, match=message):
        bc.calibrate_npose_tpose(t, sensors, mapping, npose, tpose)


def test_nan_quaternion_in_a_pose_window_names_the_sensor(recording):
    t, sensors, mapping, _ = recording
    broken = dict(sensors)
    broken[mapping["shank_r"]] = sensors[mapping["shank_r"]].copy()
    broken[mapping["shank_r"]][10] = np.nan
    with pytest.raises(ValueError, match=f"sensor {mapping['shank_r']}: NaN quaternion"):
        bc.calibrate_npose_tpose(t, broken, mapping, N_POSE, T_POSE)
    cal = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)
    with pytest.raises(ValueError, match="NaN quaternion"):
        bc.segment_orientations(cal, broken)


def test_no_arm_sensor_for_an_nt_calibration(recording):
    t, sensors, mapping, _ = recording
    legs = {s: mapping[s] for s in ("pelvis", "thigh_r", "shank_r")}
    with pytest.raises(ValueError, match="needs a sensor on an arm"):
        bc.calibrate_npose_tpose(t, sensors, legs, N_POSE, T_POSE)
    with pytest.raises(ValueError, match="no sensor on the left arm"):
        bc.calibrate_npose_tpose(t, sensors, {**legs, "upper_arm_r": mapping["upper_arm_r"]}, N_POSE, T_POSE, arms="both")


def test_settings_reject_negative_limits():
    with pytest.raises(ValueError, match="stillness_limit_deg"):
        bc.BodyCalSettings(stillness_limit_deg=-1.0)


# --------------------------------------------------------------------------------------------
# Live mapping, serialisation
# --------------------------------------------------------------------------------------------

def test_fill_missing_segments_follows_the_parent():
    q = rot.from_axis_angle(EY, 0.3)
    pairs = [(s.name, s.parent) for s in TEN.segments]
    filled = bc.fill_missing_segments({"pelvis": q, "thigh_r": rot.identity()}, pairs)
    assert set(filled) == set(TEN.segment_names)
    assert deg_between(filled["shank_r"], rot.identity()) < 1e-12
    assert deg_between(filled["forearm_l"], q) < 1e-12
    with pytest.raises(ValueError, match="segment pelvis has no sensor"):
        bc.fill_missing_segments({"thigh_r": q}, pairs)


def test_calibration_round_trips_through_its_dict(recording):
    t, sensors, mapping, _ = recording
    cal = bc.calibrate_npose_tpose(t, sensors, mapping, N_POSE, T_POSE)
    document = cal.to_dict()
    assert document["format"] == "mimucap-body-calibration"
    assert set(document["segments"]) == set(mapping)
    assert document["quality"]["arms"][0]["rotation_angle_deg"] == pytest.approx(90.0, abs=0.1)
    again = bc.BodyCalibration.from_dict(document)
    for s in mapping:
        assert deg_between(again.q_segment_from_sensor[s], cal.q_segment_from_sensor[s]) < 1e-9
    with pytest.raises(ValueError, match="not a MimuCap body calibration"):
        bc.BodyCalibration.from_dict({"format": "other"})
    bad = {**document, "segments": {"pelvis": {"sensor": "S00", "q_segment_from_sensor": [1, 2, 3, 4]}}}
    with pytest.raises(ValueError, match="segment pelvis: expected a unit quaternion"):
        bc.BodyCalibration.from_dict(bad)


# --------------------------------------------------------------------------------------------
# Real data: the OpenSense example (Xsens MTw, subject 07)
# --------------------------------------------------------------------------------------------

OPENSENSE_MAPPING = {
    "pelvis": "pelvis_imu", "thorax": "torso_imu", "thigh_r": "femur_r_imu", "thigh_l": "femur_l_imu",
    "shank_r": "tibia_r_imu", "shank_l": "tibia_l_imu", "foot_r": "calcn_r_imu", "foot_l": "calcn_l_imu",
}


@pytest.fixture
def opensense(shared_data) -> Path:
    return shared_data / "body" / "opensense_example"


@pytest.fixture
def facing_calibrations(opensense):
    from mimucap.io.orientation_inputs import read_quaternion_table

    result = {}
    for name in ("Facing_X", "Facing_negX"):
        table = read_quaternion_table(
            opensense / "test_resources" / f"MT_012005D6_009-quaternions_calibration_trial_{name}.sto")
        result[name] = bc.calibrate_heading(table.t_s, table.q_world_from_sensor, OPENSENSE_MAPPING,
                                            "pelvis_imu", EZ, up_world=table.up_world)
    return result


@pytest.mark.data("opensense")
def test_opensense_facing_x_and_negx_agree(facing_calibrations):
    """OpenSense's own test of these two trials allows 10° between the resulting IK angles.

    Measured here: the pelvis (heading reference) agrees within 3°, and the part of every leg
    segment's rotation that gravity fixes (the sensor-frame direction of the segment's long
    axis) within 3°. The remaining differences are rotations about the vertical, present in the
    raw data: relative to the pelvis sensor, the tibia sensors' headings differ by ~22° between
    the two files (see test_orientation_tables), which no heading-based calibration can remove.
    """
    x, neg = facing_calibrations["Facing_X"], facing_calibrations["Facing_negX"]
    assert x.quality.verdict == "good" and neg.quality.verdict == "good"
    assert deg_between(x.q_segment_from_sensor["pelvis"], neg.q_segment_from_sensor["pelvis"]) < 3.0
    for segment in ("pelvis", "thigh_r", "thigh_l", "shank_r", "shank_l", "foot_r", "foot_l"):
        long_axis_x = rot.rotate(rot.conjugate(x.q_segment_from_sensor[segment]), EY)
        long_axis_neg = rot.rotate(rot.conjugate(neg.q_segment_from_sensor[segment]), EY)
        assert np.degrees(np.arccos(np.clip(long_axis_x @ long_axis_neg, -1, 1))) < 3.0, segment


def knee_cycles(knee_deg):
    """Knee curves from one swing peak to the next, resampled to 51 points."""
    from scipy.signal import find_peaks

    peaks, _ = find_peaks(knee_deg, height=35.0, distance=60)
    cycles = [np.interp(np.linspace(0, 1, 51), np.linspace(0, 1, b - a + 1), knee_deg[a:b + 1])
              for a, b in zip(peaks[:-1], peaks[1:])]
    return peaks, np.array(cycles)


@pytest.mark.data("opensense")
def test_opensense_walking_knee_flexion_has_the_shape_of_normal_gait(opensense):
    """Calibrated on the first (standing) frame with heading from the pelvis sensor's +z.

    Independent reference (normal adult gait, e.g. Perry & Burnfield 2010, Winter 2009):
    knee flexion ~0–10° at heel strike, a loading-response flexion of ~15–20° just after,
    a peak of ~55–70° in swing.
    """
    from mimucap.io.orientation_inputs import read_quaternion_table

    folder = opensense
    table = read_quaternion_table(folder / "IMUData", sensor_names=folder / "myIMUMappings.xml")
    cal = bc.calibrate_heading(table.t_s, table.q_world_from_sensor, OPENSENSE_MAPPING, "pelvis_imu", EZ)
    angles = sk.joint_angles_deg(FIFTEEN, bc.segment_orientations(cal, table.q_world_from_sensor))
    for side in ("r", "l"):
        knee = angles[f"knee_{side}_flexion_deg"]
        peaks, cycles = knee_cycles(knee)
        assert len(peaks) >= 10  # ~24 s of walking
        stride_s = np.median(np.diff(table.t_s[peaks]))
        assert 0.9 < stride_s < 1.8
        assert 55.0 <= np.median(knee[peaks]) <= 70.0
        mean = cycles.mean(axis=0)
        strike = int(np.argmin(mean[:25]))  # knee extended at heel strike, after swing
        assert -5.0 <= mean[strike] <= 10.0
        loading = mean[strike:strike + 15].max() - mean[strike]
        assert loading >= 8.0  # the knee flexes under load after heel strike
        assert mean.max() == pytest.approx(np.median(knee[peaks]), abs=5.0)
        # Hip flexion is positive when the knee is most bent (swing): the signs agree.
        assert np.median(angles[f"hip_{side}_flexion_deg"][peaks]) > 10.0


def test_a_calibration_pose_with_bent_elbows_is_declared_per_segment():
    """Heading mode on a pose with the forearms forward (elbows at 90°): declaring
    q_segment_from_body for the forearms recovers their mountings; not declaring it is off by 90°."""
    mountings = random_mountings(TEN, seed=67)
    mountings["pelvis"] = rot.from_matrix(np.column_stack((EY, -EZ, -EX)))  # sensor -z forward
    t, sensors, mapping, _ = suit_recording(0.6, mountings)
    q_body = sk.q_world_from_body_facing(0.6)
    bent = rot.multiply(q_body, FORWARD_90)
    for side in ("l", "r"):
        sensors[mapping[f"forearm_{side}"]] = np.broadcast_to(
            rot.multiply(bent, mountings[f"forearm_{side}"]), sensors[mapping["pelvis"]].shape).copy()
    declared = {"forearm_l": rot.conjugate(FORWARD_90), "forearm_r": rot.conjugate(FORWARD_90)}
    cal = bc.calibrate_heading(t, sensors, mapping, mapping["pelvis"], -EZ, npose_s=N_POSE,
                               q_segment_from_body_npose=declared)
    assert max(mounting_errors(cal, mountings).values()) < 0.5
    plain = bc.calibrate_heading(t, sensors, mapping, mapping["pelvis"], -EZ, npose_s=N_POSE)
    assert mounting_errors(plain, mountings)["forearm_r"] == pytest.approx(90.0, abs=0.5)


def test_heading_mode_defaults_to_the_first_sample():
    mountings = random_mountings(TEN, seed=71)
    mountings["pelvis"] = rot.from_matrix(np.column_stack((EY, -EZ, -EX)))
    t, sensors, mapping, _ = suit_recording(-1.0, mountings)
    cal = bc.calibrate_heading(t, sensors, mapping, mapping["pelvis"], -EZ)
    assert cal.details["npose_s"] == [0.0, 0.0]
    assert all(s.n_samples == 1 for s in cal.quality.stillness)
    assert max(mounting_errors(cal, mountings).values()) < 0.5


# --------------------------------------------------------------------------------------------
# Building blocks
# --------------------------------------------------------------------------------------------

def test_fit_rotation_axis_is_the_least_squares_axis_through_the_origin():
    rng = np.random.default_rng(73)
    axis = rot.normalize(np.array([0.2, -0.3, 0.9, 0.0]))[:3]
    angles = np.linspace(0.1, 1.5, 40)
    rotvecs = angles[:, None] * axis + rng.normal(scale=0.01, size=(40, 3))
    fitted, residual = bc.fit_rotation_axis(rotvecs, -axis)
    assert np.degrees(np.arccos(abs(fitted @ axis))) < 1.0
    assert fitted @ axis < 0.0  # signed along the reference
    assert residual == pytest.approx(0.01 * np.sqrt(2.0), rel=0.3)


def test_pose_stillness_and_window():
    q = rot.from_axis_angle(EZ, np.radians([0.0, 1.0, 2.0, 3.0, 4.0]))
    mean, still = bc.pose_stillness(q, "N-pose", "S1")
    assert deg_between(mean, rot.from_axis_angle(EZ, np.radians(2.0))) < 1e-6
    assert still.max_deviation_deg == pytest.approx(2.0, abs=1e-6)
    assert still.rms_deviation_deg == pytest.approx(np.sqrt(2.0), abs=1e-6)
    t = np.arange(10) * 0.1
    assert bc.pose_window(t, (0.2, 0.5), "N-pose") == slice(2, 6)
    assert bc.pose_window(t, (0.0, 0.0), "N-pose") == slice(0, 1)


def test_body_frame_from_a_tilted_forward_axis():
    q = bc.q_world_from_body_from_forward([1.0, 1.0, 0.5], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(rot.rotate(q, EX), [np.sqrt(0.5), np.sqrt(0.5), 0.0], atol=1e-12)
    np.testing.assert_allclose(rot.rotate(q, EY), EZ, atol=1e-12)
    np.testing.assert_allclose(rot.rotate(q, EZ), [np.sqrt(0.5), -np.sqrt(0.5), 0.0], atol=1e-12)  # right
    with pytest.raises(ValueError, match="vertical"):
        bc.q_world_from_body_from_forward([0.0, 0.0, 1.0], [0.0, 0.0, 1.0])


def test_turned_toward_a_track_keeps_the_tilt_and_takes_its_share_of_the_heading():
    """A sensor tilted 20° whose static heading is 10° and whose track says 30° (± a degree of
    scatter): half the share gives 20°, the whole 30°, none 10°; the tilt stays."""
    tilt = rot.from_axis_angle([1.0, 0.0, 0.0], np.radians(20.0))
    static = rot.multiply(rot.from_axis_angle([0.0, 0.0, 1.0], np.radians(10.0)), tilt)
    scatter = np.radians([29.0, 31.0, 30.0])
    track = rot.multiply(np.stack([rot.from_axis_angle([0.0, 0.0, 1.0], a) for a in scatter]), tilt)
    for share, heading_deg in ((0.0, 10.0), (0.5, 20.0), (1.0, 30.0)):
        turned = bc.turned_toward(static, track, share)
        expected = rot.multiply(rot.from_axis_angle([0.0, 0.0, 1.0], np.radians(heading_deg)), tilt)
        assert abs(abs(float(np.dot(turned, expected))) - 1.0) < 1e-9, share
    np.testing.assert_allclose(bc.turned_toward(static, np.full((2, 4), np.nan), 1.0), static)
