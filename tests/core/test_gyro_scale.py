"""The gyroscope's scale and cross-axis correction from the magnetometer-calibration turns
(:mod:`mimucap.core.magcal.gyro_scale`), its place in the calibration record, and the chain that
applies it before the filter. The synthetic turns below have a known gyroscope error, the
independent reference."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.core.magcal.calibrate import calibrate
from mimucap.core.magcal.gyro_scale import estimate_gyro_scale, rates_at
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.pipeline.chain import SensorChain
from mimucap.core.sensor_samples import SensorSamples
from mimucap.io.calibration_store import calibration_from_json, calibration_to_json

RATE_HZ = 100.0
FIELD_WORLD_UT = np.array([0.0, 22.0, -42.0])     # ENU, dip about 62°
#: The gyroscope's true error: ω_raw = GYR_SCALE @ ω + bias (1-2 % scale, 0.3 % cross-axis).
GYR_SCALE = np.array([[1.012, 0.003, -0.002], [0.0, 0.985, 0.003], [0.002, -0.003, 1.008]])
GYR_BIAS = np.radians([0.8, -1.2, 0.5])


def turns(axes: str = "xyz", seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``t_s`` (N,) and ``q_world_from_sensor`` (N, 4) of a hand turning a unit one full turn
    (6 s) about each sensor axis in ``axes``, wobbling a few degrees, with a still second between."""
    rng = np.random.default_rng(seed)
    q = rot.from_euler(np.radians([20.0, 10.0, -15.0]), "ZXY")
    rows = [q]
    phases = np.cumsum(rng.uniform(0, 2 * np.pi, size=6))
    for axis in axes:
        unit = np.eye(3)["xyz".index(axis)]
        for k in range(int(7.0 * RATE_HZ)):
            s = k / RATE_HZ
            turning = 2 * np.pi / 6.0 * (1.0 - np.cos(2 * np.pi * s / 6.0)) if s < 6.0 else 0.0
            wobble = 0.3 * np.sin(2.1 * s + phases[:3]) * (s < 6.0)
            q = rot.normalize(rot.multiply(q, rot.from_rotvec((turning * unit + wobble) / RATE_HZ)))
            rows.append(q)
    q = np.array(rows)
    return np.arange(len(q)) / RATE_HZ, q


def measured(q: np.ndarray, seed: int = 1, gyr_scale: np.ndarray = GYR_SCALE) -> tuple[np.ndarray, np.ndarray]:
    """Raw gyroscope (rad/s; each sample the mean rate over the interval ending at it, as the
    filter takes it) and field (µT, sensor frame) with noise."""
    rng = np.random.default_rng(seed)
    omega = rot.to_rotvec(rot.multiply(rot.conjugate(q[:-1]), q[1:])) * RATE_HZ
    omega = np.vstack([np.zeros(3), omega])
    gyr = omega @ gyr_scale.T + GYR_BIAS + rng.normal(0.0, np.radians(0.1), size=omega.shape)
    mag = rot.rotate(rot.conjugate(q), np.broadcast_to(FIELD_WORLD_UT, (len(q), 3)))
    return gyr, mag + rng.normal(0.0, 0.3, size=mag.shape)


def test_known_scale_and_cross_axis_errors_are_recovered_within_a_fifth_of_a_percent():
    t, q = turns()
    gyr, mag = measured(q)
    estimate = estimate_gyro_scale(t, gyr, mag)
    assert estimate.applied and estimate.reason == "", estimate.reason
    undone = estimate.correction @ GYR_SCALE
    np.testing.assert_allclose(undone, np.eye(3), atol=0.002)
    assert np.all(estimate.turned_deg > 340.0)
    assert estimate.std.max() < 0.002
    figures = estimate.as_dict()
    assert figures["applied"] is True and figures["scale_error_pct"][1] == pytest.approx(-1.5, abs=0.2)
    assert "scale off by x +1.2" in estimate.summary() and estimate.summary().endswith(": corrected")


def test_a_magnetometer_slower_than_the_gyroscope_and_joined_recordings():
    """Field samples on every other row (a 50-Hz magnetometer beside a 100-Hz gyroscope) and two
    recordings of the turns joined with their clocks restarting: the same correction."""
    t, q = turns()
    gyr, mag = measured(q)
    mag[1::2] = np.nan
    estimate = estimate_gyro_scale(t, gyr, mag)
    assert estimate.applied, estimate.reason
    np.testing.assert_allclose(estimate.correction @ GYR_SCALE, np.eye(3), atol=0.003)
    half = len(t) // 2
    restarted = np.concatenate([t[:half], t[half:] - t[half]])
    joined = estimate_gyro_scale(restarted, gyr, measured(q)[1])
    assert joined.applied, joined.reason
    np.testing.assert_allclose(joined.correction @ GYR_SCALE, np.eye(3), atol=0.003)


def test_a_magnetometer_on_its_own_clock_gets_the_gyroscope_s_mean_rates():
    """A magnetometer sampled at jittery instants of its own (about 70 Hz) beside the 100-Hz
    gyroscope: the gyroscope's mean rate over each field interval gives the same correction."""
    t, q = turns()
    gyr, _ = measured(q)
    rng = np.random.default_rng(5)
    t_field = np.cumsum(rng.uniform(0.007, 0.021, size=int(t[-1] / 0.014)))
    t_field = t_field[t_field < t[-1]]
    q_field = rot.slerp(q[np.searchsorted(t, t_field) - 1], q[np.searchsorted(t, t_field)],
                        (t_field - t[np.searchsorted(t, t_field) - 1]) * RATE_HZ)
    mag = rot.rotate(rot.conjugate(q_field), np.broadcast_to(FIELD_WORLD_UT, (len(t_field), 3)))
    mag = mag + rng.normal(0.0, 0.3, size=mag.shape)
    rates = rates_at(t_field, t, gyr)
    assert np.all(np.isnan(rates[0])) and np.all(np.isfinite(rates[1:]))
    estimate = estimate_gyro_scale(t_field, rates, mag)
    assert estimate.applied, estimate.reason
    np.testing.assert_allclose(estimate.correction @ GYR_SCALE, np.eye(3), atol=0.003)


def test_turns_about_two_axes_only_keep_the_identity_and_say_which_axis():
    t, q = turns("xy")
    gyr, mag = measured(q)
    estimate = estimate_gyro_scale(t, gyr, mag)
    assert not estimate.applied
    np.testing.assert_array_equal(estimate.correction, np.eye(3))
    assert estimate.reason.startswith("too little rotation about z "), estimate.reason
    assert "not corrected: too little rotation about z" in estimate.summary()


def test_a_field_that_does_not_follow_the_rotation_is_not_believed():
    """The field of a unit turned near iron (here: a field that turns with the sensor) gives no
    usable estimate; the identity is kept."""
    t, q = turns()
    gyr, mag = measured(q)
    mag = np.broadcast_to(mag[0], mag.shape) + np.random.default_rng(3).normal(0.0, 0.3, size=mag.shape)
    estimate = estimate_gyro_scale(t, gyr, mag)
    assert not estimate.applied and estimate.reason
    np.testing.assert_array_equal(estimate.correction, np.eye(3))


def test_too_few_samples_keep_the_identity():
    t, q = turns("x")
    gyr, mag = measured(q)
    estimate = estimate_gyro_scale(t[:200], gyr[:200], mag[:200])
    assert not estimate.applied and "too few samples" in estimate.reason


def test_the_calibration_carries_the_correction_and_round_trips():
    t, q = turns()
    gyr, mag = measured(q)
    mag_raw = mag @ np.diag([1.05, 0.97, 1.0]).T + np.array([10.0, -20.0, 5.0])
    result = calibrate(mag_raw, "S01", t_s=t, gyr_raw_rad_s=gyr)
    calibration = result.calibration
    assert calibration.corrects_gyr and calibration.gyr_quality["applied"] is True
    np.testing.assert_allclose(calibration.gyr_correction @ GYR_SCALE, np.eye(3), atol=0.003)
    back = calibration_from_json(calibration_to_json(calibration), "test")
    np.testing.assert_array_equal(back.gyr_correction, calibration.gyr_correction)
    assert back.gyr_quality == calibration.gyr_quality
    # without the gyroscope's samples: the identity, and why
    plain = calibrate(mag_raw, "S01").calibration
    assert not plain.corrects_gyr and plain.gyr_quality["reason"] == "no gyroscope samples with the magnetometer's"


def test_a_calibration_written_before_the_correction_loads_with_the_identity():
    data = calibration_to_json(MagCalibration("S01", np.zeros(3), np.eye(3), 49.0))
    data["format_version"] = 2
    del data["gyr_correction"], data["gyr_quality"]
    old = calibration_from_json(data, "old.json")
    np.testing.assert_array_equal(old.gyr_correction, np.eye(3))
    assert not old.corrects_gyr and old.gyr_quality["applied"] is False and "before" in old.gyr_quality["reason"]
    with pytest.raises(ValueError, match="gyr_correction"):
        MagCalibration("S01", np.zeros(3), np.eye(3), 49.0, gyr_correction=np.diag([1.0, 1.0, -1.0]))


def test_the_chain_fuses_corrected_rates():
    """Ten turns about the vertical, fused without a magnetometer: a gyroscope reading 3 % high
    turns the heading by 108°; the chain whose calibration carries the correction stays on the
    true heading, forward (live blocks) and reprocessed."""
    n = int(10 * 4.0 * RATE_HZ) + 200
    t = np.arange(n) / RATE_HZ
    rate = np.where((t > 1.0) & (t <= 41.0), 2 * np.pi / 4.0, 0.0)
    scale = np.diag([1.0, 1.0, 1.03])
    gyr = np.column_stack([np.zeros(n), np.zeros(n), rate]) @ scale.T
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    samples = SensorSamples("S01", t, np.arange(n), acc=acc, gyr=gyr)
    plain = MagCalibration("S01", np.zeros(3), np.eye(3), 49.0)
    corrected = MagCalibration("S01", np.zeros(3), np.eye(3), 49.0, gyr_correction=np.linalg.inv(scale))

    def heading_deg(calibration: MagCalibration, live: bool) -> float:
        chain = SensorChain("S01", calibration)
        if live:
            q = np.concatenate([chain.update(samples.rows(slice(a, a + 50))).q_world_from_sensor
                                for a in range(0, n, 50)])
        else:
            q = chain.process(samples).q_world_from_sensor
        turned = np.degrees(rot.heading_rad(q[-1]) - rot.heading_rad(q[50]))
        return float((turned + 180.0) % 360.0 - 180.0)  # ten full turns: 0 when right

    for live in (False, True):
        assert abs(heading_deg(corrected, live)) < 1.0
        assert heading_deg(plain, live) == pytest.approx(108.0, abs=3.0)
