"""Nothing is clipped or jumps at the screen sizes of clinic laptops and desktops: the main
window, in each of its workspaces, and every dialog and wizard open inside the screen's free
area, every visible widget lies on the screen and inside its parent, no one-line text or column
header is cut, the mode bar's Record/Stop and Add Marker are in view whatever the workspace,
wizard pages keep one size, the sensor table can be made to show every row.

The screen is the test display's (Xvfb); the free area of each size (the screen less a task
bar) is given to :mod:`mimucap.gui.screen_fit`, which sizes and places every window."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest
from PyQt5 import QtCore, QtWidgets

from mimucap.gui.main_window import MainWindow
from mimucap.gui.screen_fit import FRAME_PX

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


def _problems(widget, area: QtCore.QRect | None = None) -> list[str]:
    found = layout_checks.outside_parent(widget) + layout_checks.cut_texts(widget)
    return found + (layout_checks.off_screen(widget, area) if area is not None else [])


def _actions_in_view(window) -> bool:
    """Record/Stop and Add Marker are shown, whole, in the window (the mode bar never hides them)."""
    inside = window.rect()
    return all(button.isVisible() and inside.contains(QtCore.QRect(button.mapTo(window, QtCore.QPoint(0, 0)),
                                                                   button.size()))
               for button in (window.mode_bar.record_button, window.mode_bar.marker_button))


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
    assert _problems(window, screen) == [] and _actions_in_view(window)
    # recording: the REC indicator joins the status bar and the mode bar, nothing is pushed out or cut
    window.recording_folder = lambda: tmp_path
    window.confirm_recording = lambda items: True
    window.action_record.trigger()
    _spin(qtbot)
    assert window.live_status.recording_indicator.isVisible() and window.mode_bar.recording_badge.isVisible()
    assert _problems(window, screen) == [] and _actions_in_view(window)
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
            assert _problems(wizard, screen) == [], (name, index)
        wizard.close()


def test_every_workspace_and_its_dialogs_fit_each_screen(main_window, screen, qtbot, calibrated_walk, tmp_path,
                                                         monkeypatch):
    """Review (and its export dialog), Analysis (every tab) and Library (and the comparison and
    trend dialogs), each in the main window while the live capture runs on, and recording from
    any of them: on the screen, nothing cut, no column header clipped, Record/Stop and Add Marker
    in view (the analysis window opened 1200 × 820, taller than a laptop's screen)."""
    import shutil

    from mimucap.gui.trend_dialog import TrendDialog
    from mimucap.io.library import Library
    from mimucap.session.recorded.clinical_test_results import RESULT_PREFIX

    window = main_window
    for name in ("review", "analysis"):  # nothing to show yet: each says how to get something
        window.workspace_actions[name].trigger()
        _spin(qtbot, 150)
        page = window.workspaces.currentWidget()
        assert page.currentWidget() is page.empty and page.empty.text.isVisible()
        assert _problems(window, screen) == [] and _actions_in_view(window)
    review = window.open_review(calibrated_walk)
    qtbot.waitUntil(lambda: review.ready, timeout=30000)
    assert window.workspace == "review" and window.workspaces.currentWidget() is window.review
    _spin(qtbot)
    assert _inside(screen, window) and _problems(window, screen) == [] and _actions_in_view(window)
    dialog = review.open_export()
    qtbot.waitExposed(dialog)
    assert _inside(screen, dialog)
    assert _problems(dialog, screen) == []
    dialog.close()

    window.recording_folder = lambda: tmp_path
    window.confirm_recording = lambda items: True
    window.action_record.trigger()  # recording while another workspace is shown: its state stays in view
    _spin(qtbot)
    assert window.mode_bar.recording_badge.isVisible() and window.mode_bar.record_button.text() == "■ Stop"
    window.workspace_actions["analysis"].trigger()
    analysis = window.analysis.view
    if analysis.analysis is None:
        with qtbot.waitSignal(analysis.analysed, timeout=30000):
            pass
    for index in range(analysis.tabs.count()):
        analysis.tabs.setCurrentIndex(index)
        _spin(qtbot, 150)
        assert _problems(window, screen) == [], index
        assert _actions_in_view(window) and window.mode_bar.recording_badge.isVisible()
    analysis.tabs.setCurrentIndex(0)
    _spin(qtbot, 150)
    assert analysis.parameters_table.horizontalScrollBar().maximum() == 0  # every column of the gait table in view
    window.action_record.trigger()
    window.wait_for_saving()

    root = tmp_path / "library"
    root.mkdir()
    for name in ("S001_2026-03-01_trial01.h5", "S001_2026-04-01_trial01.h5"):
        shutil.copy(calibrated_walk, root / name)
    library = Library(root)
    library.scan()
    entries = library.sessions()
    library.store_result(entries[0].path, RESULT_PREFIX + "tug", {"test": "tug", "total_s": 11.2, "result": "reprocessed"})
    monkeypatch.setattr(window, "library_folder", lambda: root)
    window.workspace_actions["library"].trigger()
    view = window.library_view
    view.wait_for_scan()
    _spin(qtbot)
    assert _problems(window, screen) == [] and _actions_in_view(window)
    view.select_paths({e.path for e in entries})
    compare = view.compare_selected()
    qtbot.waitUntil(lambda: compare.tables or compare.error, timeout=30000)
    _spin(qtbot)
    assert _inside(screen, compare) and _problems(compare, screen) == []
    trend = TrendDialog(library, entries[0].subject_id, view)
    trend.show()
    _spin(qtbot)
    assert _inside(screen, trend) and _problems(trend, screen) == []
    for dialog in (trend, compare):
        dialog.close()
    window.workspace_actions["capture"].trigger()
    _spin(qtbot)
    assert _problems(window, screen) == [] and window.sensor_dock.isVisible()


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
            assert _problems(wizard, screen) == [], (name, index)
        wizard.close()
