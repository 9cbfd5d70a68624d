"""A magnetometer calibration's standing now: may the data it corrects be trusted?

A calibration's verdict says how well the fit went when it was made. Whether it still holds
depends on more: the device it is applied to must be the one it was made on
(:mod:`mimucap.core.device_identity`), the local field must still be the one it was made in (a
sensor in another room, or near metal, sees another field magnitude or dip, and its corrected
field then points the wrong way), and it must not be old. :func:`calibration_standing` weighs
all four and is the one judge every summary of readiness asks: the sensor table and the
checklist before recording, the record prompt, the readiness a recording stores, and the
commands that process a session (``bodycal``, ``angles``, ``export``, ``gait``, ``report``).

Levels: :data:`GOOD`; :data:`WARN` (usable, with something to know: verdict warn, a device that
cannot be checked); :data:`NOT_GOOD` (a poor calibration, another device, a field that no longer fits,
too old). Each problem is a sentence naming its figures, e.g. ``"local field 85 µT, 51 µT when
calibrated"``.

The local field (:func:`local_field`) is measured from the sensor's own samples, corrected by
the calibration: the median magnitude (µT), and the median dip (degrees below the horizon) of
the samples where the sensor is still (specific force within :data:`STILL_ACC_M_S2` of g, angular
rate under :data:`STILL_GYR_RAD_S`: only then is the accelerometer's direction up). Units: µT,
m/s², rad/s, sensor frame; arrays (N, 3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Any

import numpy as np

from mimucap.core.device_identity import SensorDevice, describe_device

GOOD = "good"
WARN = "warn"
NOT_GOOD = "not good"

#: The local field's magnitude may differ this much (fraction) from the calibration's, its dip
#: this much (deg), before the calibration no longer fits (the filter's own field check rejects
#: samples 10 % off the field it learned; a calibration that is 15 % off corrects the field
#: into a wrong direction for good).
FIELD_MAGNITUDE_TOLERANCE = 0.15
FIELD_DIP_TOLERANCE_DEG = 10.0
#: A calibration older than this (hours) is not good: the magnetic surroundings of a room change
#: (furniture, equipment), and the clinic moves from room to room.
MAX_AGE_H = 24.0
#: Still samples (for the dip): specific force within this of g (m/s²), angular rate below this (rad/s).
STILL_ACC_M_S2 = 0.3
STILL_GYR_RAD_S = 0.05
GRAVITY_M_S2 = 9.81
#: Fewer usable samples than this tell nothing about the field.
MIN_FIELD_SAMPLES = 10

#: Kinds of problem (:attr:`Problem.kind`), in the order a summary lists them.
PROBLEM_KINDS = ("verdict", "device", "field", "age")


@dataclass(frozen=True)
class LocalField:
    """The field a sensor measures here, corrected by its calibration: ``magnitude_uT`` (median,
    µT), ``dip_deg`` (median dip of the still samples, degrees below the horizon; ``None`` with
    too few still samples), ``samples`` (samples with a field)."""

    magnitude_uT: float
    dip_deg: float | None
    samples: int


def local_field(acc: np.ndarray | None, gyr: np.ndarray | None, mag_calibrated_uT: np.ndarray) -> LocalField | None:
    """The local field of samples ``acc`` (N, 3) m/s², ``gyr`` (N, 3) rad/s (either may be None:
    no dip) and ``mag_calibrated_uT`` (N, 3) µT; ``None`` with fewer than
    :data:`MIN_FIELD_SAMPLES` finite field samples. NaN rows are left out."""
    mag = np.asarray(mag_calibrated_uT, dtype=np.float64).reshape(-1, 3)
    # the live view asks for every sensor a few times a second: plain ufuncs, no norm() calls
    norm = np.sqrt(np.einsum("ij,ij->i", mag, mag))
    finite = np.isfinite(norm)
    count = int(np.count_nonzero(finite))
    if count < MIN_FIELD_SAMPLES:
        return None
    magnitude = float(np.median(norm[finite]))
    dip = None
    if acc is not None and gyr is not None:
        acc = np.asarray(acc, dtype=np.float64).reshape(-1, 3)
        gyr = np.asarray(gyr, dtype=np.float64).reshape(-1, 3)
        acc_norm = np.sqrt(np.einsum("ij,ij->i", acc, acc))
        gyr_norm2 = np.einsum("ij,ij->i", gyr, gyr)
        # Only a still sensor's specific force is gravity alone (a swinging limb's is not).
        with np.errstate(invalid="ignore"):
            still = (finite & (np.abs(acc_norm - GRAVITY_M_S2) < STILL_ACC_M_S2)
                     & (gyr_norm2 < STILL_GYR_RAD_S ** 2) & (norm > 0))
        if np.count_nonzero(still) >= MIN_FIELD_SAMPLES:
            cosine = np.einsum("ij,ij->i", acc[still], mag[still]) / (acc_norm[still] * norm[still])
            dip = float(np.degrees(np.median(-np.arcsin(np.clip(cosine, -1.0, 1.0)))))
    return LocalField(magnitude, dip, count)


@dataclass(frozen=True)
class Problem:
    """Why a calibration is not good (or what to know about it): ``kind`` one of
    :data:`PROBLEM_KINDS`, ``text`` a sentence with its figures."""

    kind: str
    text: str


@dataclass(frozen=True)
class Standing:
    """A calibration's standing (see the module docstring): ``level`` :data:`GOOD`,
    :data:`WARN` or :data:`NOT_GOOD`; ``problems`` why it is not good; ``warnings`` what to
    know although it is usable; ``verdict`` its fit's verdict; ``age_h`` hours between its making
    and the data (``None``: date unknown); ``field`` the local field it was checked against
    (``None``: not checked)."""

    sensor_id: str
    level: str
    problems: tuple[Problem, ...] = ()
    warnings: tuple[Problem, ...] = ()
    verdict: str = ""
    age_h: float | None = None
    field: LocalField | None = None

    @property
    def good(self) -> bool:
        """Not :data:`NOT_GOOD` (a warning still lets the data be used)."""
        return self.level != NOT_GOOD

    def summary(self) -> str:
        """``"not good: local field 85 µT, 51 µT when calibrated"``, ``"good"``…"""
        said = self.problems if self.problems else self.warnings
        return self.level + (": " + "; ".join(p.text for p in said) if said else "")

    def to_json(self) -> dict[str, Any]:
        """The JSON object a recording stores of it."""
        data: dict[str, Any] = {"level": self.level, "verdict": self.verdict,
                                "problems": [p.text for p in self.problems],
                                "warnings": [p.text for p in self.warnings],
                                "age_h": None if self.age_h is None else round(self.age_h, 3)}
        if self.field is not None:
            data["local_field_uT"] = round(self.field.magnitude_uT, 2)
            data["local_dip_deg"] = None if self.field.dip_deg is None else round(self.field.dip_deg, 2)
        return data


def age_s_at(created_utc: str, at: datetime) -> float | None:
    """Seconds between a calibration made at ``created_utc`` (ISO 8601) and ``at`` (an aware
    datetime; positive when the calibration is older); ``None`` when the date cannot be read."""
    try:
        created = datetime.fromisoformat(str(created_utc).replace("Z", "+00:00"))
    except (ValueError, AttributeError):
        return None
    if created.tzinfo is None:
        created = created.replace(tzinfo=timezone.utc)
    return (at - created).total_seconds()


def calibration_standing(calibration, sensor_id: str, *, device: SensorDevice | None = None,
                         field: LocalField | None = None, age_s: float | None = None) -> Standing:
    """The standing of ``calibration`` (a :class:`~mimucap.core.magcal.model.MagCalibration`) applied
    to sensor ``sensor_id``.

    ``device``: what the source says the sensor is (``None`` or not settled: the device is not
    judged); ``field``: the local field of the sensor's samples corrected by ``calibration``
    (``None``: not judged); ``age_s``: seconds between the calibration's making and the data
    (its sign does not matter: a calibration made a day after a recording is a day away from it;
    ``None`` or NaN: the date is unknown, which is not good).
    """
    problems: list[Problem] = []
    warnings: list[Problem] = []
    verdict = str(calibration.quality.get("verdict", "unknown"))
    if verdict == "fail":
        problems.append(Problem("verdict", "poor calibration"))
    elif verdict != "good":
        warnings.append(Problem("verdict", f"verdict {verdict}"))
    if device is not None and device.settled:
        made_on = calibration.device_id
        if made_on is not None and device.device_id is not None and made_on != device.device_id:
            problems.append(Problem("device", f"made on {describe_device(made_on)}, this sensor is "
                                              f"{describe_device(device.device_id)}"))
        elif device.device_id is None:
            warnings.append(Problem("device", f"device not verified: {device.missing}"))
        elif made_on is None:
            warnings.append(Problem("device", "device not verified: the calibration does not say which device it "
                                              "was made on"))
    if field is not None:
        reference = float(calibration.field_uT)
        if abs(field.magnitude_uT / reference - 1.0) > FIELD_MAGNITUDE_TOLERANCE:
            problems.append(Problem("field", f"local field {field.magnitude_uT:.0f} µT, {reference:.0f} µT when "
                                             "calibrated"))
        dip_reference = calibration.quality.get("dip_mean_deg")
        if (field.dip_deg is not None and dip_reference is not None and math.isfinite(float(dip_reference))
                and abs(field.dip_deg - float(dip_reference)) > FIELD_DIP_TOLERANCE_DEG):
            problems.append(Problem("field", f"field dip {field.dip_deg:.0f}°, {float(dip_reference):.0f}° when "
                                             "calibrated"))
    age_h = None if age_s is None or not math.isfinite(age_s) else abs(age_s) / 3600.0
    if age_h is None:
        problems.append(Problem("age", "calibration date unknown"))
    elif age_h > MAX_AGE_H:
        problems.append(Problem("age", f"calibration {age_h:.0f} h old (at most {MAX_AGE_H:.0f} h)"))
    level = NOT_GOOD if problems else WARN if warnings else GOOD
    return Standing(sensor_id, level, tuple(problems), tuple(warnings), verdict, age_h, field)
