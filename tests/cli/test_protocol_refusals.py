"""``mimucap protocol`` refuses what it cannot answer, naming what to give: a session without a
body calibration (``--calibration``), a recording without the test, a wrong option."""

from __future__ import annotations

import pytest

from mimucap.cli import main


@pytest.fixture(scope="module")
def short_walk(tmp_path_factory):
    folder = tmp_path_factory.mktemp("protocol")
    session = folder / "walk.h5"
    assert main(["simulate", "--scenario", "bodycal", "--duration", "12", "--no-magcal-turns", "--out",
                 str(session)]) == 0
    return folder, session


def test_a_session_without_a_body_calibration_is_refused(short_walk, capsys):
    folder, session = short_walk
    out = folder / "tug.json"
    assert main(["protocol", "tug", str(session), "--out", str(out)]) == 1
    error = capsys.readouterr().err
    assert "no body calibration" in error and "--calibration" in error
    assert not out.exists()


def test_a_recording_without_the_test_says_so(short_walk, capsys, monkeypatch):
    folder, session = short_walk
    monkeypatch.setenv("MIMUCAP_DATA_DIR", str(folder / "data"))
    calibration = folder / "cal.json"
    assert main(["bodycal", str(session), "--out", str(calibration)]) == 0
    capsys.readouterr()
    assert main(["protocol", "tug", str(session), "--calibration", str(calibration), "--out",
                 str(folder / "tug.json")]) == 1
    assert "no rise from the chair" in capsys.readouterr().err
    assert main(["protocol", "2mwt", str(session), "--calibration", str(calibration), "--walkway", "20",
                 "--out", str(folder / "w.json")]) == 1
    assert "--walkway applies to the 10-metre walk only" in capsys.readouterr().err
