"""Quality figures and verdicts: coverage, residual, radii, field range, dip scatter."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.core.magcal.calibrate import calibrate
from mimucap.core.magcal.fit import FitSettings
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.magcal.quality import QualityThresholds, axis_coverage, coverage_condition
from mimucap.core.simulate.hand_held import calibration_motion

FIELD_WORLD_UT = np.array([0.0, 49.3 * np.cos(np.radians(60)), -49.3 * np.sin(np.radians(60))])


def turns_about(axis: int, start: np.ndarray, n: int = 360) -> np.ndarray:
    """Field in the sensor frame during one turn about sensor ``axis`` from orientation ``start``."""
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    q = rot.multiply(start, rot.from_axis_angle(np.eye(3)[axis], angles))
    return rot.rotate(rot.conjugate(q), FIELD_WORLD_UT)


def level_start(axis: int) -> np.ndarray:
    """Orientation holding sensor ``axis`` horizontal, pointing east."""
    return [rot.identity(), rot.from_axis_angle([0, 0, 1], -np.pi / 2), rot.from_axis_angle([0, 1, 0], np.pi / 2)][axis]


def test_uniform_sphere_scores_near_ideal_coverage() -> None:
    rng = np.random.default_rng(0)
    u = rng.normal(size=(5000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    assert 1.0 <= coverage_condition(u) < 2.0
    assert axis_coverage(u) == (1.0, 1.0, 1.0)


def test_three_axis_protocol_passes_and_one_or_two_axes_fail() -> None:
    rng = np.random.default_rng(1)
    circles = [turns_about(axis, level_start(axis)) + rng.normal(scale=0.3, size=(360, 3)) for axis in range(3)]
    b = np.array([15.0, -20.0, 8.0])
    three = calibrate(np.vstack(circles) + b, "S1").quality
    assert three.condition <= QualityThresholds().condition_good
    assert three.verdict == "good", three.reasons
    for axis in range(3):
        one = calibrate(circles[axis] + b, "S1", settings=FitSettings(max_radii_ratio=100)).quality
        assert one.condition > QualityThresholds().condition_fail
        assert one.verdict == "fail"
        assert any("coverage too low" in r for r in one.reasons)
        missing = [name for i, name in enumerate("xyz") if i != axis]
        assert any(f"about its {name} axis" in r for r in one.reasons for name in missing)
    two = calibrate(np.vstack(circles[:2]) + b, "S1").quality
    assert two.verdict == "fail" and "about its z axis" in " ".join(two.reasons)


def test_simulated_protocols_single_axis_good_figure8_not() -> None:
    single = calibration_motion("single_axis", 1, seed=2, errors="mpu9250")
    result = calibrate(single.mag_uT, "S01", acc=single.acc)
    assert result.quality.verdict == "good", result.quality.reasons
    np.testing.assert_allclose(result.fit.offset_uT, single.mag_b_uT, atol=0.3)
    figure8 = calibration_motion("figure8", 1, seed=2, errors="mpu9250")
    assert calibrate(figure8.mag_uT, "S01").quality.verdict == "fail"


def test_residual_thresholds() -> None:
    rng = np.random.default_rng(3)
    u = rng.normal(size=(3000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    for sigma, verdict in ((0.3, "good"), (1.3, "warn"), (3.0, "fail")):
        raw = 49.3 * u + rng.normal(scale=sigma, size=u.shape)
        quality = calibrate(raw, "S1").quality
        assert quality.rms_residual_uT == pytest.approx(sigma, rel=0.12)
        assert quality.rms_residual_pct == pytest.approx(100 * quality.rms_residual_uT / quality.field_uT)
        assert quality.verdict == verdict, quality.reasons


def test_field_out_of_range_and_radii_ratio() -> None:
    rng = np.random.default_rng(4)
    u = rng.normal(size=(1000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    counts = calibrate(300.0 * u, "S1").quality
    assert counts.verdict == "fail" and "unit and scale" in " ".join(counts.reasons)
    squashed = calibrate(49.3 * u * [1.0, 1.0, 0.6], "S1").quality
    assert squashed.radii_ratio == pytest.approx(1 / 0.6)
    assert squashed.verdict == "warn" and "radii ratio" in " ".join(squashed.reasons)


def test_dip_scatter_from_accelerometer() -> None:
    rng = np.random.default_rng(5)
    q = rot.from_rotvec(rng.normal(size=(2000, 3)) * 2.0)
    q_sensor_from_world = rot.conjugate(q)
    mag = rot.rotate(q_sensor_from_world, FIELD_WORLD_UT)
    acc = rot.rotate(q_sensor_from_world, [0.0, 0.0, 9.81])
    quality = calibrate(mag, "S1", acc=acc).quality
    assert quality.dip_mean_deg == pytest.approx(60.0, abs=1e-6)
    assert quality.dip_std_deg < 1e-6
    tilted = rot.rotate(rot.from_rotvec(rng.normal(size=(2000, 3)) * np.radians(6)), acc)
    disturbed = calibrate(mag, "S1", acc=tilted).quality
    assert disturbed.dip_std_deg > QualityThresholds().dip_std_fail_deg
    assert disturbed.verdict == "fail"
    with pytest.raises(ValueError, match="row by row"):
        calibrate(mag, "S1", acc=acc[:10])


def test_thresholds_are_validated() -> None:
    with pytest.raises(ValueError):
        QualityThresholds(condition_good=50, condition_fail=40)


def test_calibration_record_refuses_another_sensor() -> None:
    rng = np.random.default_rng(6)
    u = rng.normal(size=(500, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    result = calibrate(49.3 * u + [1.0, 2.0, 3.0], "S07", protocol="test", created_utc="2026-01-01T00:00:00Z")
    calibration = result.calibration
    assert calibration.samples_used == 500 and calibration.quality["verdict"] == "good"
    np.testing.assert_allclose(np.linalg.norm(calibration.apply([[1.0, 2.0, 52.3]], "S07")), 49.3)
    with pytest.raises(ValueError, match="S08"):
        calibration.apply([[1.0, 2.0, 3.0]], "S08")
    with pytest.raises(ValueError, match="symmetric"):
        MagCalibration("S07", np.zeros(3), np.array([[1.0, 0.1, 0], [0, 1, 0], [0, 0, 1]]), 49.3)


def test_wrong_unit_fails_even_with_the_field_given() -> None:
    rng = np.random.default_rng(7)
    u = rng.normal(size=(800, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    counts = 49.3 / 0.15 * u  # raw counts passed as µT
    quality = calibrate(counts, "S1", settings=FitSettings(field_uT=49.3)).quality
    assert quality.field_uT == 49.3 and quality.fitted_field_uT == pytest.approx(49.3 / 0.15)
    assert quality.verdict == "fail" and "unit and scale" in " ".join(quality.reasons)
