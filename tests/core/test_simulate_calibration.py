"""Single-sensor magnetometer-calibration motions: truth is consistent and the motion is what it claims."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.core.simulate.hand_held import calibration_motion
from mimucap.core.simulate.sensor_errors import IDEAL_SENSOR, SensorErrorModel

NO_GYRO_ERRORS = dataclasses.replace(
    SensorErrorModel(), gyr_bias_dps=(0.0, 0.0), gyr_bias_walk_dps_per_sqrt_s=0.0, gyr_noise_dps=0.0, gyr_scale_error=0.0
)


@pytest.mark.parametrize("protocol", ["single_axis", "figure8", "tumble"])
def test_gyroscope_integrates_to_the_true_orientation(protocol: str) -> None:
    m = calibration_motion(protocol, 1, seed=4, errors=NO_GYRO_ERRORS)
    dt = 1.0 / m.rate_hz
    q = m.q_world_from_sensor[0]
    estimates = [q]
    for gyr in m.gyr[1:]:
        q = rot.multiply(q, rot.from_rotvec(gyr * dt))
        estimates.append(q)
    error = np.degrees(rot.angle_between(np.array(estimates), m.q_world_from_sensor))
    assert error.max() < 1e-6


def test_single_axis_turns_each_sensor_axis_while_it_is_horizontal() -> None:
    m = calibration_motion("single_axis", 2, seed=1, errors=IDEAL_SENSOR)
    dt = 1.0 / m.rate_hz
    axes = [int(a) for a in m.axis_turned if a >= 0]
    order = [a for i, a in enumerate(axes) if i == 0 or axes[i - 1] != a]
    assert order == [0, 1, 2]
    for axis in range(3):
        turning = m.axis_turned == axis
        about_axis = m.gyr[turning, axis].sum() * dt
        assert abs(np.degrees(about_axis)) == pytest.approx(720.0, abs=15.0)
        off_axis = np.delete(m.gyr[turning], axis, axis=1)
        assert np.sqrt(np.mean(off_axis**2)) < 0.1 * np.sqrt(np.mean(m.gyr[turning, axis] ** 2))
        axis_world = rot.rotate(m.q_world_from_sensor[turning], np.eye(3)[axis])
        assert np.degrees(np.arcsin(np.abs(axis_world[:, 2]))).max() < 16.0
    # Slow start and stop: the rate at the start of a turn is small.
    first = np.flatnonzero(m.axis_turned == 0)[0]
    peak = np.abs(m.gyr[m.axis_turned == 0, 0]).max()
    assert np.linalg.norm(m.gyr[first]) < 0.05 * peak


def test_raw_field_is_the_true_field_after_undoing_distortion() -> None:
    m = calibration_motion("figure8", 2, seed=2, errors="mpu9250")
    corrected = np.linalg.solve(m.mag_A, (m.mag_uT - m.mag_b_uT).T).T
    world = rot.rotate(m.q_world_from_sensor, corrected)
    residual = world - m.field_world_uT
    assert np.sqrt(np.mean(residual**2)) == pytest.approx(np.sqrt(0.6**2 + 0.15**2 / 12), rel=0.1)
    assert np.max(np.abs(m.mag_b_uT)) > 5.0


def test_tumbling_covers_the_sphere_of_field_directions() -> None:
    m = calibration_motion("tumble", 3, seed=6, errors=IDEAL_SENSOR)
    directions = rot.rotate(rot.conjugate(m.q_world_from_sensor), m.field_world_uT / np.linalg.norm(m.field_world_uT))
    probes = np.array([[x, y, z] for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if (x, y, z) != (0, 0, 0)], float)
    probes /= np.linalg.norm(probes, axis=1, keepdims=True)
    closest = np.degrees(np.arccos(np.clip((probes @ directions.T).max(axis=1), -1, 1)))
    assert closest.max() < 40.0


def test_deterministic_by_seed_and_checked_arguments() -> None:
    a = calibration_motion("tumble", 1, seed=9)
    b = calibration_motion("tumble", 1, seed=9)
    c = calibration_motion("tumble", 1, seed=10)
    np.testing.assert_array_equal(a.mag_uT, b.mag_uT)
    assert not np.array_equal(a.mag_uT, c.mag_uT)
    given = calibration_motion("figure8", 1, seed=9, mag_A=np.eye(3), mag_b_uT=np.array([10.0, 0, 0]))
    np.testing.assert_array_equal(given.mag_b_uT, [10.0, 0, 0])
    with pytest.raises(ValueError, match="unknown calibration protocol 'spin'"):
        calibration_motion("spin")
    with pytest.raises(ValueError, match="turns"):
        calibration_motion("figure8", 9)
