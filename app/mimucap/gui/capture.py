"""Pictures of windows, 3D views included.

Every VTK view of the application is a :class:`~mimucap.gui.vtk_widget.VtkWidget`: a native
OpenGL window, which ``QWidget.grab()`` does not paint. :func:`grab_window` grabs the Qt
widgets, then draws each visible view afresh, reads its picture back from OpenGL
(:meth:`~mimucap.gui.vtk_widget.VtkWidget.image`) and puts it where the view stands.
"""

from __future__ import annotations

import logging
from pathlib import Path

from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap.gui.vtk_widget import VtkWidget

log = logging.getLogger(__name__)


def grab_window(window: QtWidgets.QWidget) -> QtGui.QPixmap:
    """The whole ``window`` as a pixmap, every visible 3D view freshly rendered in it."""
    pixmap = window.grab()
    painter = QtGui.QPainter(pixmap)
    for view in window.findChildren(VtkWidget):
        if not view.isVisible() or view.finalized:
            continue
        area = view.visibleRegion().boundingRect()  # the part of the view not hidden by its parents
        if area.isEmpty():
            continue
        image = view.image()
        corner = view.mapTo(window, QtCore.QPoint(0, 0))
        ratio = image.devicePixelRatio()
        source = QtCore.QRectF(area.x() * ratio, area.y() * ratio, area.width() * ratio, area.height() * ratio)
        painter.drawImage(QtCore.QRectF(area.translated(corner)), image, source)
    painter.end()
    return pixmap


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
