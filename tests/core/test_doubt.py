"""Doubtful orientations (core.doubt): a sample is flagged where its orientation is wrong, and
left alone where the filter knows it is right. Synthetic sensors with known orientation: a
sensor turning about the vertical while rocking, its samples computed from the motion."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mimucap.core import bodycal, doubt, rotation, skeleton
from mimucap.core.fusion import FusionParams
from mimucap.core.magcal import MagCalibration
from mimucap.core.pipeline import (
    FILTER_BLOCK_SAMPLES, RESULT_LIVE, RESULT_REPROCESSED, LivePipeline, joint_reasons, process_recording,
    sensor_orientation,
)
from mimucap.core.samples import SensorSamples

RATE_HZ = 100.0
BUDGET_DEG = math.degrees(doubt.DEFAULT_DOUBT_SETTINGS.attitude_budget_rad)


def field_vector(norm_uT: float, dip_deg: float, azimuth_deg: float) -> np.ndarray:
    """A field (3,) µT in ENU of magnitude, dip (down) and azimuth (east of north)."""
    dip, azimuth = math.radians(dip_deg), math.radians(azimuth_deg)
    return norm_uT * np.array([math.cos(dip) * math.sin(azimuth), math.cos(dip) * math.cos(azimuth), -math.sin(dip)])


EARTH_UT = field_vector(49.3, 60.0, 0.0)
CALIBRATION = MagCalibration("S1", np.zeros(3), np.eye(3), 49.3, quality={"dip_mean_deg": 60.0})


def motion(duration_s: float, field_of=None, yaw_rate_of=None):
    """``t`` (N,), true ``q_world_from_sensor`` (N, 4), and the samples: ``gyr`` rad/s, ``acc``
    m/s², ``mag`` µT (sensor frame; ``field_of(t)`` (N, 3) the world field, default the earth's).
    The sensor turns about the vertical (``yaw_rate_of(t)`` rad/s, default 0.3) and rocks ±17°."""
    t = np.arange(0.0, duration_s, 1.0 / RATE_HZ)
    rate = np.full(len(t), 0.3) if yaw_rate_of is None else yaw_rate_of(t)
    yaw = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) / RATE_HZ)])
    zero = np.zeros(len(t))
    q = rotation.multiply(rotation.from_rotvec(np.c_[zero, zero, yaw]),
                          rotation.from_rotvec(np.c_[0.3 * np.sin(0.7 * t), zero, zero]))
    gyr = rotation.to_rotvec(rotation.multiply(rotation.conjugate(q[:-1]), q[1:])) * RATE_HZ
    gyr = np.vstack([gyr, gyr[-1]])
    acc = rotation.rotate(rotation.conjugate(q), np.array([0.0, 0.0, 9.81]))
    field = np.tile(EARTH_UT, (len(t), 1)) if field_of is None else field_of(t)
    return t, q, gyr, acc, rotation.rotate(rotation.conjugate(q), field)


def track(t, gyr, acc, mag, result=RESULT_LIVE, seq=None, calibration=CALIBRATION):
    return sensor_orientation(t, gyr, acc, mag, None, sensor_id="S1", result=result, mag_calibration=calibration,
                              seq=np.arange(len(t)) if seq is None else seq)


def names(reasons: np.ndarray) -> set[str]:
    return {name for value in np.unique(reasons) for name in doubt.reason_names(int(value))}


@pytest.mark.parametrize("result", [RESULT_LIVE, RESULT_REPROCESSED])
def test_a_heading_taken_from_a_foreign_field_is_doubted_wherever_it_is_wrong(result):
    """At 40 s the field turns 30° and its dip by 8°: within the filter's tolerances, so the
    filter follows it, and the heading drifts tens of degrees. Every sample off by more than
    the budget is flagged, for the field; before the change (after the filter settles) the
    forward result is trusted; the smoothed one carries the drift back and is doubted."""
    foreign = field_vector(49.3 * 0.95, 52.0, 30.0)
    t, q, gyr, acc, mag = motion(120.0, field_of=lambda t: np.where((t >= 40.0)[:, None], foreign, EARTH_UT))
    out = track(t, gyr, acc, mag, result)
    error_deg = np.degrees(rotation.angle_between(out.q_world_from_sensor, q))
    assert error_deg[t > 100].min() > 20.0  # the filter did follow the foreign field
    wrong = error_deg > BUDGET_DEG
    assert np.all(out.doubt[wrong] != 0)
    assert np.all(out.doubt[wrong] & doubt.FIELD_MISMATCH)
    before = (t > 10.0) & (t < 40.0)
    if result == RESULT_LIVE:
        assert np.all(out.doubt[before] == 0)
    else:
        assert np.all(out.doubt[before] & doubt.FIELD_MISMATCH)


def test_a_field_that_keeps_its_magnitude_and_dip_within_the_tolerance_is_trusted():
    t, q, gyr, acc, mag = motion(60.0, field_of=lambda t: np.where((t >= 20.0)[:, None], 1.03 * EARTH_UT, EARTH_UT))
    out = track(t, gyr, acc, mag)
    assert np.all(out.doubt[t > 10.0] == 0)
    assert np.degrees(rotation.angle_between(out.q_world_from_sensor, q))[t > 10.0].max() < BUDGET_DEG


def test_a_lost_magnetometer_is_bridged_for_a_while_then_doubted_before_the_heading_leaves_the_budget():
    t, q, gyr, acc, mag = motion(300.0)
    mag[t >= 60.0] = np.nan
    out = track(t, gyr, acc, mag)
    error_deg = np.degrees(rotation.angle_between(out.q_world_from_sensor, q))
    first = t[(t >= 60.0) & (out.doubt != 0)][0]
    assert first - 60.0 > 5.0  # the gyroscope bridges some seconds
    assert error_deg[(t >= 60.0) & (t < first)].max() < BUDGET_DEG
    assert names(out.doubt[t >= first]) == {"mag_missing"}


def test_the_bridge_time_follows_the_filter_settings_and_the_budget():
    """From the filter's steady state, the heading's 3 σ reach the budget after the bridge time;
    a gyroscope whose bias walks more is bridged for less, and a wider budget for longer."""
    default = FusionParams()
    bridge = doubt.bridge_time_s(default, 0.01)
    assert 10.0 < bridge < 600.0
    assert doubt.bridge_time_s(FusionParams(bias_walk_rad_s_sqrt_s=10 * default.bias_walk_rad_s_sqrt_s), 0.01) < bridge
    wider = doubt.DoubtSettings(attitude_budget_rad=math.radians(10.0))
    assert doubt.bridge_time_s(default, 0.01, wider) > bridge
    assert 60.0 < doubt.smoother_memory_s(default, 0.01) < math.inf


def test_rotation_lost_with_dropped_samples_is_doubted_where_it_matters():
    """Samples dropped while the turning rate jumps lose rotation (the filter integrates the
    rates at the gap's ends): flagged, and wherever the heading is wrong beyond the budget.
    The same gap at a steady rate loses nothing and is not flagged."""
    step = lambda t: np.where(t < 30.0, 0.0, 2.0)  # noqa: E731
    t, q, gyr, acc, mag = motion(60.0, yaw_rate_of=step)
    keep = ~((t > 29.9) & (t < 30.2))
    out = track(t[keep], gyr[keep], acc[keep], mag[keep], seq=np.flatnonzero(keep))
    after = np.flatnonzero(t[keep] >= 30.2)[0]
    assert out.doubt[after] & doubt.LOST_SAMPLES
    error_deg = np.degrees(rotation.angle_between(out.q_world_from_sensor, q[keep]))
    assert error_deg.max() > BUDGET_DEG  # the gap did cost rotation
    assert np.all(out.doubt[error_deg > BUDGET_DEG] != 0)

    t, q, gyr, acc, mag = motion(60.0)
    out = track(t[keep], gyr[keep], acc[keep], mag[keep], seq=np.flatnonzero(keep))
    assert np.all(out.doubt[t[keep] > 10.0] == 0)


def test_an_uncalibrated_magnetometer_and_an_onboard_calibration_at_zero_are_standing_reasons():
    t, _q, gyr, acc, mag = motion(10.0)
    assert np.all(track(t, gyr, acc, mag, calibration=None).doubt & doubt.MAG_UNCALIBRATED)
    status = np.tile([3, 3, 1, 3], (len(t), 1)).astype(np.int8)
    status[: len(t) // 2, 3] = 0  # magnetometer not calibrated yet, then calibrated
    onboard = sensor_orientation(t, None, None, None, rotation.identity((len(t),)), sensor_id="S1", status=status)
    assert np.all(onboard.doubt[: len(t) // 2] == doubt.ONBOARD_UNCALIBRATED)
    assert np.all(onboard.doubt[len(t) // 2:] == 0)


def test_the_live_pipeline_gives_the_reasons_of_the_recording_processed_as_seen_live():
    foreign = field_vector(49.3 * 0.95, 52.0, 30.0)
    t, _q, gyr, acc, mag = motion(60.0, field_of=lambda t: np.where((t >= 30.0)[:, None], foreign, EARTH_UT))
    batch = track(t, gyr, acc, mag)
    live = LivePipeline(skeleton.load_model())
    live.set_mag_calibration(CALIBRATION)
    seq = np.arange(len(t))
    reasons = []
    for start in range(0, len(t), FILTER_BLOCK_SAMPLES):
        rows = slice(start, start + FILTER_BLOCK_SAMPLES)
        (out,) = live.feed([SensorSamples("S1", t[rows], seq[rows], acc=acc[rows], gyr=gyr[rows], mag_uT=mag[rows])])
        reasons.append(out.doubt)
    assert np.array_equal(np.concatenate(reasons), batch.doubt)
    assert live.doubts["S1"] == int(batch.doubt[-1]) != 0


def test_the_smoothed_terms_carry_a_later_pull_back_and_a_lost_step_as_it_decays():
    n = 1000
    t = np.arange(n) / RATE_HZ
    zero = np.zeros(n)
    pull = zero.copy()
    pull[800] = math.radians(20.0)
    gain = np.full(n, 0.01)
    terms = doubt.DoubtTerms(t, zero, zero, zero, pull, pull, gain, np.zeros(n, bool),
                             np.zeros(n, doubt.DOUBT_DTYPE), np.full(n, doubt.SETTLING, doubt.DOUBT_DTYPE))
    smoothed = terms.smoothed(memory_s=300.0)
    assert smoothed.field[0] > math.radians(19.0)  # 8 s before, at a 300 s memory
    assert math.radians(17.0) < smoothed.lost[790] < math.radians(20.0) and smoothed.lost[0] < 1e-3
    assert np.all(smoothed.reasons()[:800] & doubt.FIELD_MISMATCH)


def test_reasons_at_pose_instants_joints_and_windows():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    reasons = np.array([0, doubt.LOST_SAMPLES, 0, 0], dtype=doubt.DOUBT_DTYPE)
    at = doubt.at_instants(np.array([-1.0, 0.5, 1.5, 2.5, 3.2, 9.0]), t, reasons, hold_s=0.5)
    assert list(at) == [doubt.NO_ORIENTATION, doubt.LOST_SAMPLES, doubt.LOST_SAMPLES, 0, 0, doubt.LOST_SAMPLES]
    model = skeleton.load_model()
    sensors = {"S1": "thigh_r", "S2": "shank_r", "S3": "pelvis"}
    tracks = {"S1": (t, reasons), "S2": (t, np.zeros(4, doubt.DOUBT_DTYPE)), "S3": (t, np.zeros(4, doubt.DOUBT_DTYPE))}
    found = joint_reasons(model, t, sensors, tracks, None)
    assert set(found) == {"hip_r", "knee_r"}
    assert list(found["knee_r"]) == [doubt.NO_BODY_CALIBRATION | r for r in (0, doubt.LOST_SAMPLES, 0, 0)]
    gyr = np.zeros((6, 3))
    gyr[1:3, 2] = 3.0  # being strapped on until 1 s, then still
    off = doubt.off_body(np.arange(6.0) * 0.5, [(0.0, 0.75)], gyr, 0.1, 1.0)
    assert list(off) == [doubt.OFF_BODY] * 4 + [0, 0]  # still for 1 s at 2 s
    assert list(doubt.singular(np.array([0.0, 59.0, 61.0, -89.0]), proper=False)) == [0, 0, doubt.SINGULAR, doubt.SINGULAR]
    assert list(doubt.singular(np.array([5.0, 90.0, 175.0]), proper=True)) == [doubt.SINGULAR, 0, doubt.SINGULAR]
    assert doubt.spans(np.arange(6.0), np.array([0, 1, 1, 0, 0, 4])) == [(1.0, 2.0, 1), (5.0, 5.0, 4)]
    assert doubt.spans(np.arange(6.0), np.array([0, 1, 0, 4, 0, 0]), join_s=2.5) == [(1.0, 3.0, 5)]
    assert doubt.describe(doubt.FIELD_MISMATCH | doubt.MAG_UNCALIBRATED).startswith("magnetometer not calibrated; ")


def test_a_body_calibration_made_from_doubtful_orientations_says_so_and_makes_every_joint_doubtful():
    q = rotation.identity()
    calibration = bodycal.BodyCalibration(q, np.array([0.0, 0.0, 1.0]), {"thigh_r": "S1", "shank_r": "S2"},
                                          {"thigh_r": q, "shank_r": q}, bodycal.CalibrationQuality("npose_tpose", ()))
    doubtful = bodycal.with_doubtful_sensors(calibration, {"S2": "samples lost"})
    assert doubtful.quality.verdict == "acceptable" and doubtful.quality.doubtful_sensors == ("S2",)
    assert "S2 (samples lost)" in doubtful.quality.problems[-1]
    again = bodycal.BodyCalibration.from_dict(doubtful.to_dict())
    assert again.quality.doubtful_sensors == ("S2",)
    assert bodycal.with_doubtful_sensors(calibration, {}) is calibration
    t = np.arange(3.0)
    streams = {sid: SensorSamples(sid, t, np.arange(3), q_world_from_sensor=rotation.identity((3,))) for sid in ("S1", "S2")}
    out = process_recording(streams, skeleton.load_model(), body_calibration=again)
    assert np.all(out.joint_doubt["knee_r"] == doubt.BODY_CALIBRATION_DOUBTFUL)
