"""Windows open on the screen: at their default size where it fits, smaller where it does not,
and wholly inside the screen's available area (a 1366 × 768 laptop has 1366 × about 730 free;
a 1280 × 800 window would open with its bottom row and status bar under the task bar)."""

from __future__ import annotations

from PyQt5 import QtCore, QtGui, QtWidgets

#: Room left for the window's frame and title bar, which Qt's sizes do not count (px).
FRAME_PX = QtCore.QSize(8, 32)


def available_geometry(widget: QtWidgets.QWidget | None = None) -> QtCore.QRect:
    """The free area of the screen ``widget`` is on (the primary screen by default), in pixels."""
    screen = widget.screen() if widget is not None and widget.screen() is not None else None
    screen = screen or QtGui.QGuiApplication.primaryScreen()
    return screen.availableGeometry()


def fit_on_screen(window: QtWidgets.QWidget, width: int, height: int,
                  anchor: QtWidgets.QWidget | None = None) -> QtCore.QSize:
    """Size ``window`` ``width`` × ``height`` or, where the screen is smaller, the free area
    less the frame (never below its minimum size hint), and place it inside the free area:
    centred on ``anchor`` when given (e.g. the window that opens it), else on the screen.
    Returns the size given."""
    area = available_geometry(anchor or window)
    minimum = window.minimumSizeHint()
    size = QtCore.QSize(max(min(width, area.width() - FRAME_PX.width()), minimum.width()),
                        max(min(height, area.height() - FRAME_PX.height()), minimum.height()))
    window.resize(size)
    centre = anchor.frameGeometry().center() if anchor is not None and anchor.isVisible() else area.center()
    x = min(max(centre.x() - size.width() // 2, area.left()), area.right() - size.width() - FRAME_PX.width() + 1)
    y = min(max(centre.y() - size.height() // 2, area.top()), area.bottom() - size.height() - FRAME_PX.height() + 1)
    window.move(max(x, area.left()), max(y, area.top()))
    return size
