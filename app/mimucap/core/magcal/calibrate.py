"""The one-call magnetometer calibration: the ellipsoid fit (:mod:`mimucap.core.magcal.fit`)
and its quality assessment (:mod:`mimucap.core.magcal.quality`), returned with the calibration
record (:class:`~mimucap.core.magcal.model.MagCalibration`); given the gyroscope's samples of
the same turns, with the gyroscope's scale correction they show
(:mod:`mimucap.core.magcal.gyro_scale`). Fields in µT, rates rad/s, sensor frame.
"""

from __future__ import annotations

from dataclasses import dataclass

from numpy.typing import ArrayLike

from mimucap.core.magcal.fit import EllipsoidFit, FitSettings, apply_correction, fit_ellipsoid
from mimucap.core.magcal.gyro_scale import GyroScaleEstimate, GyroScaleLimits, estimate_gyro_scale, identity_estimate
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.magcal.quality import Quality, QualityThresholds, assess_quality


@dataclass(frozen=True)
class CalibrationResult:
    """What :func:`calibrate` returns: the fit, its quality, the gyroscope's scale estimate and
    the calibration record."""

    fit: EllipsoidFit
    quality: Quality
    calibration: MagCalibration
    gyro: GyroScaleEstimate


def calibrate(
    mag_raw: ArrayLike,
    sensor_id: str,
    acc: ArrayLike | None = None,
    settings: FitSettings = FitSettings(),
    thresholds: QualityThresholds = QualityThresholds(),
    protocol: str = "",
    created_utc: str = "",
    device_id: str | None = None,
    t_s: ArrayLike | None = None,
    gyr_raw_rad_s: ArrayLike | None = None,
    gyro_limits: GyroScaleLimits = GyroScaleLimits(),
) -> CalibrationResult:
    """Fit and assess a magnetometer calibration for ``sensor_id``.

    mag_raw: (N, 3) raw samples, µT, sensor frame. acc: optional (N, 3) specific force, m/s²,
    sampled at the same instants (enables the dip-scatter figure). device_id: the device the
    samples came from (None when not known). t_s (N,) s and gyr_raw_rad_s (N, 3): the times and
    the raw gyroscope samples at the same instants; without them the gyroscope correction stays
    the identity (said in the result's ``gyro.reason``). Raises
    :class:`~mimucap.core.magcal.fit.FitRefused` (a ``ValueError``) when no trustworthy
    ellipsoid can be fitted; otherwise the verdict of the result may still be "fail".
    """
    fit = fit_ellipsoid(mag_raw, settings)
    quality = assess_quality(fit, mag_raw, acc, thresholds)
    if t_s is None or gyr_raw_rad_s is None:
        gyro = identity_estimate("no gyroscope samples with the magnetometer's")
    else:
        gyro = estimate_gyro_scale(t_s, gyr_raw_rad_s, apply_correction(mag_raw, fit.offset_uT, fit.soft_iron),
                                   gyro_limits)
    calibration = MagCalibration(
        sensor_id=sensor_id,
        offset_uT=fit.offset_uT,
        soft_iron=fit.soft_iron,
        field_uT=fit.field_uT,
        created_utc=created_utc,
        protocol=protocol,
        samples_used=fit.samples_used,
        quality=quality.as_dict(),
        device_id=device_id,
        gyr_correction=gyro.correction,
        gyr_quality=gyro.as_dict(),
    )
    return CalibrationResult(fit=fit, quality=quality, calibration=calibration, gyro=gyro)
