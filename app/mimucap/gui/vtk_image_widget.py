"""A VTK view drawn offscreen and shown as an image in a plain Qt widget.

Why not VTK's ``QVTKRenderWindowInteractor`` (an on-screen OpenGL window inside Qt)? On a
machine without a GPU (Mesa's llvmpipe, e.g. under Xvfb) presenting an on-screen VTK frame
costs two full-window framebuffer blits plus the GLX buffer swap: 7–8 ms of CPU for an
*empty* 500 × 560 frame, which alone would eat most of a core at 60 frames per second. Rendering
into VTK's offscreen framebuffer and reading the pixels back costs 1.5 ms for the same frame,
and Qt then shows the picture like any other widget (``bench/bench_gui.py`` measures the
whole window). With a GPU, the read-back of ~1 MB per frame is a fraction of a millisecond.

The widget forwards Qt's mouse and wheel events to a ``vtkGenericRenderWindowInteractor``
with VTK's trackball-camera style (orbit with the left button, pan with the middle one or
Shift+left, zoom with the right one or the wheel). Every ``Render()`` of the window,
whoever asks for it (this widget, the interactor style, a screenshot), is read back and
painted. Because the picture is an ordinary Qt image, ``QWidget.grab()`` sees it too.
"""

from __future__ import annotations

import numpy as np
import vtkmodules.vtkInteractionStyle  # noqa: F401  (registers the interactor styles)
import vtkmodules.vtkRenderingFreeType  # noqa: F401  (text rendering)
import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (the OpenGL back end)
from PyQt5 import QtCore, QtGui, QtWidgets
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkCommand, vtkUnsignedCharArray
from vtkmodules.vtkInteractionStyle import vtkInteractorStyleTrackballCamera
from vtkmodules.vtkRenderingCore import vtkRenderWindow
from vtkmodules.vtkRenderingUI import vtkGenericRenderWindowInteractor

_BUTTON_EVENTS = {
    QtCore.Qt.LeftButton: ("LeftButtonPressEvent", "LeftButtonReleaseEvent"),
    QtCore.Qt.MiddleButton: ("MiddleButtonPressEvent", "MiddleButtonReleaseEvent"),
    QtCore.Qt.RightButton: ("RightButtonPressEvent", "RightButtonReleaseEvent"),
}


class VtkImageWidget(QtWidgets.QWidget):
    """One offscreen ``vtkRenderWindow`` (:attr:`render_window`) shown as a Qt image.

    Attributes:
        render_window: add renderers to it; call :meth:`render` (or its ``Render()``) to
            draw. Its size follows the widget's size in device pixels.
        interactor: the ``vtkGenericRenderWindowInteractor`` driven by Qt's mouse events.

    Signals:
        rendered(): after each frame was read back (the widget repaints itself).
    """

    rendered = QtCore.pyqtSignal()

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setAttribute(QtCore.Qt.WA_OpaquePaintEvent)
        self.setFocusPolicy(QtCore.Qt.WheelFocus)
        self.setMinimumSize(160, 120)
        self.render_window = vtkRenderWindow()
        self.render_window.SetMultiSamples(0)  # MSAA costs 4x on software OpenGL
        self.render_window.OffScreenRenderingOn()
        self.render_window.SetSize(max(1, self.width()), max(1, self.height()))
        self.interactor = vtkGenericRenderWindowInteractor()
        self.interactor.SetRenderWindow(self.render_window)
        self.interactor.SetInteractorStyle(vtkInteractorStyleTrackballCamera())
        self._pixels = vtkUnsignedCharArray()
        self._image: QtGui.QImage | None = None
        self._buffer: np.ndarray | None = None  # keeps the QImage's memory alive
        self._initialized = False
        self._finalized = False
        self._reading = False
        self.render_window.AddObserver(vtkCommand.EndEvent, self._on_render_end)

    # -- life cycle --------------------------------------------------------------------------
    def Initialize(self) -> None:  # noqa: N802 (same name as VTK's Qt widget)
        """Create the OpenGL context (idempotent; rendering initialises on demand too)."""
        if not self._initialized and not self._finalized:
            self.interactor.Initialize()
            self._initialized = True

    def Finalize(self) -> None:  # noqa: N802
        """Release the OpenGL context; the widget then shows its last picture only."""
        if self._finalized:
            return
        self._finalized = True
        self.render_window.RemoveAllObservers()
        self.render_window.Finalize()
        self.interactor.SetRenderWindow(None)

    @property
    def finalized(self) -> bool:
        return self._finalized

    def render(self) -> None:
        """Draw one frame now (nothing after :meth:`Finalize`)."""
        if self._finalized:
            return
        self.Initialize()
        self.render_window.Render()

    # -- read-back and painting ----------------------------------------------------------------
    def _on_render_end(self, _caller, _event) -> None:
        if self._reading or self._finalized:
            return
        self._reading = True
        try:
            width, height = self.render_window.GetSize()
            self.render_window.GetRGBACharPixelData(0, 0, width - 1, height - 1, 0, self._pixels, 0)
            rgba = vtk_to_numpy(self._pixels).reshape(height, width, 4)
            if self._buffer is None or self._buffer.shape != rgba.shape:
                self._buffer = np.empty_like(rgba)
                self._image = QtGui.QImage(self._buffer.data, width, height, 4 * width,
                                           QtGui.QImage.Format_RGBX8888)
                self._image.setDevicePixelRatio(self.devicePixelRatioF())
            np.copyto(self._buffer, rgba[::-1])  # VTK's rows run bottom-up
        finally:
            self._reading = False
        self.update()
        self.rendered.emit()

    def image(self) -> QtGui.QImage:
        """A copy of the last frame (RGB, device pixels); a null image before the first one."""
        return QtGui.QImage() if self._image is None else self._image.convertToFormat(QtGui.QImage.Format_RGB888)

    def paintEvent(self, event: QtGui.QPaintEvent) -> None:  # noqa: N802 (Qt API)
        painter = QtGui.QPainter(self)
        if self._image is None:
            painter.fillRect(self.rect(), QtGui.QColor(64, 71, 87))
        else:
            painter.drawImage(QtCore.QPoint(0, 0), self._image)
        painter.end()

    def resizeEvent(self, event: QtGui.QResizeEvent) -> None:  # noqa: N802
        super().resizeEvent(event)
        if self._finalized:
            return
        ratio = self.devicePixelRatioF()
        width = max(1, int(round(self.width() * ratio)))
        height = max(1, int(round(self.height() * ratio)))
        self.render_window.SetSize(width, height)
        self.interactor.SetSize(width, height)
        self.interactor.ConfigureEvent()
        if self._initialized:
            self.render()

    # -- mouse -----------------------------------------------------------------------------------
    def _set_event_position(self, event: QtGui.QMouseEvent | QtGui.QWheelEvent, repeat: int = 0) -> None:
        ratio = self.devicePixelRatioF()
        position = event.pos() if isinstance(event, QtGui.QMouseEvent) else event.position().toPoint()
        modifiers = event.modifiers()
        self.interactor.SetEventInformationFlipY(
            int(round(position.x() * ratio)), int(round(position.y() * ratio)),
            1 if modifiers & QtCore.Qt.ControlModifier else 0,
            1 if modifiers & QtCore.Qt.ShiftModifier else 0, chr(0), repeat, None)

    def mousePressEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802
        names = _BUTTON_EVENTS.get(event.button())
        if names is None or self._finalized:
            return
        self.Initialize()
        self._set_event_position(event, repeat=1 if event.type() == QtCore.QEvent.MouseButtonDblClick else 0)
        getattr(self.interactor, names[0])()

    mouseDoubleClickEvent = mousePressEvent

    def mouseReleaseEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802
        names = _BUTTON_EVENTS.get(event.button())
        if names is None or self._finalized:
            return
        self._set_event_position(event)
        getattr(self.interactor, names[1])()

    def mouseMoveEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802
        if self._finalized:
            return
        self._set_event_position(event)
        self.interactor.MouseMoveEvent()

    def wheelEvent(self, event: QtGui.QWheelEvent) -> None:  # noqa: N802
        if self._finalized:
            return
        self.Initialize()
        self._set_event_position(event)
        if event.angleDelta().y() > 0:
            self.interactor.MouseWheelForwardEvent()
        elif event.angleDelta().y() < 0:
            self.interactor.MouseWheelBackwardEvent()
