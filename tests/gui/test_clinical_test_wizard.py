"""Assess → Clinical Test, driven as a clinician would on the simulated subject: both
calibrations through their wizards, then the Timed Up and Go chosen, the subject seated, the
countdown and start signal; the recording ends by itself when the subject sits again, and the
result comes from the saved session through the ``protocol`` command's path, is kept in the
library and makes a report; then the 10-metre walk and the chair stand, one after the other (one
calibration for all: the calibrations are the end-to-end tests' business). The simulated subject
does what the wizard asks; its true phase durations (from its own schedule, never read by the
result) grade the result."""

from __future__ import annotations

import json

import pytest
from PyQt5 import QtCore

from mimucap.session.recorded.clinical_test_results import RESULT_PREFIX, subject_trend
from mimucap.session.recorded.clinical_tests import run_clinical_test
from tests.gui.live_window import calibrate, closed, live_window


@pytest.fixture
def calibrated_window(qtbot, tmp_path, monkeypatch):
    from mimucap.gui import main_window

    monkeypatch.setattr(main_window.MainWindow, "library_folder", staticmethod(lambda: tmp_path / "library"))
    window = live_window(qtbot, "simulated:demo")
    calibrate(window, qtbot)
    yield window
    closed(window)


def _true_tug_s(activities: list[tuple[float, str]]) -> float:
    """The simulated subject's Timed Up and Go from its schedule's entries (start time in
    simulator time, activity; the result never reads them): from the onset of its rise to the
    end of sitting down again."""
    rise = next(t for t, label in activities if label == "sit_to_stand")
    last_sit_down = max(k for k, (_t, label) in enumerate(activities) if label == "stand_to_sit")
    return next(t for t, label in activities[last_sit_down:] if label == "sit") - rise


def test_the_guided_tests_record_measure_and_report(calibrated_window, qtbot, tmp_path):
    window = calibrated_window
    live = window.live
    window.action_clinical_test.trigger()
    wizard = window._wizard
    wizard.choose("tug")
    wizard.age.setValue(72)
    wizard.sex.setCurrentIndex(wizard.sex.findData("female"))
    assert wizard.walkway.isVisible() and wizard.chair.isVisible() and not wizard.weight.isHidden()
    assert wizard.ready_button.isEnabled(), wizard.choice_status.text()
    qtbot.mouseClick(wizard.ready_button, QtCore.Qt.LeftButton)
    qtbot.waitUntil(lambda: live.simulator.current_activity() == "sit", timeout=20000)
    entries: dict[float, str] = {}  # the schedule forgets old entries: noted while the test runs

    def note_activity(_frame_id, _geometry) -> None:
        if wizard.procedure is not None and wizard.procedure.state == "running":
            entries.update(live.simulator.schedule.entries)

    live.events.frame.connect(note_activity)
    qtbot.mouseClick(wizard.countdown_button, QtCore.Qt.LeftButton)
    assert live.recording
    qtbot.waitUntil(lambda: wizard.procedure.state == "running", timeout=20000)
    qtbot.waitUntil(lambda: wizard.result is not None or "No result" in wizard.result_status.text(), timeout=120000)
    assert wizard.result is not None, wizard.result_status.text()
    result = wizard.result
    assert wizard.procedure.ended_by == "sensors: seated again"
    live.events.frame.disconnect(note_activity)
    # Graded by the simulated subject's own schedule (the result never reads it).
    true_total = _true_tug_s(sorted(entries.items()))
    assert abs(result.values["total_s"] - true_total) < 0.5, (result.values, true_total)
    phases = sum(result.values[k] for k in ("sit_to_stand_s", "walk_out_s", "turn_s", "walk_back_s", "turn_to_sit_s"))
    assert phases == pytest.approx(result.values["total_s"], abs=1e-6)
    # The same file through the command's path gives the same numbers.
    again = run_clinical_test(wizard.session_path, "tug")
    assert again.values == pytest.approx(result.values)
    # The session says which test it holds, with its settings and the start signal.
    from mimucap.io.session import read_metadata

    meta = read_metadata(wizard.session_path)
    assert meta["clinical_test"]["test"] == "tug" and meta["clinical_test"]["chair_height_cm"] == 43.0
    assert meta["subject"]["age_years"] == 72 and meta["subject"]["sex"] == "female"
    # The reference for a woman of 72 is shown, and the result is kept for the trend.
    assert result.reference is not None and "70" in result.reference["group"]
    cells = [wizard.result_table.item(0, c).text() for c in range(3)]
    assert cells[0] == "Total time" and cells[1].endswith(" s") and "mean" in cells[2]
    from mimucap.io.library import Library

    library = Library(tmp_path / "library")
    stored = library.result(wizard.session_path, RESULT_PREFIX + "tug")
    assert json.loads(json.dumps(stored))["total_s"] == pytest.approx(result.values["total_s"])
    assert [v.values["total_s"] for v in subject_trend(library, meta["subject"]["id"], "tug")] == \
        pytest.approx([result.values["total_s"]])
    report = wizard.write_report(tmp_path / "tug.pdf")
    assert report.stat().st_size > 5000
    # The session's full report has the test's page (the same result, the reference).
    from mimucap.cli import main

    full = tmp_path / "full.pdf"
    assert main(["report", str(wizard.session_path), "--out", str(full)]) == 0
    import subprocess

    text = subprocess.run(["pdftotext", str(full), "-"], capture_output=True, text=True, check=True).stdout
    assert "Timed Up and Go" in text and f"{result.values['total_s']:.1f} s" in text and "Bohannon" in text

    check_ten_metre_walk_and_chair_stand(window, qtbot)


def _run_guided(wizard, qtbot, test: str) -> None:
    wizard.run_again()
    wizard.choose(test)
    qtbot.mouseClick(wizard.ready_button, QtCore.Qt.LeftButton)
    qtbot.mouseClick(wizard.countdown_button, QtCore.Qt.LeftButton)
    try:
        qtbot.waitUntil(lambda: wizard.result is not None or "No result" in wizard.result_status.text(), timeout=120000)
    except Exception:
        p = wizard.procedure
        raise AssertionError(f"{test}: state {p.state}, {wizard.live.simulator.current_activity()}, "
                             f"history {list(p._history)[-10:]}, left start {p._left_start}, {wizard.result_status.text()}")
    assert wizard.result is not None, wizard.result_status.text()


def check_ten_metre_walk_and_chair_stand(window, qtbot) -> None:
    """The 10-metre walk and the chair stand run guided one after the other (Run Again)."""
    wizard = window._wizard
    entries: dict[float, str] = {}
    live = window.live
    live.events.frame.connect(lambda *_: entries.update(live.simulator.schedule.entries))

    _run_guided(wizard, qtbot, "10mwt")
    assert wizard.procedure.ended_by == "sensors: standing still again"
    # plausible for the simulated subject (1.0-1.45 m/s); accuracy is the protocol route tests' business
    assert 0.9 < wizard.result.values["speed_m_s"] < 1.6 and 80 < wizard.result.values["cadence_steps_min"] < 150
    assert wizard.chair.isHidden() and not wizard.walkway.isHidden()

    entries.clear()
    _run_guided(wizard, qtbot, "chair-stand")
    assert wizard.procedure.ended_by == "time"
    rises = sorted(t for t, label in entries.items() if label == "sit_to_stand")
    true_stands = sum(1 for t in rises if t < rises[0] + 30.0 - 0.6)  # up (or more than halfway) by 30 s
    assert abs(wizard.result.values["stands"] - true_stands) <= 1, (wizard.result.values, true_stands)
