"""A widget in a frameless scroll area: a small window scrolls it instead of being held at the
widget's full size (the session panel, the stack of live plots)."""

from __future__ import annotations

from PyQt5 import QtCore, QtWidgets


def scrolling(widget: QtWidgets.QWidget, parent: QtWidgets.QWidget | None = None,
              horizontal: bool = True) -> QtWidgets.QScrollArea:
    """``widget`` in a frameless, widget-resizable scroll area; ``horizontal=False`` never
    scrolls sideways (the widget takes the area's width)."""
    area = QtWidgets.QScrollArea(parent)
    area.setFrameShape(QtWidgets.QFrame.NoFrame)
    area.setWidgetResizable(True)
    if not horizontal:
        area.setHorizontalScrollBarPolicy(QtCore.Qt.ScrollBarAlwaysOff)
    area.setWidget(widget)
    return area
