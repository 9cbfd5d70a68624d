"""Interaction bugs a new user met, each held by a test that failed before its fix."""

from __future__ import annotations

import pytest
from PyQt5 import QtCore, QtGui, QtWidgets


def _review(qtbot, path):
    from mimucap.gui.review_window import ReviewWindow

    review = ReviewWindow(path)
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


def test_switching_the_result_keeps_the_export_dialog_and_its_ticks(qtbot, calibrated_walk):
    from mimucap.gui.review_window import ReviewWindow

    review = ReviewWindow(calibrated_walk)
    qtbot.addWidget(review)
    review.export_when_loaded = True  # as File → Export Last Recording opens it
    review.show()
    review.load()
    qtbot.waitUntil(lambda: review.export_dialog is not None, timeout=30000)
    dialog = review.export_dialog
    dialog.want_c3d.setChecked(True)
    other = review.result_combo.findData(next(review.result_combo.itemData(k) for k in range(review.result_combo.count())
                                              if k != review.result_combo.currentIndex()))
    with qtbot.waitSignal(review.loaded, timeout=30000):
        review.result_combo.setCurrentIndex(other)
    assert review.export_dialog is dialog and dialog.want_c3d.isChecked()
    assert dialog.data is review.player.data  # the summary follows the result shown
    review.close()


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
    review.close()


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


@pytest.mark.parametrize("keys", ["Esc", "Ctrl+W"])
def test_the_library_closes_with_esc_and_ctrl_w(qtbot, tmp_path, keys):
    from mimucap.gui.library_window import LibraryWindow

    window = LibraryWindow(tmp_path / "lib")
    qtbot.addWidget(window)
    window.show()
    qtbot.waitExposed(window)
    window.wait_for_scan()
    _activate(qtbot, window)
    sequence = QtGui.QKeySequence(keys)
    qtbot.keyClick(window, sequence[0] & ~QtCore.Qt.KeyboardModifierMask,
                   QtCore.Qt.KeyboardModifiers(sequence[0] & QtCore.Qt.KeyboardModifierMask))
    assert not window.isVisible()


def test_the_analysis_window_closes_with_esc(qtbot, calibrated_walk):
    review = _review(qtbot, calibrated_walk)
    window = review.open_analysis()
    with qtbot.waitSignal(window.analysed, timeout=30000):
        pass
    _activate(qtbot, window)
    qtbot.keyClick(window, QtCore.Qt.Key_Escape)
    assert not window.isVisible()
    review.close()
