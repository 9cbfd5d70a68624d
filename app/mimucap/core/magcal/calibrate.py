"""The one-call magnetometer calibration: the ellipsoid fit (:mod:`mimucap.core.magcal.fit`)
and its quality assessment (:mod:`mimucap.core.magcal.quality`), returned with the calibration
record (:class:`~mimucap.core.magcal.model.MagCalibration`). Fields in µT, sensor frame.
"""

from __future__ import annotations

from dataclasses import dataclass

from numpy.typing import ArrayLike

from mimucap.core.magcal.fit import EllipsoidFit, FitSettings, fit_ellipsoid
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.magcal.quality import Quality, QualityThresholds, assess_quality


@dataclass(frozen=True)
class CalibrationResult:
    """What :func:`calibrate` returns: the fit, its quality and the calibration record."""

    fit: EllipsoidFit
    quality: Quality
    calibration: MagCalibration


def calibrate(
    mag_raw: ArrayLike,
    sensor_id: str,
    acc: ArrayLike | None = None,
    settings: FitSettings = FitSettings(),
    thresholds: QualityThresholds = QualityThresholds(),
    protocol: str = "",
    created_utc: str = "",
    device_id: str | None = None,
) -> CalibrationResult:
    """Fit and assess a magnetometer calibration for ``sensor_id``.

    mag_raw: (N, 3) raw samples, µT, sensor frame. acc: optional (N, 3) specific force, m/s²,
    sampled at the same instants (enables the dip-scatter figure). device_id: the device the
    samples came from (None when not known). Raises
    :class:`~mimucap.core.magcal.fit.FitRefused` (a ``ValueError``) when no trustworthy
    ellipsoid can be fitted; otherwise the verdict of the result may still be "fail".
    """
    fit = fit_ellipsoid(mag_raw, settings)
    quality = assess_quality(fit, mag_raw, acc, thresholds)
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
    )
    return CalibrationResult(fit=fit, quality=quality, calibration=calibration)
