"""Calibration store: versioned JSON per sensor, session embedding, refusals, corrupt files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mimucap.core.magcal import MagCalibration
from mimucap.io.calibration_store import (
    CALIBRATION_FORMAT_VERSION,
    CalibrationFileError,
    CalibrationStore,
    calibration_from_session,
    calibration_to_json,
    embed_in_session,
    user_data_dir,
)
from mimucap.io.session import Session, read_session, write_session

SOFT_IRON = np.array([[1.02, 0.01, -0.03], [0.01, 0.97, 0.02], [-0.03, 0.02, 1.05]])


def make(sensor_id: str = "S01") -> MagCalibration:
    return MagCalibration(
        sensor_id=sensor_id, offset_uT=np.array([12.5, -3.0, 40.25]), soft_iron=SOFT_IRON, field_uT=49.3,
        created_utc="2026-11-21T06:00:00Z", protocol="single_axis", samples_used=1234,
        quality={"rms_residual_uT": 0.42, "condition": 4.2, "verdict": "good", "reasons": [], "dip_std_deg": None},
    )


def test_default_location_follows_the_environment(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.setenv("MIMUCAP_DATA_DIR", str(tmp_path / "override"))
    assert CalibrationStore().directory == tmp_path / "override" / "calibrations" / "magnetometer"
    monkeypatch.delenv("MIMUCAP_DATA_DIR")
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert user_data_dir() == tmp_path / "xdg" / "mimucap"
    monkeypatch.delenv("XDG_DATA_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert user_data_dir() == tmp_path / "home" / ".local" / "share" / "mimucap"


def test_round_trip_is_exact_and_versioned() -> None:
    store = CalibrationStore()
    path = store.save(make())
    data = json.loads(path.read_text())
    assert data["format"] == "mimucap-magcal" and data["format_version"] == CALIBRATION_FORMAT_VERSION
    assert data["sensor_id"] == "S01" and data["protocol"] == "single_axis" and data["samples_used"] == 1234
    assert data["created_utc"] == "2026-11-21T06:00:00Z" and data["quality"]["verdict"] == "good"
    loaded = store.load("S01")
    np.testing.assert_array_equal(loaded.offset_uT, make().offset_uT)
    np.testing.assert_array_equal(loaded.soft_iron, SOFT_IRON)
    assert loaded.field_uT == 49.3 and loaded.quality == make().quality
    assert store.sensor_ids() == ["S01"]
    store.save(make("S02"))
    assert store.sensor_ids() == ["S01", "S02"]
    assert not list(store.directory.glob(".*tmp"))


def test_another_sensor_id_is_refused() -> None:
    store = CalibrationStore()
    path = store.save(make("S01"))
    path.rename(path.with_name("S05.json"))  # a file copied onto another sensor's name
    with pytest.raises(CalibrationFileError, match="belongs to sensor 'S01', not 'S05'"):
        store.load("S05")
    with pytest.raises(ValueError, match="cannot be applied to sensor 'S05'"):
        make("S01").apply([[0.0, 0.0, 0.0]], "S05")


def test_missing_corrupt_foreign_and_newer_files() -> None:
    store = CalibrationStore()
    with pytest.raises(FileNotFoundError, match="S01"):
        store.load("S01")
    path = store.save(make())
    path.write_text('{"format": "mimucap-magcal", "format_version": 1, "sensor_id": "S01", "offset_uT": [1, 2')
    with pytest.raises(CalibrationFileError, match=r"S01\.json: corrupt"):
        store.load("S01")
    path.write_text(json.dumps({"format": "something-else"}))
    with pytest.raises(CalibrationFileError, match="not a MimuCap magnetometer calibration"):
        store.load("S01")
    data = calibration_to_json(make())
    data["format_version"] = CALIBRATION_FORMAT_VERSION + 1
    path.write_text(json.dumps(data))
    with pytest.raises(CalibrationFileError, match="newer"):
        store.load("S01")
    data = calibration_to_json(make())
    data["soft_iron"] = [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]
    path.write_text(json.dumps(data))
    with pytest.raises(CalibrationFileError, match="symmetric"):
        store.load("S01")
    del data["offset_uT"]
    path.write_text(json.dumps(data))
    with pytest.raises(CalibrationFileError, match="offset_uT"):
        store.load("S01")


def test_unsafe_sensor_ids_cannot_name_files() -> None:
    store = CalibrationStore()
    for bad in ("../evil", "a/b", "", ".hidden"):
        with pytest.raises(ValueError, match="sensor id"):
            store.path_for(bad)


def test_session_embeds_the_calibrations_it_used(tmp_path: Path) -> None:
    session = Session(metadata={"source": "test"})
    embed_in_session(session.calibrations, make("S01"))
    embed_in_session(session.calibrations, make("S02"))
    write_session(tmp_path / "s.h5", session)
    loaded = read_session(tmp_path / "s.h5")
    calibration = calibration_from_session(loaded.calibrations, "S02")
    assert calibration.sensor_id == "S02"
    np.testing.assert_array_equal(calibration.soft_iron, SOFT_IRON)
    with pytest.raises(KeyError, match="S03"):
        calibration_from_session(loaded.calibrations, "S03")


def _with_device(sensor_id: str, device_id: str | None) -> MagCalibration:
    from dataclasses import replace

    return replace(make(sensor_id), device_id=device_id)


def test_a_calibration_is_kept_for_its_device_and_labelled_by_its_sensor_id() -> None:
    from mimucap.core.device_identity import SensorDevice

    store = CalibrationStore()
    path = store.save(_with_device("S01", "mac:A1B2C3D4E5F6"))
    assert path == store.directory / "devices" / "mac_A1B2C3D4E5F6.json"
    assert json.loads(path.read_text())["device_id"] == "mac:A1B2C3D4E5F6"
    assert store.sensor_ids() == ["S01"] and store.load("S01").device_id == "mac:A1B2C3D4E5F6"
    # the device answering to another id (its node re-numbered) still finds its own calibration
    found = store.lookup("S07", SensorDevice("mac:A1B2C3D4E5F6"))
    assert found.calibration is not None and found.calibration.device_id == "mac:A1B2C3D4E5F6" and found.note == ""
    # another device numbered S01 does not take it, and is told why
    found = store.lookup("S01", SensorDevice("mac:0200000000AA"))
    assert found.calibration is None
    assert found.note == ("the calibration stored under S01 is of MAC A1:B2:C3:D4:E5:F6 (2026-11-21T06:00:00Z); "
                          "this sensor is MAC 02:00:00:00:00:AA: not used, calibrate it here")
    # a sensor that does not say which device it is does not take a device's calibration either
    found = store.lookup("S01", SensorDevice(None, "its node sends no hello"))
    assert found.calibration is None and "S01 does not say which device it is (its node sends no hello)" in found.note
    # and a sensor whose source has not said yet gets nothing, and no note, until it does
    pending = store.lookup("S01", SensorDevice())
    assert pending.calibration is None and pending.note == ""
    store.save(_with_device("S01", "mac:0200000000AA"))
    with pytest.raises(CalibrationFileError, match="2 devices have a calibration labelled S01"):
        store.load("S01")
    assert store.load("S01", "mac:0200000000AA").device_id == "mac:0200000000AA"


def test_an_older_calibration_without_a_device_is_never_given_silently_to_a_known_device() -> None:
    """A format-1 file (written before calibrations were tied to devices) may belong to any
    device numbered S01: a sensor of a known device does not take it and is told why; a sensor
    whose source says no device (an older node) takes it, unverified."""
    from mimucap.core.device_identity import SensorDevice
    from mimucap.core.magcal_standing import WARN, calibration_standing

    store = CalibrationStore()
    old = calibration_to_json(make("S01"))
    old["format_version"] = 1
    del old["device_id"]
    (store.directory).mkdir(parents=True)
    (store.directory / "S01.json").write_text(json.dumps(old))
    found = store.lookup("S01", SensorDevice("sim:0011aabb/S01"))
    assert found.calibration is None
    assert found.note == ("the calibration stored under S01 was made before calibrations were tied to a device "
                          "(2026-11-21T06:00:00Z); this sensor is simulated unit S01 of suit 0011aabb: not used, "
                          "calibrate it here")
    older_node = SensorDevice(None, "its node sends no hello")
    found = store.lookup("S01", older_node)
    assert found.calibration is not None and found.calibration.device_id is None
    standing = calibration_standing(found.calibration, "S01", device=older_node, age_s=600.0)
    assert standing.level == WARN and standing.summary() == "warn: device not verified: its node sends no hello"
