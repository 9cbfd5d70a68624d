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
