"""The Analysis window of the review: gait and ROM tabs filled from a simulated session
(processed like a real one: no truth in the file), curves, marker ROM, report button."""

from __future__ import annotations

import pytest
from PyQt5 import QtWidgets

from mimucap.core.simulate.config import SimulationConfig
from mimucap.gui.review_window import ReviewWindow
from mimucap.session.analysis_evaluation import simulated_analysis

ROM_MARKERS = ((30.0, "rom:knee_flexion:left:start"), (37.0, "rom:knee_flexion:left:end"))


def index_of(combo, text):
    return next(i for i in range(combo.count()) if text in combo.itemText(i))


@pytest.fixture(scope="module")
def session_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("analysis")
    config = SimulationConfig(scenario="demo", duration_s=40.0, n_sensors=10, errors="bno055", seed=2)
    _, analysis = simulated_analysis(config, folder, ROM_MARKERS)
    return analysis.review.path


def test_analysis_window_shows_gait_rom_and_writes_the_report(qtbot, session_file, tmp_path, monkeypatch):
    review = ReviewWindow(session_file)
    qtbot.addWidget(review)
    review.show()
    with qtbot.waitSignal(review.loaded, timeout=30000):
        review.load()
    assert review.action_analysis.isEnabled()
    window = review.open_analysis()
    with qtbot.waitSignal(window.analysed, timeout=30000):
        pass
    assert "straight strides analysed" in window.gait_summary.text()
    assert window.parameters_table.rowCount() == 8
    assert window.strides_table.rowCount() == len(window.analysis.gait.strides)
    refused = [window.strides_table.item(r, 7).text() for r in range(window.strides_table.rowCount())]
    assert any(text != "analysed" for text in refused)
    assert window.curve_choice.currentText() == "knee flexion"
    assert len(window.curve_plot.listDataItems()) >= 2  # left and right means at least
    window.tabs.setCurrentWidget(window.rom_tab)
    assert window.rom_table.rowCount() == 1 and window.rom_table.item(0, 0).text() == "Knee flexion"
    # ROM between the squat markers (30 s .. 37 s) finds the knees and hips of the squats.
    window.marker_from.setCurrentIndex(index_of(window.marker_from, "rom:knee_flexion:left:start"))
    window.marker_to.setCurrentIndex(index_of(window.marker_to, "rom:knee_flexion:left:end"))
    window.compute_marker_rom()
    movements = {window.marker_table.item(r, 0).text() for r in range(window.marker_table.rowCount())}
    assert {"Knee flexion", "Hip flexion"} <= movements
    out = tmp_path / "report.pdf"
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName", lambda *a, **k: (str(out), "PDF (*.pdf)"))
    assert window.report_button.isEnabled()
    window.report_button.click()
    assert out.read_bytes().startswith(b"%PDF")
    review.close()
