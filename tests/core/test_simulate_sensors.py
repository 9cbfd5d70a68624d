"""The simulator's sensor error model against physics and its own stated parameters."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.core.simulate.magnetic_field import EarthField, MagneticDisturbance, disturbed_field
from mimucap.core.simulate.sensor_errors import (
    GRAVITY_MPS2,
    IDEAL_SENSOR,
    NOISE_CHUNK,
    SensorErrorModel,
    SensorNoise,
    draw_sensor_parameters,
    error_model,
    measure,
    sample_kinematics,
)


def test_earth_field_has_the_configured_norm_and_dip() -> None:
    field = EarthField().field_world_uT()
    assert np.linalg.norm(field) == pytest.approx(49.3)
    assert np.degrees(np.arctan2(-field[2], np.hypot(field[0], field[1]))) == pytest.approx(60.0)
    assert field[0] == pytest.approx(0.0) and field[1] > 0  # points north and down
    other = EarthField(magnitude_uT=30.0, dip_deg=-20.0, declination_deg=90.0).field_world_uT()
    np.testing.assert_allclose(other, [30 * np.cos(np.radians(20)), 0, 30 * np.sin(np.radians(20))], atol=1e-12)
    with pytest.raises(ValueError, match="dip"):
        EarthField(dip_deg=95.0)


def _static(q: np.ndarray):
    def pose(t: np.ndarray):
        return np.broadcast_to(q, t.shape + (4,)), np.broadcast_to([0.3, 0.2, 1.0], t.shape + (3,))
    return pose


def test_sensor_at_rest_reads_gravity_up_and_the_field_after_undoing_distortion() -> None:
    errors = dataclasses.replace(IDEAL_SENSOR, mag_hard_iron_uT=40.0, mag_soft_iron_scale=0.1,
                                 mag_soft_iron_cross=0.05, mag_noise_uT=0.3, acc_noise_mps2=0.02)
    q = rot.normalize(np.array([0.3, -0.5, 0.7, 0.2]))
    params = draw_sensor_parameters(7, 0, "S01", errors)
    assert np.max(np.abs(params.mag_b_uT)) > 5.0  # a real hard-iron offset is present
    n, dt = 2000, 0.01
    t = np.arange(n) * dt
    q_now, q_prev, _, acc_world = sample_kinematics(_static(q), t, dt)
    np.testing.assert_allclose(acc_world, 0.0, atol=1e-9)
    field = EarthField().field_world_uT()
    m = measure(params, errors, SensorNoise(7, params, errors, 100.0).block(0, n), t, q_now, q_prev, acc_world, field, dt)
    acc_world_measured = rot.rotate(q, m.acc.mean(axis=0))
    np.testing.assert_allclose(acc_world_measured, [0, 0, GRAVITY_MPS2], atol=0.005)
    mag_sensor = np.linalg.solve(params.mag_A, (m.mag_uT - params.mag_b_uT).T).T.mean(axis=0)
    mag_world = rot.rotate(q, mag_sensor)
    assert np.linalg.norm(mag_world) == pytest.approx(49.3, abs=0.05)
    dip = np.degrees(np.arctan2(-mag_world[2], np.hypot(mag_world[0], mag_world[1])))
    assert dip == pytest.approx(60.0, abs=0.1)
    np.testing.assert_allclose(m.gyr, 0.0, atol=1e-12)
    # The raw field norm is visibly distorted: calibration matters.
    assert abs(np.linalg.norm(m.mag_uT.mean(axis=0)) - 49.3) > 2.0


def test_soft_iron_is_symmetric_positive_definite_and_offsets_bounded() -> None:
    for index in range(20):
        p = draw_sensor_parameters(3, index, f"S{index:02d}", SensorErrorModel())
        np.testing.assert_array_equal(p.mag_A, p.mag_A.T)
        assert np.all(np.linalg.eigvalsh(p.mag_A) > 0.7)
        assert np.all(np.abs(p.mag_b_uT) <= 40.0)
        assert 0.5 <= np.degrees(np.linalg.norm(p.gyr_bias0_rad_s)) <= 2.0


def test_noise_is_identical_for_any_block_partition() -> None:
    errors = SensorErrorModel(drop_probability=0.1)
    params = draw_sensor_parameters(11, 2, "S03", errors)
    total = 3 * NOISE_CHUNK + 17
    whole = SensorNoise(11, params, errors, 100.0).block(0, total)
    pieces = SensorNoise(11, params, errors, 100.0)
    rng = np.random.default_rng(0)
    k, parts = 0, []
    while k < total:
        n = min(int(rng.integers(1, 700)), total - k)
        parts.append(pieces.block(k, n))
        k += n
    for name in ("gyr_noise", "gyr_bias", "acc_noise", "mag_noise", "keep"):
        np.testing.assert_array_equal(np.concatenate([getattr(p, name) for p in parts]), getattr(whole, name))
    assert 0.08 < 1.0 - whole.keep.mean() < 0.12
    # The bias random walk wanders (not a constant) but stays small over 30 s.
    drift = whole.gyr_bias - params.gyr_bias0_rad_s
    assert 0.0 < np.degrees(np.abs(drift).max()) < 0.5


def test_quantisation_onboard_output_and_clock() -> None:
    errors = SensorErrorModel(mag_lsb_uT=0.15, onboard_orientation=True, onboard_error_deg=1.0)
    params = draw_sensor_parameters(5, 1, "S02", errors)
    n, dt = 3000, 0.01
    t = np.arange(n) * dt
    q = rot.from_rotvec(np.stack([np.sin(t), np.cos(0.5 * t), 0.3 * t], axis=-1))
    m = measure(params, errors, SensorNoise(5, params, errors, 100.0).block(0, n), t, q, q, np.zeros((n, 3)),
                EarthField().field_world_uT(), dt)
    steps = m.mag_uT / 0.15
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)
    error_deg = np.degrees(rot.angle_between(m.q_world_from_sensor, q))
    assert 0.2 < np.sqrt(np.mean(error_deg**2)) < 3.0
    np.testing.assert_allclose(m.device_time_s, (1 + params.clock_drift) * t + params.clock_offset_s)
    assert params.clock_drift != 0.0 and params.clock_offset_s != 0.0


def test_disturbance_adds_a_local_field_in_its_window() -> None:
    d = MagneticDisturbance(field_uT=(20.0, 0.0, 0.0), start_s=2.0, end_s=4.0, ramp_s=0.5,
                            center_m=(1.0, 0.0, 1.0), radius_m=0.2)
    t = np.array([0.0, 3.0, 3.0, 5.0])
    positions = np.array([[1.0, 0, 1], [1.0, 0, 1], [3.0, 0, 1], [1.0, 0, 1]])
    base = EarthField().field_world_uT()
    field = disturbed_field(base, (d,), "S01", t, positions)
    np.testing.assert_allclose(field[[0, 2, 3]], np.tile(base, (3, 1)), atol=1e-12)
    np.testing.assert_allclose(field[1], base + [20.0, 0, 0])
    assert np.all(disturbed_field(base, (dataclasses.replace(d, sensor_ids=("S09",)),), "S01", t, positions) == base)


def test_settings_are_checked() -> None:
    with pytest.raises(ValueError, match="gyr_noise_dps"):
        SensorErrorModel(gyr_noise_dps=-1.0)
    with pytest.raises(ValueError, match="drop_probability"):
        SensorErrorModel(drop_probability=1.0)
    with pytest.raises(ValueError, match="unknown sensor error preset 'nope'"):
        error_model("nope")
    assert error_model("mpu9250").mag_lsb_uT == 0.15
