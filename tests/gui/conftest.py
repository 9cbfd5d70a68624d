"""GUI tests need a display: run them under Xvfb (``make test`` does)."""

from __future__ import annotations

import os

import pytest
from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap.gui.app import has_display

GUI_ENV = {"QT_API": "pyqt5"}


def pytest_collection_modifyitems(config, items):
    for item in items:
        if "tests/gui" in str(item.fspath).replace(os.sep, "/"):
            item.add_marker(pytest.mark.gui)


@pytest.fixture(autouse=True)
def _need_display():
    if not has_display():
        raise RuntimeError("the GUI tests need a display: run them under xvfb-run -a (make test does)")


@pytest.fixture
def accept_modal():
    """``accept_modal(handle)``: run ``handle(dialog)`` on the next modal dialog, from inside its
    event loop (call it just before the action that opens the dialog)."""
    def arm(handle) -> None:
        def poke() -> None:
            dialog = QtWidgets.QApplication.activeModalWidget()
            if dialog is None:
                QtCore.QTimer.singleShot(20, poke)
                return
            handle(dialog)
        QtCore.QTimer.singleShot(0, poke)
    return arm


@pytest.fixture
def left_drag(qtbot):
    """``left_drag(widget, start, step, steps=5)``: press the left button at ``start`` (a
    ``QPoint``), move by ``step`` ``steps`` times with the button held, release there. (QTest's
    mouseMove carries no pressed button, so the moves are sent as events.)"""
    def drag(widget, start, step, steps: int = 5) -> None:
        qtbot.mousePress(widget, QtCore.Qt.LeftButton, pos=start)
        for index in range(1, steps + 1):
            move = QtGui.QMouseEvent(QtCore.QEvent.MouseMove, QtCore.QPointF(start + step * index),
                                     QtCore.Qt.NoButton, QtCore.Qt.LeftButton, QtCore.Qt.NoModifier)
            QtWidgets.QApplication.sendEvent(widget, move)
        qtbot.mouseRelease(widget, QtCore.Qt.LeftButton, pos=start + step * steps)
    return drag


@pytest.fixture
def window(qtbot):
    """The main window live on the simulated suit, shown and started (closed after the test).
    Tests that may leave a recording running define their own (closing would ask first)."""
    from mimucap.gui.main_window import MainWindow

    win = MainWindow("simulated:demo")
    qtbot.addWidget(win)
    win.confirm_recording = lambda items: True  # the checklist's own tests answer it themselves
    win.show()
    win.start()
    qtbot.waitExposed(win)
    yield win
    win.close()
