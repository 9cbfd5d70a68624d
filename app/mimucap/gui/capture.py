"""Pictures of windows: the Qt widgets grabbed, with each VTK view's own image painted in.

``QWidget.grab()`` cannot read an OpenGL surface, so a 3D view comes out blank; the VTK image
(read back with ``vtkWindowToImageFilter``) is painted into the VTK widget's rectangle. Any
child widget with a ``vtk_widget`` and a ``grab_image()`` method (the skeleton view, the
magnetometer wizard's ellipsoid view) is treated that way.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PyQt5 import QtCore, QtGui, QtWidgets
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkRenderingCore import vtkRenderWindow, vtkWindowToImageFilter


def render_window_image(render_window: vtkRenderWindow) -> QtGui.QImage:
    """Render ``render_window`` once and read its back buffer into an RGB ``QImage``."""
    render_window.Render()
    capture = vtkWindowToImageFilter()
    capture.SetInput(render_window)
    capture.SetInputBufferTypeToRGB()
    capture.ReadFrontBufferOff()
    capture.Update()
    image = capture.GetOutput()
    width, height, _ = image.GetDimensions()
    pixels = vtk_to_numpy(image.GetPointData().GetScalars()).reshape(height, width, 3)
    pixels = np.ascontiguousarray(pixels[::-1])  # VTK rows run bottom-up
    return QtGui.QImage(pixels.data, width, height, 3 * width, QtGui.QImage.Format_RGB888).copy()


def grab_window(window: QtWidgets.QWidget) -> QtGui.QPixmap:
    """The whole ``window`` as a pixmap, every visible VTK view painted in properly."""
    pixmap = window.grab()
    painter = QtGui.QPainter(pixmap)
    try:
        for child in window.findChildren(QtWidgets.QWidget):
            vtk_widget = getattr(child, "vtk_widget", None)
            if vtk_widget is None or not hasattr(child, "grab_image"):
                continue
            if not child.isVisible() or not vtk_widget.isVisible() or not getattr(child, "alive", True):
                continue
            image = child.grab_image()
            top_left = vtk_widget.mapTo(window, QtCore.QPoint(0, 0))
            painter.drawImage(QtCore.QRect(top_left, vtk_widget.size()), image)
    finally:
        painter.end()
    return pixmap


def save_window_png(window: QtWidgets.QWidget, path: str | Path) -> Path:
    """Write :func:`grab_window` of ``window`` to ``path`` (PNG); raises OSError on failure."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not grab_window(window).save(str(path), "PNG"):
        raise OSError(f"could not write the screenshot {path}")
    return path
