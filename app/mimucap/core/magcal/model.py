"""The magnetometer calibration of one sensor: the model and its application.

Model (``docs/conventions.md``): ``mag_raw = A · mag_true + b + noise``. A
:class:`MagCalibration` holds the hard-iron offset ``b`` (``offset_uT``, (3,), µT, sensor
frame) and the soft-iron correction ``A⁻¹`` (``soft_iron``, (3, 3), the symmetric square root),
and is applied as ``mag_cal = soft_iron @ (mag_raw − offset_uT)``. It carries the sensor id
it belongs to and refuses to be applied to another one, the device it was made on
(:mod:`mimucap.core.device_identity`; ``None`` when the source did not say), the creation date (ISO 8601 UTC,
supplied by the caller: the core reads no clock), the protocol used, the sample count and
its quality figures.

It also carries the sensor's gyroscope correction ``gyr_correction`` (3, 3), estimated from the
same turns (:mod:`mimucap.core.magcal.gyro_scale`) and applied as ``ω = gyr_correction @ ω_raw``
before the orientation filter; the identity when the turns did not determine it (or a calibration file
holds none), with the reason in ``gyr_quality``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mimucap.core.device_identity import check_device_id
from mimucap.core.magcal.fit import apply_correction

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class MagCalibration:
    """Hard- and soft-iron calibration of one sensor's magnetometer.

    sensor_id: the sensor it belongs to. offset_uT: ``b`` (3,), µT. soft_iron: ``A⁻¹`` (3, 3),
    symmetric. field_uT: field magnitude the calibrated samples have. created_utc: ISO 8601
    date. protocol: how the samples were recorded (e.g. "single_axis", "figure8", "file").
    samples_used: samples in the final fit. quality: :meth:`Quality.as_dict` figures.
    device_id: the device the samples came from (:func:`~mimucap.core.device_identity.check_device_id`),
    ``None`` when it is not known (a file without one, a node that does not say).
    gyr_correction: ``C`` (3, 3), dimensionless, the gyroscope's scale and cross-axis correction
    (``ω_rad_s = C @ ω_raw_rad_s``, sensor frame); gyr_quality: the figures of its estimate
    (:meth:`~mimucap.core.magcal.gyro_scale.GyroScaleEstimate.as_dict`; empty when none was made).
    """

    sensor_id: str
    offset_uT: FloatArray
    soft_iron: FloatArray
    field_uT: float
    created_utc: str = ""
    protocol: str = ""
    samples_used: int = 0
    quality: dict = field(default_factory=dict)
    device_id: str | None = None
    gyr_correction: FloatArray = field(default_factory=lambda: np.eye(3))
    gyr_quality: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        offset = np.asarray(self.offset_uT, dtype=np.float64)
        soft_iron = np.asarray(self.soft_iron, dtype=np.float64)
        if offset.shape != (3,) or not np.all(np.isfinite(offset)):
            raise ValueError(f"sensor {self.sensor_id}: offset_uT must be 3 finite numbers")
        if soft_iron.shape != (3, 3) or not np.all(np.isfinite(soft_iron)):
            raise ValueError(f"sensor {self.sensor_id}: soft_iron must be a finite 3×3 matrix")
        if not np.allclose(soft_iron, soft_iron.T, rtol=0, atol=1e-9 * np.abs(soft_iron).max()):
            raise ValueError(f"sensor {self.sensor_id}: soft_iron must be symmetric")
        if np.linalg.eigvalsh(soft_iron)[0] <= 0:
            raise ValueError(f"sensor {self.sensor_id}: soft_iron must be positive definite")
        if not (np.isfinite(self.field_uT) and self.field_uT > 0):
            raise ValueError(f"sensor {self.sensor_id}: field_uT must be a positive number")
        if not self.sensor_id:
            raise ValueError("a magnetometer calibration needs a sensor id")
        if self.device_id is not None:
            check_device_id(self.device_id, f"sensor {self.sensor_id}")
        correction = np.asarray(self.gyr_correction, dtype=np.float64)
        if correction.shape != (3, 3) or not np.all(np.isfinite(correction)) or np.linalg.det(correction) <= 0:
            raise ValueError(f"sensor {self.sensor_id}: gyr_correction must be a finite 3×3 matrix with a positive "
                             "determinant")
        object.__setattr__(self, "gyr_correction", correction)
        object.__setattr__(self, "offset_uT", offset)
        object.__setattr__(self, "soft_iron", soft_iron)

    def apply(self, mag_raw: ArrayLike, sensor_id: str) -> FloatArray:
        """Calibrated samples ``soft_iron @ (mag_raw − offset_uT)`` (..., 3) of ``sensor_id``;
        raises ``ValueError`` if this calibration belongs to another sensor."""
        if sensor_id != self.sensor_id:
            raise ValueError(
                f"the magnetometer calibration of sensor {self.sensor_id!r} cannot be applied "
                f"to sensor {sensor_id!r}: calibrate that sensor"
            )
        return apply_correction(mag_raw, self.offset_uT, self.soft_iron)

    @property
    def corrects_gyr(self) -> bool:
        """Whether the gyroscope correction is other than the identity."""
        return not np.array_equal(self.gyr_correction, np.eye(3))

    def correct_gyr(self, gyr_raw_rad_s: ArrayLike) -> FloatArray:
        """Rates ``gyr_correction @ ω_raw`` (..., 3), rad/s, sensor frame."""
        return np.asarray(gyr_raw_rad_s, dtype=np.float64) @ self.gyr_correction.T
