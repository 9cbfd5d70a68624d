"""Pictures of windows, 3D views included.

Every VTK view of the application is a :class:`~mimucap.gui.vtk_image_widget.VtkImageWidget`
(rendered offscreen and painted as an image), so ``QWidget.grab()`` sees it like any other
widget; each visible view renders once first, so the picture shows the current state.
"""

from __future__ import annotations

import logging
from pathlib import Path

from PyQt5 import QtGui, QtWidgets

from mimucap.gui.vtk_image_widget import VtkImageWidget

log = logging.getLogger(__name__)


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


def save_screenshot(window: QtWidgets.QMainWindow, path: str | Path) -> Path:
    """:func:`save_window_png` of ``window``, said in its status bar; raises OSError on failure."""
    written = save_window_png(window, path)
    window.statusBar().showMessage(f"Screenshot saved to {written}", 5000)
    return written


def ask_to_save_screenshot(window: QtWidgets.QMainWindow, default_name: str) -> Path | None:
    """Ask where to :func:`save_screenshot` ``window`` and write it; a failure is said in a
    dialog (and the log). Returns the file written, if any."""
    path, _ = QtWidgets.QFileDialog.getSaveFileName(window, "Save Screenshot", default_name, "PNG images (*.png)")
    if not path:
        return None
    try:
        return save_screenshot(window, path)
    except OSError as error:
        log.warning("screenshot not saved: %s", error)
        QtWidgets.QMessageBox.warning(window, "Screenshot not saved",
                                      f"{path} could not be written: {error}\n\nChoose another folder.")
        return None
