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

The pictures may also be drawn elsewhere (:meth:`VtkImageWidget.set_remote`): the skeleton view
has a render process draw them (``mimucap.gui.scene.render_client``) and hands them to
:meth:`VtkImageWidget.show_frame`; this widget's own window then never draws, its camera still
follows the mouse, and each turn asks for a new picture.

Text labels anchored in the scene (e.g. the names of the world axes) are painted by Qt over the
picture (:class:`OverlayLabel`, from :attr:`VtkImageWidget.label_provider` after every frame):
VTK's caption actors re-rasterised their text and rebuilt their shaders on every frame in
which the scene moved, 5 % of a core at 60 frames per second (``bench/bench_gui.py``).

On Mesa's software OpenGL the rasteriser draws without helper threads unless the user chose
otherwise (:mod:`mimucap.gui.software_gl`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

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

from mimucap.gui.software_gl import prefer_unthreaded_software_gl


_BUTTON_EVENTS = {
    QtCore.Qt.LeftButton: ("LeftButtonPressEvent", "LeftButtonReleaseEvent"),
    QtCore.Qt.MiddleButton: ("MiddleButtonPressEvent", "MiddleButtonReleaseEvent"),
    QtCore.Qt.RightButton: ("RightButtonPressEvent", "RightButtonReleaseEvent"),
}


@dataclass(frozen=True)
class OverlayLabel:
    """A text painted over the picture, centred on ``(x_px, y_px)``: device pixels of the
    render window, from the left and from the *top*; ``rgb`` 0..255."""

    text: str
    x_px: float
    y_px: float
    rgb: tuple[int, int, int] = (255, 255, 255)


class VtkImageWidget(QtWidgets.QWidget):
    """One offscreen ``vtkRenderWindow`` (:attr:`render_window`) shown as a Qt image.

    Attributes:
        render_window: add renderers to it; call :meth:`render` (or its ``Render()``) to
            draw. Its size follows the widget's size in device pixels.
        interactor: the ``vtkGenericRenderWindowInteractor`` driven by Qt's mouse events.
        label_provider: called after every frame (``None``: no labels); returns the
            :class:`OverlayLabel` s to paint over it.
        label_point_size: point size of the labels' bold font.
        hint: a message painted in a box in the middle of the picture (``""``: none), e.g.
            what the view is waiting for; set it with :meth:`set_hint`.

    Signals:
        rendered(): after each frame was read back (the widget repaints itself).
    """

    rendered = QtCore.pyqtSignal()

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setAttribute(QtCore.Qt.WA_OpaquePaintEvent)
        self.setFocusPolicy(QtCore.Qt.WheelFocus)
        self.setMinimumSize(160, 120)
        prefer_unthreaded_software_gl()  # before the first context
        self.render_window = vtkRenderWindow()
        self.render_window.SetMultiSamples(0)  # MSAA costs 4x on software OpenGL
        self.render_window.OffScreenRenderingOn()
        # The frame is read back from VTK's render framebuffer (``front`` = 0 below). At the
        # end of each frame VTK would copy it, colour and depth, to its display framebuffer
        # ("swap buffers") and on to the hidden window's: on software OpenGL 0.5 ms of waste.
        self.render_window.SetFrameBlitModeToNoBlit()
        self.render_window.SwapBuffersOff()
        self.render_window.SetSize(max(1, self.width()), max(1, self.height()))
        self.interactor = vtkGenericRenderWindowInteractor()
        self.interactor.SetRenderWindow(self.render_window)
        self.interactor.SetInteractorStyle(vtkInteractorStyleTrackballCamera())
        self._pixels = vtkUnsignedCharArray()
        self._image: QtGui.QImage | None = None
        self._buffer: np.ndarray | None = None  # the copy of the last frame (show_frame)
        self._image_source: np.ndarray | None = None  # the memory the QImage shows, kept alive
        self._initialized = False
        self._finalized = False
        self._reading = False
        self._remote = None
        self.label_provider: Callable[[], Sequence[OverlayLabel]] | None = None
        self.label_point_size = 10.0
        self._labels: tuple[OverlayLabel, ...] = ()
        self.hint = ""
        self._label_font: tuple[tuple, QtGui.QFont, QtGui.QFontMetricsF] | None = None
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
        """Draw one frame now and show it (nothing after :meth:`Finalize`); with a remote
        renderer (:meth:`set_remote`), wait until its picture is shown."""
        if self._finalized:
            return
        self.Initialize()
        if self._remote is not None:
            self._remote.render(wait=True)
        else:
            self.render_window.Render()

    # -- read-back and painting ----------------------------------------------------------------
    def _on_render_end(self, _caller, _event) -> None:
        if self._reading or self._finalized or self._remote is not None:
            return
        self._reading = True
        try:
            width, height = self.render_window.GetSize()
            self.render_window.GetRGBACharPixelData(0, 0, width - 1, height - 1, 0, self._pixels, 0)
            rgba = vtk_to_numpy(self._pixels).reshape(height, width, 4)
            labels = tuple(self.label_provider()) if self.label_provider is not None else ()
            self.show_frame(rgba[::-1], labels)  # VTK's rows run bottom-up
        finally:
            self._reading = False

    def show_frame(self, pixels: np.ndarray, labels: Sequence[OverlayLabel] = (),
                   image_format: QtGui.QImage.Format = QtGui.QImage.Format_RGBX8888, copy: bool = True) -> None:
        """Show the picture ``pixels`` ``(height, width, 4)`` (bytes in ``image_format``, rows
        from the top) with ``labels`` over it, and emit :attr:`rendered`. With ``copy=False``
        the widget shows ``pixels`` in place: the caller keeps that memory valid and unchanged
        until the next call."""
        height, width = pixels.shape[:2]
        if copy:
            if self._buffer is None or self._buffer.shape != pixels.shape:
                self._buffer = np.empty((height, width, 4), dtype=np.uint8)
            np.copyto(self._buffer, pixels)
            pixels = self._buffer
        if self._image is None or self._image_source is not pixels or self._image.format() != image_format:
            self._image = QtGui.QImage(pixels.data, width, height, 4 * width, image_format)
            self._image.setDevicePixelRatio(self.devicePixelRatioF())
            self._image_source = pixels
        self._labels = tuple(labels)
        self.update()
        self.rendered.emit()

    # -- drawing in another process -------------------------------------------------------------
    def set_remote(self, remote) -> None:
        """Have ``remote`` draw the pictures from now on (``None``: draw here again).

        ``remote`` has ``render(wait: bool)``, which draws the scene as it is now and brings the
        picture back through :meth:`show_frame` (e.g. a
        :class:`~mimucap.gui.scene.render_client.RenderClient`). This window then never draws:
        the mouse still turns the camera here, and each turn asks ``remote`` for a frame."""
        self._remote = remote
        if remote is None:
            self.interactor.EnableRenderOn()
        else:
            self.interactor.EnableRenderOff()

    @property
    def remote(self):
        """Who draws the pictures (``None``: this widget)."""
        return self._remote

    def _camera_moved(self) -> None:
        """After a mouse event: a frame from the remote renderer (VTK's interactor style renders
        by itself when this widget draws)."""
        if self._remote is not None:
            self._remote.render(wait=False)

    def set_hint(self, text: str) -> None:
        """Show ``text`` in the middle of the picture (``""`` removes it); repaints only when it
        changes."""
        if text != self.hint:
            self.hint = text
            self.update()

    @property
    def labels(self) -> tuple[OverlayLabel, ...]:
        """The labels painted over the last frame."""
        return self._labels

    def image(self) -> QtGui.QImage:
        """A copy of the last frame with its labels (RGB, device pixels); a null image before
        the first one."""
        if self._image is None:
            return QtGui.QImage()
        image = self._image.convertToFormat(QtGui.QImage.Format_RGB888)
        painter = QtGui.QPainter(image)  # logical pixels: the copy keeps the device pixel ratio
        self._paint_labels(painter)
        self._paint_hint(painter, QtCore.QRectF(0.0, 0.0, image.width() / image.devicePixelRatio(),
                                                image.height() / image.devicePixelRatio()))
        painter.end()
        return image

    def _paint_hint(self, painter: QtGui.QPainter, area: QtCore.QRectF) -> None:
        """Paint :attr:`hint` centred in ``area`` (logical pixels): white text, wrapped, on a
        dark translucent box."""
        if not self.hint:
            return
        font = QtGui.QFont(self.font())
        font.setPointSizeF(font.pointSizeF() * 1.15)
        painter.setFont(font)
        width = min(area.width() - 24.0, 420.0)
        flags = QtCore.Qt.AlignCenter | QtCore.Qt.TextWordWrap
        text = QtGui.QFontMetricsF(font).boundingRect(QtCore.QRectF(0.0, 0.0, width, 1e4), flags, self.hint)
        box = text.adjusted(-14.0, -10.0, 14.0, 10.0)
        box.moveCenter(area.center())
        painter.setRenderHint(QtGui.QPainter.Antialiasing)
        painter.setPen(QtCore.Qt.NoPen)
        painter.setBrush(QtGui.QColor(20, 24, 32, 200))
        painter.drawRoundedRect(box, 6.0, 6.0)
        painter.setPen(QtGui.QColor(255, 255, 255))
        painter.drawText(box, flags, self.hint)

    def _paint_labels(self, painter: QtGui.QPainter) -> None:
        """Paint the labels with ``painter`` (logical pixels)."""
        if not self._labels:
            return
        ratio = self.devicePixelRatioF()
        font, metrics = self._font_and_metrics()
        painter.setFont(font)
        rise = (metrics.ascent() - metrics.descent()) / 2.0
        for label in self._labels:
            x = label.x_px / ratio - metrics.horizontalAdvance(label.text) / 2.0
            painter.setPen(QtGui.QColor(*label.rgb))
            painter.drawText(QtCore.QPointF(x, label.y_px / ratio + rise), label.text)

    def _font_and_metrics(self) -> tuple[QtGui.QFont, QtGui.QFontMetricsF]:
        """The labels' bold font and its metrics, made again only when the widget's font or
        :attr:`label_point_size` changed (the labels are painted 60 times a second)."""
        key = (self.font().key(), self.label_point_size)
        if self._label_font is None or self._label_font[0] != key:
            font = QtGui.QFont(self.font())
            font.setBold(True)
            font.setPointSizeF(self.label_point_size)
            self._label_font = (key, font, QtGui.QFontMetricsF(font))
        return self._label_font[1], self._label_font[2]

    def paintEvent(self, event: QtGui.QPaintEvent) -> None:  # noqa: N802 (Qt API)
        painter = QtGui.QPainter(self)
        if self._image is None:
            painter.fillRect(self.rect(), QtGui.QColor(64, 71, 87))
        else:
            painter.drawImage(QtCore.QPoint(0, 0), self._image)
            self._paint_labels(painter)
        self._paint_hint(painter, QtCore.QRectF(self.rect()))
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
        if self._initialized and self._remote is not None:
            self._remote.render(wait=False)
        elif self._initialized:
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
        self._camera_moved()

    mouseDoubleClickEvent = mousePressEvent

    def mouseReleaseEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802
        names = _BUTTON_EVENTS.get(event.button())
        if names is None or self._finalized:
            return
        self._set_event_position(event)
        getattr(self.interactor, names[1])()
        self._camera_moved()

    def mouseMoveEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802
        if self._finalized:
            return
        self._set_event_position(event)
        self.interactor.MouseMoveEvent()
        if event.buttons():
            self._camera_moved()

    def wheelEvent(self, event: QtGui.QWheelEvent) -> None:  # noqa: N802
        if self._finalized:
            return
        self.Initialize()
        self._set_event_position(event)
        if event.angleDelta().y() > 0:
            self.interactor.MouseWheelForwardEvent()
        elif event.angleDelta().y() < 0:
            self.interactor.MouseWheelBackwardEvent()
        self._camera_moved()
