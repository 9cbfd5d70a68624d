"""Full-page screenshots of widgets holding VTK views.

A Qt ``grab()`` leaves OpenGL child windows black; :func:`grab_page` paints each visible VTK
view's own read-back image (``grab_image()``) into that view's rectangle of the Qt grab.
"""

from __future__ import annotations

from PyQt5 import QtCore, QtGui, QtWidgets


def grab_page(widget: QtWidgets.QWidget) -> QtGui.QImage:
    """``widget`` as a ``QImage`` with its visible VTK views (anything with ``grab_image``
    and a ``vtk_widget``) painted in."""
    image = widget.grab().toImage()
    painter = QtGui.QPainter(image)
    try:
        for child in widget.findChildren(QtWidgets.QWidget):
            vtk_widget = getattr(child, "vtk_widget", None)
            if vtk_widget is None or not hasattr(child, "grab_image") or not vtk_widget.isVisible():
                continue
            if not getattr(child, "alive", True):
                continue
            picture = child.grab_image()
            origin = vtk_widget.mapTo(widget, QtCore.QPoint(0, 0))
            target = QtCore.QRect(origin, vtk_widget.size())
            painter.drawImage(target, picture)
    finally:
        painter.end()
    return image
