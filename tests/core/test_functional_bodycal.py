"""Functional body calibration on recordings built from known joint angles and mountings:
standing still, then walking (pure hinges at knees, elbows and ankles), facing any way; the
signs, the walking direction, the verdict's words, refusals."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core import bodycal as bc
from mimucap.core import functional_bodycal as fb
from mimucap.core import rotation as rot
from mimucap.core import skeleton as sk

TEN = sk.load_model("ten_segment")
FIFTEEN = sk.load_model("fifteen_segment")
RATE_HZ = 100.0
STILL = (0.0, 0.99)
MOVEMENT = (1.5, 10.99)
EX, EY, EZ = np.eye(3)


def deg_between(q1, q2):
    return float(np.degrees(rot.angle_between(q1, q2)))


def walking_angles(t, stride_s=1.1, knee_peak_deg=60.0, elbow=True):
    """Joint angles (deg) of a walk starting at 1 s (zero before): hips flex and extend, abduct
    and rotate a little; knees, elbows and ankles are pure hinges (knees and elbows flex one
    way only from standing, ankles both ways); the left side half a stride later."""
    n = t.size
    ramp = np.clip(t - 1.0, 0.0, 1.0)
    angles = {}
    for side, shift in (("r", 0.0), ("l", 0.5)):
        phase = 2 * np.pi * ((t / stride_s + shift) % 1.0)
        hip = np.column_stack((10 + 20 * np.cos(phase), 5 * np.sin(phase + 0.6), 4 * np.cos(phase)))
        knee = np.zeros((n, 3))
        knee[:, 0] = knee_peak_deg * 0.5 * (1 - np.cos(phase)) ** 2 / 2
        ankle = np.zeros((n, 3))
        ankle[:, 0] = 12 * np.sin(phase + 1.0)
        angles[f"hip_{side}"] = ramp[:, None] * hip
        angles[f"knee_{side}"] = ramp[:, None] * knee
        angles[f"ankle_{side}"] = ramp[:, None] * ankle
        angles[f"shoulder_{side}"] = ramp[:, None] * np.column_stack((20 * np.cos(phase + np.pi), np.full(n, -5.0),
                                                                      np.zeros(n)))
        if elbow:
            elbow_angles = np.zeros((n, 3))
            elbow_angles[:, 0] = 25 + 15 * np.cos(phase + np.pi)
            angles[f"elbow_{side}"] = ramp[:, None] * elbow_angles
    angles["lumbar"] = ramp[:, None] * np.column_stack((np.full(n, 2.0), np.zeros(n), 3 * np.sin(2 * np.pi * t / stride_s)))
    return angles


def walking_recording(heading_rad, mountings, model=TEN, turn_dps=0.0, seconds=11.0, **kwargs):
    """Standing still (0-1 s) facing ``heading_rad``, then walking (turning at ``turn_dps``);
    the pelvis yaws ±5° about the line of progression. Returns ``t``, sensor orientations,
    mapping (segment → sensor), true segment orientations and joint angles."""
    t = np.arange(0.0, seconds, 1.0 / RATE_HZ)
    heading = heading_rad + np.radians(turn_dps) * np.clip(t - 1.0, 0.0, None)
    yaw = np.radians(5.0) * np.sin(2 * np.pi * t / 1.1) * np.clip(t - 1.0, 0.0, 1.0)
    q_root = rot.multiply(sk.q_world_from_body_facing(heading), rot.from_axis_angle(EY, yaw))
    angles = {joint: a for joint, a in walking_angles(t, **kwargs).items() if joint in model.joint_names}
    segments = sk.segment_orientations_from_joint_angles(model, q_root, angles)
    sensors = {f"S{i:02d}": rot.multiply(segments[s], mountings[s]) for i, s in enumerate(model.segment_names)}
    mapping = {s: f"S{i:02d}" for i, s in enumerate(model.segment_names)}
    return t, sensors, mapping, segments, angles


def random_mountings(model, seed):
    rng = np.random.default_rng(seed)
    return {s: rot.normalize(rng.normal(size=4)) for s in model.segment_names}


@pytest.mark.parametrize(("heading_deg", "seed", "turn_dps"), [(0.0, 1, 0.0), (130.0, 2, 0.0), (-75.0, 3, 20.0)])
def test_every_segment_of_a_walk_is_recovered(heading_deg, seed, turn_dps):
    mountings = random_mountings(TEN, seed)
    t, sensors, mapping, segments, _ = walking_recording(np.radians(heading_deg), mountings, turn_dps=turn_dps)
    cal = fb.calibrate_functional(t, sensors, mapping, STILL, MOVEMENT)
    assert cal.quality.method == "functional" and cal.quality.verdict == "good", cal.quality.problems
    for segment in TEN.segment_names:
        # hinge segments exactly; pelvis and thorax face the walking direction within a degree
        limit = 1.0 if segment in ("pelvis", "thorax") else 0.05
        assert deg_between(cal.q_segment_from_sensor[segment], mountings[segment]) < limit, segment
    assert cal.quality.axis_sources["thigh_r"] == "knee_r" and cal.quality.axis_sources["forearm_l"] == "elbow_l"
    assert cal.quality.axis_sources["pelvis"] == fb.WALKING_DIRECTION
    assert cal.quality.walking_direction_from == ("knee_l", "knee_r")
    assert deg_between(cal.q_world_from_body, sk.q_world_from_body_facing(np.radians(heading_deg))) < 1.0
    knee = next(h for h in cal.quality.hinges if h.joint == "knee_r")
    assert knee.flexion_low_deg == pytest.approx(0.0, abs=1.0) and knee.flexion_high_deg > 45.0
    assert knee.residual_deg < 0.01 and knee.halves_deg < 0.01
    # the joint angles computed with it are the walk's
    angles = sk.joint_angles_deg(TEN, bc.segment_orientations(cal, sensors))
    truth = sk.joint_angles_deg(TEN, segments)
    for column in ("knee_r_flexion_deg", "knee_l_flexion_deg", "hip_r_flexion_deg", "elbow_l_flexion_deg"):
        assert np.max(np.abs(angles[column] - truth[column])) < 1.0, column


def test_feet_take_the_ankle_axis_signed_by_the_shank():
    """The ankle flexes both ways from standing: its sign comes from the shank's lateral axis."""
    mountings = random_mountings(FIFTEEN, 8)
    t, sensors, mapping, _, _ = walking_recording(np.radians(40.0), mountings, model=FIFTEEN)
    legs = {s: mapping[s] for s in ("pelvis", "thigh_l", "thigh_r", "shank_l", "shank_r", "foot_l", "foot_r")}
    cal = fb.calibrate_functional(t, sensors, legs, STILL, MOVEMENT)
    for side in "lr":
        assert cal.quality.axis_sources[f"foot_{side}"] == f"ankle_{side}"
        assert deg_between(cal.q_segment_from_sensor[f"foot_{side}"], mountings[f"foot_{side}"]) < 0.05
    ankle = next(h for h in cal.quality.hinges if h.joint == "ankle_l")
    assert ankle.flexion_low_deg < -8.0 and ankle.flexion_high_deg > 8.0  # dorsi- and plantarflexion


def test_without_legs_the_elbows_give_the_forward_direction():
    """Seated, only the arms move: the elbows flex from hanging."""
    mountings = random_mountings(TEN, 9)
    t, sensors, mapping, _, _ = walking_recording(np.radians(200.0), mountings)
    upper = {s: mapping[s] for s in ("thorax", "upper_arm_l", "upper_arm_r", "forearm_l", "forearm_r")}
    cal = fb.calibrate_functional(t, sensors, upper, STILL, MOVEMENT)
    assert cal.quality.walking_direction_from == ("elbow_l", "elbow_r")
    for segment in upper:
        assert deg_between(cal.q_segment_from_sensor[segment], mountings[segment]) < (1.5 if segment == "thorax" else 0.05)


def test_a_knee_that_did_not_bend_is_named_and_its_segments_face_the_walking_direction():
    mountings = random_mountings(TEN, 10)
    t, sensors, mapping, _, _ = walking_recording(0.3, mountings, knee_peak_deg=4.0)
    cal = fb.calibrate_functional(t, sensors, mapping, STILL, MOVEMENT)
    assert cal.quality.verdict == "acceptable"
    knee = next(h for h in cal.quality.hinges if h.joint == "knee_r")
    assert not knee.used and "moved only" in knee.note
    assert cal.quality.axis_sources["thigh_r"] == fb.WALKING_DIRECTION
    assert cal.quality.walking_direction_from == ("elbow_l", "elbow_r")
    assert any("Right knee axis not defined by the movement: it moved only" in p and "the right thigh and right shank face the "
               "walking direction" in p for p in cal.quality.problems)
    # its verdict says so, axis by axis
    axes = {axis.axis: axis for axis in cal.quality.axes}
    assert axes["knee_r"].verdict == fb.NOT_DEFINED and "it moved only" in axes["knee_r"].words
    assert axes["thigh_r"].verdict == "good" and axes["thigh_r"].words.startswith("Right thigh forward direction good: it faces the walking")
    assert axes["elbow_l"].verdict == "good" and axes["elbow_l"].segments == ("upper_arm_l", "forearm_l")


def test_the_verdict_names_a_weakly_defined_axis():
    mountings = random_mountings(TEN, 11)
    t, sensors, mapping, _, _ = walking_recording(0.0, mountings, knee_peak_deg=14.0)
    cal = fb.calibrate_functional(t, sensors, mapping, STILL, MOVEMENT)
    assert cal.quality.verdict == "acceptable"
    assert any(p.startswith("the left knee moved only 14°") for p in cal.quality.problems), cal.quality.problems
    knee = next(axis for axis in cal.quality.axes if axis.axis == "knee_l")
    assert knee.verdict == "acceptable" and knee.words.startswith("Left knee axis acceptable: it bent")
    assert "the left knee moved only 14°: its axis is weakly defined" in knee.words
    assert next(axis for axis in cal.quality.axes if axis.axis == "elbow_l").verdict == "good"


def test_nothing_bent_is_refused_naming_the_joints():
    mountings = random_mountings(TEN, 12)
    t, sensors, mapping, _, _ = walking_recording(0.0, mountings, knee_peak_deg=3.0, elbow=False)
    with pytest.raises(bc.CalibrationRefused, match=r"no knee or elbow flexion axis.*knee_l: it moved only"):
        fb.calibrate_functional(t, sensors, mapping, STILL, MOVEMENT)


def test_moving_while_standing_is_refused():
    mountings = random_mountings(TEN, 13)
    t, sensors, mapping, _, _ = walking_recording(0.0, mountings)
    with pytest.raises(bc.CalibrationRefused, match="moved during the quiet standing"):
        fb.calibrate_functional(t, sensors, mapping, (0.5, 2.0), (3.0, 10.99))
    with pytest.raises(ValueError, match="overlap"):
        fb.calibrate_functional(t, sensors, mapping, (0.0, 0.9), (0.5, 10.99))
    with pytest.raises(ValueError, match="movement window 5:20 s lies outside the recording"):
        fb.calibrate_functional(t, sensors, mapping, STILL, (5.0, 20.0))


def test_the_rate_estimator_gives_the_same_frames_on_pure_hinges():
    mountings = random_mountings(TEN, 14)
    t, sensors, mapping, _, _ = walking_recording(1.0, mountings)
    cal = fb.calibrate_functional(t, sensors, mapping, STILL, MOVEMENT, settings=fb.FunctionalSettings(hinge_from="rates"))
    assert cal.details["hinge_from"] == "rates"
    for segment in ("thigh_l", "shank_r", "forearm_r"):
        assert deg_between(cal.q_segment_from_sensor[segment], mountings[segment]) < 0.1, segment


def test_still_orientations_replace_the_long_axis_and_the_document_round_trips():
    mountings = random_mountings(TEN, 15)
    t, sensors, mapping, _, _ = walking_recording(0.0, mountings)
    tilted = rot.multiply(rot.from_axis_angle(EX, np.radians(3.0)), sensors["S00"][0])  # pelvis sensor
    cal = fb.calibrate_functional(t, sensors, mapping, STILL, MOVEMENT, still_orientations={"S00": tilted})
    assert cal.details["still_track_vs_given_deg"] == {"S00": pytest.approx(3.0, abs=1e-6)}
    assert deg_between(cal.q_segment_from_sensor["pelvis"], mountings["pelvis"]) == pytest.approx(3.0, abs=0.6)
    document = cal.to_dict()
    assert document["method"] == "functional" and document["still_s"] == [0.0, 0.99]
    assert {h["joint"] for h in document["quality"]["hinges"]} == {"knee_l", "knee_r", "elbow_l", "elbow_r"}
    assert document["quality"]["axis_sources"]["pelvis"] == "walking direction"
    again = bc.BodyCalibration.from_dict(document)
    assert again.quality.method == "functional"
    assert deg_between(again.q_segment_from_sensor["shank_l"], cal.q_segment_from_sensor["shank_l"]) < 1e-9


def test_the_first_still_window():
    mountings = random_mountings(TEN, 16)
    t, sensors, *_ = walking_recording(0.0, mountings)
    assert fb.first_still_window(t, sensors) == (0.0, pytest.approx(1.0))
    with pytest.raises(ValueError, match="no 1 s in which every sensor stayed within"):
        fb.first_still_window(t[150:], {k: q[150:] for k, q in sensors.items()})


def test_settings_are_checked():
    with pytest.raises(ValueError, match="hinge_from must be one of orientations, rates"):
        fb.FunctionalSettings(hinge_from="magic")
    with pytest.raises(ValueError, match="halves_good_deg must be a finite non-negative"):
        fb.FunctionalSettings(halves_good_deg=-1.0)


def test_elbow_flexions_with_the_upper_arms_still():
    """Seated, upper arms hanging still, the elbows flexed to 90° a few times: the sensors'
    heading disagreement cannot be seen (the upper arm keeps its orientation), so their
    headings are taken as they are, and the axes come out exact."""
    mountings = random_mountings(TEN, 17)
    t = np.arange(0.0, 8.0, 0.01)
    flexion = 45.0 * (1 - np.cos(2 * np.pi * np.clip(t - 1.0, 0.0, None) / 1.5))
    angles = {f"elbow_{s}": np.column_stack((flexion, np.zeros_like(t), np.zeros_like(t))) for s in "lr"}
    q_body = np.broadcast_to(sk.q_world_from_body_facing(2.0), (t.size, 4))
    segments = sk.segment_orientations_from_joint_angles(TEN, q_body, angles)
    upper = ("thorax", "upper_arm_l", "upper_arm_r", "forearm_l", "forearm_r")
    sensors = {s: rot.multiply(segments[s], mountings[s]) for s in upper}
    cal = fb.calibrate_functional(t, sensors, {s: s for s in upper}, STILL, (1.0, 7.99))
    assert cal.quality.verdict == "good", cal.quality.problems
    elbow = next(h for h in cal.quality.hinges if h.joint == "elbow_r")
    assert elbow.heading_offset_deg is None and elbow.flexion_high_deg > 85.0
    for segment in upper:
        assert deg_between(cal.q_segment_from_sensor[segment], mountings[segment]) < 0.05, segment
