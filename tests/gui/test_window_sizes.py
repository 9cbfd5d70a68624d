"""Nothing is clipped or jumps at the screen sizes of clinic laptops and desktops: every
window opens inside the screen's free area, no widget sticks out of its parent, no one-line
text is cut, wizard pages keep one size, the sensor table can be made to show every row.

The screen is the test display's (Xvfb); the free area of each size (the screen less a task
bar) is given to :mod:`mimucap.gui.screen_fit`, which sizes and places every window."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest
from PyQt5 import QtCore, QtWidgets

from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import simulate_session
from mimucap.gui.main_window import MainWindow
from mimucap.gui.screen_fit import FRAME_PX
from mimucap.io.session import session_from_simulation, write_session

_spec = importlib.util.spec_from_file_location("layout_checks", Path(__file__).with_name("layout_checks.py"))
layout_checks = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(layout_checks)

SIZES = [(1280, 800), (1366, 768), (1920, 1080)]
#: Height of a task bar (px): the free area of a screen is this much shorter.
TASK_BAR_PX = 40


@pytest.fixture(params=SIZES, ids=[f"{w}x{h}" for w, h in SIZES])
def screen(request, monkeypatch):
    width, height = request.param
    area = QtCore.QRect(0, 0, width, height - TASK_BAR_PX)
    monkeypatch.setattr("mimucap.gui.screen_fit.available_geometry", lambda widget=None: area)
    return area


def _spin(qtbot, ms: int = 300) -> None:
    qtbot.wait(ms)


def _problems(widget) -> list[str]:
    return layout_checks.outside_parent(widget) + layout_checks.cut_texts(widget)


def _inside(area: QtCore.QRect, window: QtWidgets.QWidget) -> bool:
    """Whether ``window`` lies in ``area`` with room for a window manager's frame (none under Xvfb)."""
    room = FRAME_PX
    return (area.contains(window.frameGeometry()) and window.width() + room.width() <= area.width()
            and window.height() + room.height() <= area.height())


@pytest.fixture
def main_window(qtbot, screen):
    window = MainWindow("simulated:demo")
    window.show()
    window.start()
    qtbot.waitExposed(window)
    qtbot.waitUntil(lambda: window.live.samples_received > 50, timeout=15000)
    window.live.publish_status()
    yield window
    if window.live is not None and window.live.recording:  # a test that failed while recording:
        window.action_record.trigger()                    # closing would ask whether to stop
        window.wait_for_saving()
    window.close()
    window.deleteLater()


def test_the_main_window_and_its_wizards_fit_each_screen(main_window, screen, qtbot, tmp_path):
    window = main_window
    assert _inside(screen, window), (window.geometry(), screen)
    qtbot.waitUntil(lambda: window.plots.refresh_count > 2, timeout=5000)
    _spin(qtbot)
    assert _problems(window) == []
    # recording: the REC indicator joins the status bar, nothing is pushed out or cut
    window.recording_folder = lambda: tmp_path
    window.confirm_recording = lambda items: True
    window.action_record.trigger()
    _spin(qtbot)
    assert window.live_status.recording_indicator.isVisible() and _problems(window) == []
    target = window.live_status.recording_target  # the file's name beside the badge, whole
    assert target.isVisible() and target.width() >= target.sizeHint().width()
    window.action_record.trigger()
    window.wait_for_saving()
    # the plots' titles are whole: the stack is as wide as its widest title asks
    window.plots.set_joints(["shoulder_r", "lumbar", "hip_l"])
    _spin(qtbot)
    stack = window.plots.layout_widget
    assert stack.width() >= stack.ci.effectiveSizeHint(QtCore.Qt.MinimumSize).width()
    # the sensor table can be made tall enough to show every row
    table = window.sensor_panel
    rows_px = table.horizontalHeader().height() + sum(table.rowHeight(r) for r in range(table.rowCount()))
    window.resizeDocks([window.sensor_dock], [rows_px + 40], QtCore.Qt.Vertical)
    qtbot.waitUntil(lambda: table.verticalScrollBar().maximum() == 0, timeout=3000)

    for name in ("magnetometer", "body"):
        window.open_wizard(name)
        wizard = window._wizard
        qtbot.waitExposed(wizard)
        assert _inside(screen, wizard), (name, wizard.geometry(), screen)
        size = wizard.size()
        for index in range(wizard.pages.count()):
            wizard.pages.setCurrentIndex(index)
            if name == "magnetometer":
                wizard.views_panel.setVisible(index > 0)  # the views come with the recording
            _spin(qtbot, 150)
            assert wizard.size() == size, (name, index)  # a page never resizes the wizard
            assert _problems(wizard) == [], (name, index)
        wizard.close()


@pytest.fixture(scope="module")
def session_file(tmp_path_factory):
    sim = simulate_session(SimulationConfig(scenario="walk", duration_s=3.0))
    path = tmp_path_factory.mktemp("sizes") / "walk.h5"
    write_session(path, session_from_simulation(sim))
    return path


def test_the_review_window_and_export_dialog_open_on_each_screen(qtbot, screen, session_file):
    from mimucap.gui.review_window import ReviewWindow

    review = ReviewWindow(session_file)
    review.show()
    review.load()
    qtbot.waitUntil(lambda: review.player is not None, timeout=20000)
    assert _inside(screen, review), (review.geometry(), screen)
    _spin(qtbot)
    assert _problems(review) == []
    dialog = review.open_export()
    qtbot.waitExposed(dialog)
    assert _inside(screen, dialog)
    assert _problems(dialog) == []
    dialog.close()
    review.close()


def test_the_analysis_library_compare_trend_and_assessment_windows_fit_each_screen(qtbot, screen, calibrated_walk,
                                                                                   tmp_path):
    """Every other window and dialog a clinician opens: on the screen, nothing cut, no column
    header clipped (the analysis window opened 1200 × 820, taller than a laptop's screen)."""
    import shutil

    from mimucap.gui.library_window import LibraryWindow
    from mimucap.gui.review_window import ReviewWindow
    from mimucap.gui.trend_dialog import TrendDialog
    from mimucap.io.library import Library
    from mimucap.session.recorded.clinical_test_results import RESULT_PREFIX

    review = ReviewWindow(calibrated_walk)
    review.show()
    review.load()
    qtbot.waitUntil(lambda: review.player is not None, timeout=20000)
    analysis = review.open_analysis()
    with qtbot.waitSignal(analysis.analysed, timeout=30000):
        pass
    for index in range(analysis.tabs.count()):
        analysis.tabs.setCurrentIndex(index)
        _spin(qtbot, 150)
        assert _inside(screen, analysis), (analysis.geometry(), screen)
        assert _problems(analysis) == [], index
    analysis.tabs.setCurrentIndex(0)
    _spin(qtbot, 150)
    assert analysis.parameters_table.horizontalScrollBar().maximum() == 0  # every column of the gait table in view
    analysis.close()
    review.close()

    root = tmp_path / "library"
    root.mkdir()
    for name in ("S001_2026-03-01_trial01.h5", "S001_2026-04-01_trial01.h5"):
        shutil.copy(calibrated_walk, root / name)
    library = Library(root)
    library.scan()
    entries = library.sessions()
    library.store_result(entries[0].path, RESULT_PREFIX + "tug", {"test": "tug", "total_s": 11.2, "result": "reprocessed"})
    window = LibraryWindow(root)
    window.show()
    window.wait_for_scan()
    _spin(qtbot)
    assert _inside(screen, window) and _problems(window) == []
    window.select_paths({e.path for e in entries})
    compare = window.compare_selected()
    qtbot.waitUntil(lambda: compare.tables or compare.error, timeout=30000)
    _spin(qtbot)
    assert _inside(screen, compare) and _problems(compare) == []
    trend = TrendDialog(library, entries[0].subject_id, window)
    trend.show()
    _spin(qtbot)
    assert _inside(screen, trend) and _problems(trend) == []
    for dialog in (trend, compare, window):
        dialog.close()


def test_the_assessment_wizards_fit_each_screen(main_window, screen, qtbot):
    window = main_window
    for name in ("rom", "clinical_test"):
        window.open_wizard(name)
        wizard = window._wizard
        qtbot.waitExposed(wizard)
        assert _inside(screen, wizard), (name, wizard.geometry(), screen)
        pages = getattr(wizard, "pages", None)
        for index in range(pages.count() if pages is not None else 1):
            if pages is not None:
                pages.setCurrentIndex(index)
            _spin(qtbot, 150)
            assert _problems(wizard) == [], (name, index)
        wizard.close()
