"""The commands judge the magnetometer calibrations they apply as the live view does: a stored
calibration goes only to its own device (``magcal fit --save`` of one simulated suit is not
taken by another suit numbered alike), and one whose local field no longer fits the recording
is named with its figures by ``bodycal`` (which exits 3 unless ``--accept-poor``), ``angles``,
``export``, ``gait`` and ``report``."""

from __future__ import annotations

import json
import re

import pytest

from mimucap.cli import main
from mimucap.cli.bodycal import EXIT_POOR
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.magnetic_field import EarthField
from mimucap.core.simulate.suit import simulate_session
from mimucap.io.calibration_store import CalibrationStore, embed_in_session
from mimucap.io.session import read_session, session_from_simulation, write_session

#: The export of the sensors' own orientations (no body calibration needed; the magnetometers judged).
SENSOR_ORIENTATIONS = ("--format", "sto", "--raw-sensors", "--out")
FIELD = re.compile(r"the magnetometer calibration of Pelvis sensor \(S01\) is not good: local field (\d+) µT, "
                   r"(\d+) µT when calibrated")


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    """Three simulated demo sessions of 50 s and the store ``magcal fit --save`` made from the
    first: ``here`` (seed 3, where the calibrations were made), ``other_suit`` (seed 4: another
    suit numbered S01…), ``other_room`` (seed 3, the same suit, in a field of 85 µT)."""
    folder = tmp_path_factory.mktemp("readiness")
    data = folder / "data"
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MIMUCAP_DATA_DIR", str(data))
        here, other_suit = folder / "here.h5", folder / "other-suit.h5"
        assert main(["simulate", "--scenario", "demo", "--duration", "50", "--seed", "3", "--out", str(here)]) == 0
        assert main(["simulate", "--scenario", "demo", "--duration", "50", "--seed", "4", "--out", str(other_suit)]) == 0
        assert main(["magcal", "fit", str(here), "--save"]) == 0
    other_room = folder / "other-room.h5"
    config = SimulationConfig(scenario="demo", duration_s=50.0, seed=3, magcal_turns=True,
                              earth_field=EarthField(magnitude_uT=85.0))
    write_session(other_room, session_from_simulation(simulate_session(config)))
    return {"folder": folder, "data": data, "here": here, "other_suit": other_suit, "other_room": other_room}


@pytest.fixture(autouse=True)
def _store(sessions, monkeypatch):
    monkeypatch.setenv("MIMUCAP_DATA_DIR", str(sessions["data"]))


def check_field_figures(err: str) -> None:
    """The pelvis sensor's figures: the field the recording's samples give through the
    calibration (85 µT times the calibration's scale), and the calibration's own."""
    calibration = CalibrationStore().load("S01")
    local, when = map(int, FIELD.search(err).groups())
    assert when == round(calibration.field_uT)
    assert abs(local - 85.0 * calibration.field_uT / 49.3) <= 2.0


def test_in_the_room_of_its_calibrations_the_suit_is_good(sessions, tmp_path, capsys):
    assert main(["bodycal", str(sessions["here"]), "--out", str(tmp_path / "cal.json")]) == 0
    out, err = capsys.readouterr()
    assert re.search(r"magnetometer S01: stored \(.*devices/sim_[0-9a-f]{8}_S01\.json\); good\n", out)
    assert "warning" not in err
    standing = json.loads((tmp_path / "cal.json").read_text())["magnetometer_standing"]["S01"]
    assert standing["level"] == "good" and standing["local_field_uT"] == pytest.approx(49.3, abs=2.0)


def test_another_suit_numbered_alike_takes_none_and_says_so(sessions, tmp_path, capsys):
    # raw fields: the poses' orientations are doubtful and the verdict may be poor; used anyway
    assert main(["bodycal", str(sessions["other_suit"]), "--out", str(tmp_path / "cal.json"), "--accept-poor"]) == 0
    out, err = capsys.readouterr()
    stored = CalibrationStore().load("S01").device_id.split("/")[0].removeprefix("sim:")
    theirs = read_session(sessions["other_suit"]).metadata["devices"]["S01"]["device_id"].split("/")[0].removeprefix("sim:")
    why = (f"the calibration stored under S01 is of simulated unit S01 of suit {stored} (")
    assert f"magnetometer S01: not calibrated (raw field used): {why}" in out
    assert f"this sensor is simulated unit S01 of suit {theirs}: not used, calibrate it here" in out
    assert f"mimucap bodycal: warning: Pelvis sensor (S01) is not calibrated: {why}" in err
    assert err.count("is not calibrated: the calibration stored under") == 10


def test_a_calibration_whose_field_no_longer_fits_fails_bodycal_unless_accepted(sessions, tmp_path, capsys):
    cal = tmp_path / "cal.json"
    assert main(["bodycal", str(sessions["other_room"]), "--out", str(cal)]) == EXIT_POOR
    out, err = capsys.readouterr()
    check_field_figures(err)
    assert "calibrate it again where the recording is made" in err
    assert err.count("is not good: local field") == 10
    assert "the magnetometer calibration of S01, S02, S03, S04, S05, S06, S07, S08, S09, S10 is not good" in err
    assert "pass --accept-poor" in err
    assert re.search(r"magnetometer S01: stored \(.*\); not good: local field \d+ µT, \d+ µT when calibrated", out)
    assert json.loads(cal.read_text())["magnetometer_standing"]["S01"]["level"] == "not good"   # written all the same
    assert main(["bodycal", str(sessions["other_room"]), "--accept-poor", "--out", str(cal)]) == 0
    check_field_figures(capsys.readouterr().err)
    assert main(["angles", str(sessions["other_room"]), "--calibration", str(cal), "--out",
                 str(tmp_path / "a.csv")]) == 0
    err = capsys.readouterr().err
    check_field_figures(err)
    assert err.startswith("mimucap angles: warning: ")


def test_a_recording_carrying_a_calibration_that_no_longer_fits_is_named_by_export_gait_and_report(
        sessions, tmp_path, capsys):
    cal = tmp_path / "cal.json"
    assert main(["bodycal", str(sessions["other_room"]), "--accept-poor", "--out", str(cal)]) == 0
    session = read_session(sessions["other_room"])
    store = CalibrationStore()
    for sensor_id in session.sensors:                    # recorded with the calibrations of another room
        embed_in_session(session.calibrations, store.load(sensor_id))
    session.calibrations["body"] = json.loads(cal.read_text())
    recording = tmp_path / "recorded.h5"
    write_session(recording, session)
    capsys.readouterr()
    assert main(["export", str(recording), *SENSOR_ORIENTATIONS, str(tmp_path / "e.sto")]) == 0
    err = capsys.readouterr().err
    assert err.startswith("mimucap export: warning: ")
    check_field_figures(err)
    assert main(["gait", str(recording), "--out", str(tmp_path / "gait")]) == 0
    err = capsys.readouterr().err
    assert "mimucap gait: warning: the magnetometer calibration of Pelvis sensor (S01)" in err
    check_field_figures(err)
    assert main(["report", str(recording), "--out", str(tmp_path / "r.pdf")]) == 0
    err = capsys.readouterr().err
    assert "mimucap report: warning: the magnetometer calibration of Pelvis sensor (S01)" in err
    check_field_figures(err)


def test_a_recording_without_magnetometer_calibrations_says_whose_raw_field_is_used(sessions, tmp_path, capsys,
                                                                                    monkeypatch):
    # Its own devices' stored calibrations are applied, without a word; another suit's are not.
    assert main(["export", str(sessions["here"]), *SENSOR_ORIENTATIONS, str(tmp_path / "e.sto")]) == 0
    assert "warning" not in capsys.readouterr().err
    assert main(["export", str(sessions["other_suit"]), *SENSOR_ORIENTATIONS, str(tmp_path / "o.sto")]) == 0
    assert "Pelvis sensor (S01) is not calibrated: the calibration stored under S01" in capsys.readouterr().err
    monkeypatch.setenv("MIMUCAP_DATA_DIR", str(tmp_path / "empty"))  # nothing stored, nothing recorded
    assert main(["export", str(sessions["here"]), *SENSOR_ORIENTATIONS, str(tmp_path / "r.sto")]) == 0
    assert ("mimucap export: warning: the recording holds no magnetometer calibration for S01, S02, S03 and 7 more: "
            "their raw field is used") in capsys.readouterr().err
