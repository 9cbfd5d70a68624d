"""Calibration of real magnetometer recordings against independent references.

References: the sunsided set-2 ``full-sphere`` recording (dense coverage, the dataset's own
reference motion) for the single-axis turns of the same board; the Earth's field range
(22–67 µT); sensor data sheets for unit scales (AK8963 in 14-bit mode: 0.6 µT/LSB).
"""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core.magcal.calibrate import calibrate
from mimucap.core.magcal.fit import FitRefused, FitSettings, fit_ellipsoid
from mimucap.core.magcal.quality import QualityThresholds
from mimucap.io.magdata import read_mag_files, to_microtesla

ROTATIONS = (
    "rotate-ccw-around-x-pointing-forward",
    "rotate-ccw-around-y-pointing-left",
    "rotate-ccw-around-z-pointing-up",
)


def set2(shared_data, name: str):
    recording = read_mag_files([shared_data / "mag" / "sunsided_hmc5883l" / "set-2" / name])[0]
    return to_microtesla(recording.mag, recording.unit, None), recording


@pytest.mark.data("mag-hmc5883l")
def test_full_sphere_fits_below_one_percent(shared_data) -> None:
    mag, recording = set2(shared_data, "full-sphere")
    result = calibrate(mag, "hmc5883l", acc=recording.acc_at_mag_times())
    quality = result.quality
    assert quality.rms_residual_pct < 1.0
    assert 22.0 <= result.fit.field_uT <= 67.0
    assert quality.verdict == "good", quality.reasons
    # The board's accelerometer and magnetometer agree on a constant dip (northern hemisphere).
    assert 50.0 < quality.dip_mean_deg < 75.0


@pytest.mark.data("mag-hmc5883l")
@pytest.mark.parametrize("method", ["ellipsoid", "quadric"])
def test_three_single_axis_turns_find_the_full_sphere_centre(shared_data, method: str) -> None:
    settings = FitSettings(method=method)
    reference = fit_ellipsoid(set2(shared_data, "full-sphere")[0], settings)
    union = np.vstack([set2(shared_data, name)[0] for name in ROTATIONS])
    result = calibrate(union, "hmc5883l", settings=settings)
    assert np.linalg.norm(result.fit.offset_uT - reference.offset_uT) < 0.5
    np.testing.assert_allclose(result.fit.ellipsoid.radii, reference.ellipsoid.radii, rtol=0.01)
    assert result.quality.verdict == "good", result.quality.reasons


@pytest.mark.data("mag-hmc5883l")
@pytest.mark.parametrize("name", ROTATIONS + ("rotate-ccw-around-x-pointing-up", "pan-along-z-pointing-up"))
def test_one_rotation_alone_is_refused_or_fails(shared_data, name: str) -> None:
    mag, _ = set2(shared_data, name)
    try:
        result = calibrate(mag, "hmc5883l")
    except FitRefused:
        return
    assert result.quality.verdict == "fail"
    if name.startswith("rotate"):
        assert any("coverage too low" in reason for reason in result.quality.reasons)


@pytest.mark.data("mag-mpu9250")
def test_mpu9250_recording_fits_plausibly(shared_data) -> None:
    recording = read_mag_files([shared_data / "mag" / "jremington_mpu9250" / "mag.txt"])[0]
    mag = to_microtesla(recording.mag, "counts", 0.6)  # AK8963 14-bit: 0.6 µT/LSB (data sheet)
    result = calibrate(mag, "mpu9250")
    assert 22.0 <= result.fit.field_uT <= 67.0
    # Hand rotation with 1-LSB (0.6 µT) quantisation and AK8963 noise: about 1 µT, not more.
    assert result.quality.rms_residual_pct < 3.0
    assert result.quality.rms_residual_uT < QualityThresholds().residual_fail_uT
    assert result.quality.condition < 15.0
    assert result.fit.ellipsoid.radii_ratio < 1.2


@pytest.mark.data("mag-ellipsoid")
def test_ellipsoid_fit_example_fits_plausibly(shared_data) -> None:
    recording = read_mag_files([shared_data / "mag" / "bazhin_ellipsoid_fit" / "mag_out.txt"])[0]
    fit = fit_ellipsoid(recording.mag)  # counts of an unnamed sensor: judge relative figures only
    residual = np.linalg.norm(fit.apply(recording.mag[fit.used_mask]), axis=1) / fit.field_uT - 1.0
    assert np.sqrt(np.mean(residual**2)) < 0.03
    assert fit.ellipsoid.radii_ratio < 1.3
    assert fit.samples_rejected <= 0.05 * fit.samples_input

