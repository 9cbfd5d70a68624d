"""Pictures of windows, 3D views included.

Every VTK view of the application is a :class:`~mimucap.gui.vtk_image_widget.VtkImageWidget`
(rendered offscreen and painted as an image), so ``QWidget.grab()`` sees it like any other
widget; each visible view renders once first, so the picture shows the current state.
"""

from __future__ import annotations

from pathlib import Path

from PyQt5 import QtGui, QtWidgets

from mimucap.gui.vtk_image_widget import VtkImageWidget


def grab_window(window: QtWidgets.QWidget) -> QtGui.QPixmap:
    """The whole ``window`` as a pixmap, every visible 3D view freshly rendered."""
    for view in window.findChildren(VtkImageWidget):
        if view.isVisible() and not view.finalized:
            view.render()
    return window.grab()


def save_window_png(window: QtWidgets.QWidget, path: str | Path) -> Path:
    """Write :func:`grab_window` of ``window`` to ``path`` (PNG); raises OSError on failure."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not grab_window(window).save(str(path), "PNG"):
        raise OSError(f"could not write the screenshot {path}")
    return path
