"""The Analysis workspace on the recording in Review: gait and ROM tabs filled from a simulated session
(processed like a real one: no truth in the file), curves, marker ROM, report button."""

from __future__ import annotations

import pytest
from PyQt5 import QtWidgets

from mimucap.core.simulate.config import SimulationConfig
from mimucap.session.recorded.gait_validation import simulated_analysis

ROM_MARKERS = ((30.0, "rom:knee_flexion:left:start"), (37.0, "rom:knee_flexion:left:end"))


def index_of(combo, text):
    return next(i for i in range(combo.count()) if text in combo.itemText(i))


@pytest.fixture(scope="module")
def session_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("analysis")
    config = SimulationConfig(scenario="demo", duration_s=40.0, n_sensors=10, errors="bno055", seed=2)
    _, analysis = simulated_analysis(config, folder, ROM_MARKERS)
    return analysis.review.path


def test_the_analysis_workspace_shows_gait_rom_and_writes_the_report(qtbot, window, session_file, tmp_path,
                                                                     monkeypatch):
    main = window
    main.workspace_actions["analysis"].trigger()  # nothing in Review: the workspace says where to get one
    assert main.analysis.view is None and "recording in Review" in main.analysis.empty.text.text()
    review, window = analysed_in_review(qtbot, main, session_file)
    assert main.workspace == "analysis" and main.workspaces.currentWidget() is main.analysis
    assert "straight strides analysed" in window.gait_summary.text()
    assert window.parameters_table.rowCount() == 8
    assert window.strides_table.rowCount() == len(window.analysis.gait.strides)
    refused = [window.strides_table.item(r, 7).text() for r in range(window.strides_table.rowCount())]
    assert any(text != "analysed" for text in refused)
    assert window.curve_choice.currentText() == "Knee flexion"
    assert len(window.curve_plot.listDataItems()) >= 2  # left and right means at least
    window.tabs.setCurrentWidget(window.rom_tab)
    assert window.rom_table.rowCount() == 1 and window.rom_table.item(0, 0).text() == "Knee flexion"
    # ROM between the squat markers (30 s .. 37 s) finds the knees and hips of the squats.
    window.marker_from.setCurrentIndex(index_of(window.marker_from, "Knee flexion (left) — start"))
    window.marker_to.setCurrentIndex(index_of(window.marker_to, "Knee flexion (left) — end"))
    window.compute_marker_rom()
    movements = {window.marker_table.item(r, 0).text() for r in range(window.marker_table.rowCount())}
    assert {"Knee flexion", "Hip flexion"} <= movements
    out = tmp_path / "report.pdf"
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName", lambda *a, **k: (str(out), "PDF (*.pdf)"))
    assert window.report_button.isEnabled()
    window.report_button.click()
    assert out.read_bytes().startswith(b"%PDF")
    # Back in Review, another result: the analysis shown is of the old one, so it is made again.
    main.show_workspace("review")
    with qtbot.waitSignal(review.loaded, timeout=30000):
        review.set_result("live")
    assert main.analysis.view is None
    main.workspace_actions["analysis"].trigger()
    assert main.analysis.view is not window and main.analysis.view.data.result == "live"


def pdf_text(path) -> str:
    """The PDF's text, by poppler's pdftotext (another program than the writer)."""
    import shutil
    import subprocess

    if shutil.which("pdftotext") is None:
        pytest.fail("pdftotext (Debian poppler-utils) is needed: make debs installs it")
    text = subprocess.run(["pdftotext", "-layout", str(path), "-"], check=True, capture_output=True, text=True).stdout
    return text.replace("\ufb01", "fi").replace("\ufb02", "fl")  # the font's ligatures


def analysed_in_review(qtbot, main, path, result: str = "reprocessed"):
    """``path`` in the Review workspace of main window ``main`` showing ``result``, and its view
    in the Analysis workspace once analysed."""
    review = main.open_review(path)
    with qtbot.waitSignal(review.loaded, timeout=30000):
        pass
    if result != review.result:
        with qtbot.waitSignal(review.loaded, timeout=30000):
            review.set_result(result)
    main.workspace_actions["analysis"].trigger()
    view = main.analysis.view
    if view.analysis is None:
        with qtbot.waitSignal(view.analysed, timeout=30000):
            pass
    return review, view


@pytest.mark.parametrize("result", ["reprocessed", "live"])
def test_the_windows_report_and_the_command_agree_for_the_same_result(qtbot, window, session_file, tmp_path, result):
    """The report and the tables made in the window while review shows a result, and ``mimucap
    report`` of the same file for the same result: the same text and the same numbers, each
    saying which result it holds on its first page."""
    from mimucap.cli import main
    from mimucap.session.recorded.analysis import write_analysis_csv

    review, view = analysed_in_review(qtbot, window, session_file, result)
    view.write_report(tmp_path / "window.pdf")
    window_tables = write_analysis_csv(tmp_path / "window", view.analysis)
    assert main(["report", str(session_file), "--out", str(tmp_path / "command.pdf"), "--csv", str(tmp_path / "command")]
                + (["--live"] if result == "live" else [])) == 0
    shown, written = pdf_text(tmp_path / "window.pdf"), pdf_text(tmp_path / "command.pdf")
    first_page = written.split("\f")[0]
    assert ("Result: as seen live" if result == "live" else "Result: reprocessed") in first_page
    assert "Body calibration: N-pose/T-pose, " in first_page and "Source file: simulated_demo_10.h5" in first_page
    assert "the device fuses its orientation on board" in " ".join(first_page.split())  # however it wraps
    assert shown == written
    assert len(window_tables) >= 4
    for table in window_tables:
        assert table.read_text() == (tmp_path / "command" / table.name).read_text(), table.name


@pytest.fixture(scope="module")
def uncalibrated_file(tmp_path_factory):
    """A simulated walk written without a body calibration (sensor axes only)."""
    from mimucap.core.simulate.suit import simulate_session
    from mimucap.io.session import session_from_simulation, write_session

    path = tmp_path_factory.mktemp("uncalibrated") / "walk.h5"
    config = SimulationConfig(scenario="walk", duration_s=15.0, n_sensors=10, errors="bno055", seed=2)
    return write_session(path, session_from_simulation(simulate_session(config), include_truth=False))


def test_without_a_body_calibration_the_analysis_gives_temporal_parameters_only(qtbot, window, uncalibrated_file,
                                                                               tmp_path):
    review, window = analysed_in_review(qtbot, window, uncalibrated_file)
    assert not window.analysis.calibrated
    assert window.limits_label.isVisible() and "no body calibration" in window.limits_label.text()
    assert "straight strides analysed" in window.gait_summary.text()
    rows = {window.parameters_table.item(r, 0).text(): window.parameters_table.item(r, 3).text()
            for r in range(window.parameters_table.rowCount())}
    assert rows["Cadence (steps/min)"].split(" ± ")[0] != "–"  # temporal: given
    assert rows["Stride length (m)"] == "– ± –" and rows["Gait speed (m/s)"] == "– ± –"  # spatial: not
    for widget in (window.report_button, window.curve_choice, window.marker_button):
        assert not widget.isEnabled() and "no body calibration" in widget.toolTip()
    assert not window.tabs.isTabEnabled(window.tabs.indexOf(window.rom_tab))
    assert "no body calibration" in window.tabs.tabToolTip(window.tabs.indexOf(window.rom_tab))
    assert window.csv_button.isEnabled()  # the temporal tables, labelled
    with pytest.raises(ValueError, match="no body calibration"):
        window.write_report(tmp_path / "report.pdf")
