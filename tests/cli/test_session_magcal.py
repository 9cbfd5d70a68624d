"""The command-line session route, first half: ``mimucap simulate`` writes a demo session that
begins with the marked magnetometer turns, and ``mimucap magcal fit SESSION.h5 --save``
calibrates every sensor from them. The simulator's truth (hard and soft iron, when the units
were in the hands) is the independent reference."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mimucap.cli import main
from mimucap.cli.magcal import FAIL_EXIT_STATUS
from mimucap.core import phase_markers
from mimucap.io.calibration_store import CalibrationStore
from mimucap.io.session import read_session


@pytest.fixture(scope="module")
def demo_session(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("route") / "demo.h5"
    assert main(["simulate", "--scenario", "demo", "--duration", "36", "--sensors", "3", "--seed", "3",
                 "--out", str(out)]) == 0
    return out


def test_the_demo_session_begins_with_the_marked_turns_then_n_and_t_pose(demo_session: Path) -> None:
    session = read_session(demo_session)
    assert [m.label for m in session.markers] == ["magnetometer turns", "N-pose", "T-pose", "N-pose", "walk"]
    assert session.metadata["source"]["magcal_turns"] is True
    (start_s, end_s), = phase_markers.phase_windows(session.markers, phase_markers.MAG_TURNS, 36.0)
    (npose_s, npose_end_s), _ = phase_markers.phase_windows(session.markers, phase_markers.NPOSE, 36.0)
    assert start_s == 0.0 and npose_s == end_s and npose_end_s - npose_s == pytest.approx(4.0)
    t = session.truth.t_s
    turns = (t >= start_s) & (t < end_s)
    axis_turned = session.truth.extra["mag_axis_turned"]
    assert set(np.unique(axis_turned[turns])) == {-1, 0, 1, 2}   # one turn about each axis, in the window
    assert np.all(axis_turned[~turns] == -1)
    for sensor_id, truth in session.truth.sensors.items():
        held = truth.parameters["held"]
        assert np.all(held[turns & (t >= 1.0)] == 1.0), sensor_id       # in the hands after the pick-up
        assert np.all(held[t >= npose_s + 1.0] == 0.0), sensor_id       # worn for the still N-pose


def test_magcal_fit_saves_every_sensor_recovering_the_true_hard_and_soft_iron(demo_session: Path, capsys) -> None:
    capsys.readouterr()
    assert main(["magcal", "fit", str(demo_session), "--save"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == f"{demo_session}: 3 sensors, magnetometer turns: 0.0-26.0 s, method ellipsoid"
    session = read_session(demo_session)
    store = CalibrationStore()
    assert store.sensor_ids() == ["S01", "S02", "S03"]
    for sensor_id, truth in session.truth.sensors.items():
        row = next(line for line in lines if line.startswith(sensor_id + " "))
        assert row.split()[-2:] == ["good", "yes"], row
        calibration = store.load(sensor_id)
        assert calibration.protocol == "single_axis" and calibration.samples_used > 1500
        np.testing.assert_allclose(calibration.offset_uT, truth.mag_b_uT, atol=0.3, err_msg=sensor_id)
        # soft_iron undoes mag_A up to the field's scale, which the turns cannot tell
        undone = calibration.soft_iron @ truth.mag_A
        scale = np.trace(undone) / 3.0
        np.testing.assert_allclose(undone / scale, np.eye(3), atol=0.005, err_msg=sensor_id)
        assert scale == pytest.approx(1.0, abs=0.06)
        # the gyroscope's 1 % scale errors, estimated from the same turns, undone within 0.2 %
        assert calibration.gyr_quality["applied"] is True, calibration.gyr_quality
        undone = calibration.gyr_correction @ truth.parameters["gyr_scale"]
        np.testing.assert_allclose(np.diag(undone), 1.0, atol=0.002, err_msg=sensor_id)
        np.testing.assert_allclose(undone, np.eye(3), atol=0.005, err_msg=sensor_id)
    assert sum("gyroscope scale off by" in line and line.endswith(": corrected") for line in lines) == 3


def test_without_turns_all_samples_are_fitted_and_failing_fits_are_named_not_saved(tmp_path, capsys) -> None:
    """A demo without the turns: the worn units cover too little of the sphere, so every fit
    fails its checks, is named with its reason, and nothing is stored."""
    out = tmp_path / "no_turns.h5"
    assert main(["simulate", "--scenario", "demo", "--duration", "20", "--sensors", "3", "--seed", "3",
                 "--no-magcal-turns", "--out", str(out)]) == 0
    assert [m.label for m in read_session(out).markers][:2] == ["N-pose", "T-pose"]
    capsys.readouterr()
    assert main(["magcal", "fit", str(out), "--save"]) == FAIL_EXIT_STATUS
    captured = capsys.readouterr()
    assert "magnetometer turns: all samples (no 'magnetometer turns' marker)" in captured.out
    rows = [line.split() for line in captured.out.splitlines() if line.startswith("S0")]
    assert [(row[0], row[-2], row[-1]) for row in rows] == [(s, "fail", "-") for s in ("S01", "S02", "S03")]
    assert "fail: coverage too low" in captured.out
    assert captured.err.count("failed its quality checks: not saved") == 3
    assert CalibrationStore().sensor_ids() == []
