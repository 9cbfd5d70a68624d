"""Interaction bugs a new user met, each held by a test that failed before its fix."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
from PyQt5 import QtCore, QtGui, QtWidgets


def _review(qtbot, path):
    from mimucap.gui.review_view import ReviewView

    review = ReviewView(path)
    qtbot.addWidget(review)
    review.show()
    review.load()
    qtbot.waitUntil(lambda: review.player is not None, timeout=30000)
    return review


def _activate(qtbot, window) -> None:
    """Make ``window`` the active one: its shortcuts answer only then."""
    window.activateWindow()
    window.raise_()
    qtbot.waitUntil(lambda: QtWidgets.QApplication.activeWindow() is window, timeout=5000)


def test_switching_the_result_keeps_the_export_dialog_and_its_ticks(qtbot, window, calibrated_walk):
    window.last_recording = SimpleNamespace(session_path=calibrated_walk, samples={"S01": 1})  # as after Stop
    window.action_export.trigger()  # nothing in Review: the last recording opens there and exports
    review = window.review.view
    assert window.workspace == "review" and review.path == calibrated_walk
    qtbot.waitUntil(lambda: review.export_dialog is not None, timeout=30000)
    dialog = review.export_dialog
    dialog.want_c3d.setChecked(True)
    other = review.result_combo.findData(next(review.result_combo.itemData(k) for k in range(review.result_combo.count())
                                              if k != review.result_combo.currentIndex()))
    with qtbot.waitSignal(review.loaded, timeout=30000):
        review.result_combo.setCurrentIndex(other)
    assert review.export_dialog is dialog and dialog.want_c3d.isChecked()
    assert dialog.data is review.player.data  # the summary follows the result shown
    window.action_export.trigger()  # a recording in Review: its dialog again, not the last recording
    assert window.review.view is review and review.export_dialog is not dialog
    review.export_dialog.close()


def test_a_click_on_a_marker_in_the_timeline_jumps_there(qtbot, calibrated_walk):
    review = _review(qtbot, calibrated_walk)
    plot = review.timeline.getPlotItem()
    assert plot.buttonsHidden  # no auto-range "A" button on a timeline that always shows everything
    marker = review.player.data.markers[1]
    view = plot.vb
    scene_point = view.mapViewToScene(QtCore.QPointF(marker.t_s + 2.0 * view.viewPixelSize()[0], 0.5))
    widget_point = review.timeline.mapFromScene(scene_point)
    review.seek(review.player.data.start_s)
    qtbot.mouseClick(review.timeline.viewport(), QtCore.Qt.LeftButton, pos=widget_point)
    assert review.player.cursor_s == pytest.approx(marker.t_s, abs=1e-6)
    elsewhere = review.timeline.mapFromScene(view.mapViewToScene(QtCore.QPointF(marker.t_s + 0.8, 0.5)))
    qtbot.mouseClick(review.timeline.viewport(), QtCore.Qt.LeftButton, pos=elsewhere)
    assert review.player.cursor_s == pytest.approx(marker.t_s + 0.8, abs=0.05)
    review.shutdown()


def test_the_wheel_over_a_segment_choice_scrolls_instead_of_reassigning(qtbot):
    from mimucap.gui.assignment_dialog import AssignmentDialog

    dialog = AssignmentDialog(None, [f"S{k:02d}" for k in range(1, 11)], ["pelvis", "thorax", "thigh_l", "thigh_r"],
                              {"S01": "pelvis"})
    qtbot.addWidget(dialog)
    dialog.show()
    combo = dialog.combos["S01"]
    before = combo.currentIndex()
    wheel = QtGui.QWheelEvent(QtCore.QPointF(5, 5), QtCore.QPointF(combo.mapToGlobal(QtCore.QPoint(5, 5))),
                              QtCore.QPoint(0, 0), QtCore.QPoint(0, -120), QtCore.Qt.NoButton, QtCore.Qt.NoModifier,
                              QtCore.Qt.NoScrollPhase, False)
    QtWidgets.QApplication.sendEvent(combo, wheel)
    assert combo.currentIndex() == before
    assert not wheel.isAccepted()  # left to the table, which scrolls


def _press(qtbot, widget, keys: str) -> None:
    sequence = QtGui.QKeySequence(keys)
    qtbot.keyClick(widget, sequence[0] & ~QtCore.Qt.KeyboardModifierMask,
                   QtCore.Qt.KeyboardModifiers(sequence[0] & QtCore.Qt.KeyboardModifierMask))


def test_ctrl_1_to_4_switch_the_workspaces_and_ctrl_w_closes_the_recording(qtbot, window, calibrated_walk):
    """Analysis and Library are workspaces of the main window (they were windows that did not
    close with Esc or Ctrl+W): the keys switch between them; Ctrl+W closes the recording in Review."""
    _activate(qtbot, window)
    for index, name in enumerate(("capture", "review", "analysis", "library"), start=1):
        _press(qtbot, window, f"Ctrl+{index}")
        assert window.workspace == name and window.mode_bar.workspace_actions[name].isChecked()
        assert window.session_dock.isVisible() == (name == "capture")  # the live panels belong to Capture
    review = window.open_review(calibrated_walk)
    qtbot.waitUntil(lambda: review.ready, timeout=30000)
    window.show_workspace("capture")
    _press(qtbot, window, "Ctrl+Space")  # View → Play/Pause Review: plays the recording in Review, shown
    assert review.player.playing and window.workspace == "review" and review.play_button.text() == "❚❚ Pause"
    window.action_play.trigger()
    assert not review.player.playing
    _press(qtbot, window, "Ctrl+W")
    assert window.review.view is None and window.review.currentWidget() is window.review.empty


@pytest.mark.parametrize("keys", ["Esc", "Ctrl+W"])
def test_the_comparison_closes_with_esc_and_ctrl_w(qtbot, tmp_path, calibrated_walk, keys):
    import shutil

    from mimucap.gui.library_view import LibraryView

    root = tmp_path / "lib"
    root.mkdir()
    for name in ("S001_2026-03-01_trial01.h5", "S001_2026-04-01_trial01.h5"):
        shutil.copy(calibrated_walk, root / name)
    library = LibraryView(root)
    qtbot.addWidget(library)
    library.show()
    library.wait_for_scan()
    library.select_paths(set(library.entries))
    dialog = library.compare_selected()
    qtbot.waitExposed(dialog)
    _activate(qtbot, dialog)
    with qtbot.waitSignal(dialog.finished, timeout=5000):
        _press(qtbot, dialog, keys)
    assert not dialog.isVisible() and dialog not in library.compare_dialogs
    library.shutdown()
