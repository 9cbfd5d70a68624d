"""The README's command-line route on a simulated session: simulate → magcal fit --save →
bodycal (pose windows from the session's markers, stored magnetometer calibrations) → angles.
The simulator's truth, stored in the session, is the independent reference: no command reads it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mimucap.cli import main
from mimucap.core import phases
from mimucap.io.angles_export import read_angles_csv
from mimucap.io.session import read_session
from mimucap.session.evaluation import angle_errors

COLUMNS = ("hip_l_flexion_deg", "hip_r_flexion_deg", "knee_l_flexion_deg", "knee_r_flexion_deg")


@pytest.fixture(scope="module")
def route(tmp_path_factory):
    """The route's files, and the user data folder where magcal stored the calibrations."""
    folder = tmp_path_factory.mktemp("route")
    session = folder / "demo.h5"
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MIMUCAP_DATA_DIR", str(folder / "data"))
        assert main(["simulate", "--scenario", "demo", "--duration", "90", "--seed", "3", "--out", str(session)]) == 0
        assert main(["magcal", "fit", str(session), "--save"]) == 0
        calibration = folder / "CAL.json"
        assert main(["bodycal", str(session), "--out", str(calibration)]) == 0
    return folder, session, calibration


@pytest.fixture(autouse=True)
def _route_data(route, monkeypatch):
    monkeypatch.setenv("MIMUCAP_DATA_DIR", str(route[0] / "data"))


@pytest.mark.parametrize("live", [False, True])
def test_knee_and_hip_flexion_while_walking_match_the_truth(route, live, capsys):
    folder, session, calibration = route
    out = folder / f"angles{'_live' if live else ''}.csv"
    assert main(["angles", str(session), "--calibration", str(calibration), "--out", str(out)]
                + (["--live"] if live else [])) == 0
    printed = capsys.readouterr().out
    assert "magnetometer S01: stored" in printed
    header = [line for line in out.read_text().splitlines() if line.startswith("#")]
    assert any(("as seen live" if live else "reprocessed") in line for line in header)
    table = read_angles_csv(out)
    recorded = read_session(session)
    assert [m.label for m in table.markers] == [m.label for m in recorded.markers]  # the record's markers
    walks = phases.phase_windows(recorded.markers, phases.WALK, float(table.t_s[-1]))
    assert len(walks) >= 2
    for window in walks:
        errors = angle_errors(table.t_s, table.angles_deg, recorded.truth.t_s, recorded.truth.joint_angles_deg,
                              span_s=(window[0] + 1.0, window[1]))
        for column in COLUMNS:
            assert errors[column].rms_deg < 3.0, (window, column, errors[column])



def test_the_npose_orientations_come_from_the_still_calibrated_sensors(route):
    """Every sensor has a stored magnetometer calibration: its N-pose orientation is the static
    alignment of its accelerometer and calibrated field, within a few degrees of the smoothed
    filter's (what the calibration file records per sensor)."""
    _folder, _session, calibration = route
    document = json.loads(calibration.read_text())
    differences = document["npose_track_vs_given_deg"]
    assert set(differences) == {entry["sensor"] for entry in document["segments"].values()}
    assert max(differences.values()) < 5.0, differences

def test_a_poor_calibration_is_refused_unless_accepted(route, tmp_path, capsys):
    folder, session, calibration = route
    document = json.loads(calibration.read_text())
    document["verdict"] = "poor"
    document["quality"]["verdict"] = "poor"
    document["quality"]["problems"] = ["the arms disagree"]
    poor = tmp_path / "poor.json"
    poor.write_text(json.dumps(document))
    assert main(["angles", str(session), "--calibration", str(poor), "--out", str(tmp_path / "a.csv")]) != 0
    assert "verdict is poor (the arms disagree)" in capsys.readouterr().err
    assert not (tmp_path / "a.csv").exists()
    assert main(["angles", str(session), "--calibration", str(poor), "--out", str(tmp_path / "a.csv"),
                 "--accept-poor"]) == 0


def test_bodycal_without_pose_markers_says_what_to_give(tmp_path, capsys):
    session = tmp_path / "walk.h5"
    assert main(["simulate", "--scenario", "walk", "--duration", "5", "--no-magcal-turns", "--out", str(session)]) == 0
    assert main(["bodycal", str(session), "--out", str(tmp_path / "cal.json")]) != 0
    assert "give --npose and --tpose" in capsys.readouterr().err
