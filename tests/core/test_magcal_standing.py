"""A magnetometer calibration's standing: verdict, device, local field (magnitude, dip) and age,
each problem a sentence with its figures; the local field measured from samples with known
field and attitude."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mimucap.core import rotation
from mimucap.core.device_identity import SensorDevice
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.magcal.standing import (
    FIELD_DIP_TOLERANCE_DEG, FIELD_MAGNITUDE_TOLERANCE, GOOD, MAX_AGE_H, NOT_GOOD, WARN, LocalField,
    calibration_standing, local_field,
)

DEVICE = "mac:A1B2C3D4E5F6"


def calibration(verdict="good", field_uT=50.0, dip=60.0, device=DEVICE) -> MagCalibration:
    return MagCalibration("S01", np.zeros(3), np.eye(3), field_uT, created_utc="2026-11-21T06:00:00Z",
                          quality={"verdict": verdict, "dip_mean_deg": dip}, device_id=device)


def still_samples(field_uT: float, dip_deg: float, n: int = 200, seed: int = 0):
    """A still sensor in random attitudes (one per sample), the field of ``field_uT`` and
    ``dip_deg`` in world ENU measured in its frame: known magnitude and dip."""
    rng = np.random.default_rng(seed)
    q = rotation.normalize(rng.normal(size=(n, 4)))
    dip = math.radians(dip_deg)
    field_world = field_uT * np.array([0.0, math.cos(dip), -math.sin(dip)])
    q_sensor_from_world = rotation.conjugate(q)
    mag = rotation.rotate(q_sensor_from_world, np.broadcast_to(field_world, (n, 3)))
    acc = rotation.rotate(q_sensor_from_world, np.broadcast_to([0.0, 0.0, 9.81], (n, 3)))
    return acc, np.zeros((n, 3)), mag


def test_the_local_field_is_measured_with_its_magnitude_and_dip():
    acc, gyr, mag = still_samples(49.3, 64.0)
    here = local_field(acc, gyr, mag)
    assert here.magnitude_uT == pytest.approx(49.3, abs=1e-9) and here.dip_deg == pytest.approx(64.0, abs=1e-6)
    assert here.samples == 200
    turning = local_field(acc, gyr + 1.0, mag)        # not still: no dip, the magnitude still counts
    assert turning.dip_deg is None and turning.magnitude_uT == pytest.approx(49.3)
    assert local_field(None, None, mag).dip_deg is None
    assert local_field(acc[:5], gyr[:5], mag[:5]) is None
    mag[::2] = np.nan
    assert local_field(acc, gyr, mag).samples == 100


def test_a_calibration_that_fits_here_on_its_device_is_good():
    standing = calibration_standing(calibration(), "S01", device=SensorDevice(DEVICE),
                                    field=LocalField(50.0 * (1 + 0.9 * FIELD_MAGNITUDE_TOLERANCE), 60.0 + 9.0, 100),
                                    age_s=3600.0)
    assert standing.level == GOOD and standing.good and standing.summary() == "good" and standing.age_h == 1.0


@pytest.mark.parametrize(("field", "age_s", "device", "expected"), [
    (LocalField(85.0, 60.0, 100), 60.0, DEVICE, "not good: local field 85 µT, 50 µT when calibrated"),
    (LocalField(50.0, 60.0 - FIELD_DIP_TOLERANCE_DEG - 1.0, 100), 60.0, DEVICE,
     "not good: field dip 49°, 60° when calibrated"),
    (None, (MAX_AGE_H + 6) * 3600.0, DEVICE, "not good: calibration 30 h old (at most 24 h)"),
    (None, -(MAX_AGE_H + 6) * 3600.0, DEVICE, "not good: calibration 30 h old (at most 24 h)"),
    (None, None, DEVICE, "not good: calibration date unknown"),
    (None, 60.0, "mac:0200000000AA", "not good: made on MAC A1:B2:C3:D4:E5:F6, this sensor is MAC 02:00:00:00:00:AA"),
])
def test_what_makes_a_calibration_not_good_is_said_with_its_figures(field, age_s, device, expected):
    standing = calibration_standing(calibration(), "S01", device=SensorDevice(device), field=field, age_s=age_s)
    assert standing.level == NOT_GOOD and not standing.good
    assert standing.summary() == expected


def test_a_warn_verdict_and_an_unverified_device_are_usable_with_a_warning():
    assert calibration_standing(calibration("warn"), "S01", age_s=60.0).summary() == "warn: verdict warn"
    assert calibration_standing(calibration("fail"), "S01", age_s=60.0).summary() == "not good: poor calibration"
    made_anywhere = calibration_standing(calibration(device=None), "S01", device=SensorDevice(DEVICE), age_s=60.0)
    assert made_anywhere.level == WARN and "does not say which device it was made on" in made_anywhere.summary()
    # a source that has not told the device yet: the device is not judged
    assert calibration_standing(calibration(), "S01", device=SensorDevice(), age_s=60.0).level == GOOD
    record = calibration_standing(calibration(), "S01", field=LocalField(85.0, None, 10), age_s=60.0).to_json()
    assert record["level"] == NOT_GOOD and record["local_field_uT"] == 85.0 and record["local_dip_deg"] is None
