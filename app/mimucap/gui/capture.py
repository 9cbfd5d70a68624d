"""Pictures of the window: the Qt widgets grabbed, with the VTK view's own image painted in.

``QWidget.grab()`` cannot read an OpenGL surface, so the 3D view comes out blank; the VTK
image (read back with ``vtkWindowToImageFilter``) is painted into the VTK widget's rectangle.
"""

from __future__ import annotations

from pathlib import Path

from PyQt5 import QtCore, QtGui, QtWidgets


def grab_window(window: QtWidgets.QWidget) -> QtGui.QPixmap:
    """The whole ``window`` as a pixmap, every visible ``SceneView`` painted in properly."""
    from mimucap.gui.scene.view import SceneView

    pixmap = window.grab()
    painter = QtGui.QPainter(pixmap)
    try:
        for view in window.findChildren(SceneView):
            if not view.isVisible() or not view.alive:
                continue
            image = view.grab_image()
            top_left = view.vtk_widget.mapTo(window, QtCore.QPoint(0, 0))
            target = QtCore.QRect(top_left, view.vtk_widget.size())
            painter.drawImage(target, image)
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
