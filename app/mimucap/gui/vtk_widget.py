"""A VTK render window inside a Qt widget, the way VTK desktop programs embed one.

:class:`VtkWidget` is VTK's own ``QVTKRenderWindowInteractor`` (as in pyvistaqt and MNE): a
native child window that owns a ``vtkRenderWindow`` (:attr:`VtkWidget.render_window`); each
``Render()`` draws the scene with the OpenGL driver of the machine (a GPU's, or Mesa's software
one where there is no GPU) and presents it in that window. Qt's mouse and wheel events drive
VTK's trackball camera style (orbit with the left button, pan with the middle one or
Shift+left, zoom with the right one or the wheel); VTK renders after each of them by itself.

Two settings of the render window:

* No multisampling: the views are made of large smooth shapes and lines, and a 4x or 8x
  multisampled framebuffer multiplies the cost of every pixel on a machine without a GPU.
* The finished frame is copied to the window's back buffer in colour only
  (``FrameBlitMode`` "blit to current", the default framebuffer being the one bound while VTK
  renders into its own window): VTK's default also copies the depth buffer to the window, which
  nothing reads and which costs a whole-window copy per frame without a GPU.

Text anchored in the scene is drawn by VTK text actors in the same frame (no Qt painting over
a native OpenGL window, which would flicker). A native OpenGL window is not part of what
``QWidget.grab()`` paints: :meth:`VtkWidget.image` reads the picture back from OpenGL, and
:func:`mimucap.gui.capture.grab_window` puts it in place.

After :meth:`VtkWidget.Finalize` (called on close) nothing renders any more, whatever asks
(Qt's paint and resize events, the interactor, the owner).
"""

from __future__ import annotations

import vtkmodules.qt
import vtkmodules.vtkInteractionStyle  # noqa: F401  (registers the interactor styles)
import vtkmodules.vtkRenderingFreeType  # noqa: F401  (text rendering)
import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (the OpenGL back end)
from PyQt5 import QtCore, QtGui

# VTK's Qt widget picks the first Qt binding it can import unless told: the application's.
vtkmodules.qt.PyQtImpl = "PyQt5"
from vtkmodules.qt.QVTKRenderWindowInteractor import QVTKRenderWindowInteractor  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402
from vtkmodules.vtkCommonCore import vtkCommand  # noqa: E402
from vtkmodules.vtkInteractionStyle import vtkInteractorStyleTrackballCamera  # noqa: E402
from vtkmodules.vtkRenderingCore import vtkWindowToImageFilter  # noqa: E402


class VtkWidget(QVTKRenderWindowInteractor):
    """A ``vtkRenderWindow`` (:attr:`render_window`) drawn in a native child window of Qt.

    Attributes:
        render_window: add renderers to it; :meth:`render` draws. Its size follows the
            widget's size in device pixels.
        interactor: the ``vtkGenericRenderWindowInteractor`` driven by Qt's events.

    Signals:
        rendered(): after each frame drawn (by :meth:`render`, the mouse or a repaint).
    """

    rendered = QtCore.pyqtSignal()

    def __init__(self, parent=None) -> None:
        # A native child window makes its ancestors native, and by default their siblings too
        # (in the main window 26 widgets, each then an X window of its own, flushed apart): only
        # the chain down to this widget has to be.
        QtCore.QCoreApplication.setAttribute(QtCore.Qt.AA_DontCreateNativeWidgetSiblings)
        super().__init__(parent)
        self.setMinimumSize(160, 120)
        self.render_window = self.GetRenderWindow()
        self.render_window.SetMultiSamples(0)
        self.render_window.SetFrameBlitModeToBlitToCurrent()
        self.interactor = self._Iren
        self.interactor.SetInteractorStyle(vtkInteractorStyleTrackballCamera())
        self._end_observer = self.render_window.AddObserver(vtkCommand.EndEvent, self._frame_done)
        self._initialized = False
        self._finalized = False

    # -- life cycle --------------------------------------------------------------------------
    def Initialize(self) -> None:  # noqa: N802 (VTK's name)
        """Make the OpenGL context (idempotent; nothing after :meth:`Finalize`)."""
        if not self._gone and not self._initialized:
            self.interactor.Initialize()
            self._initialized = True

    @property
    def _gone(self) -> bool:
        """Finalized, or torn down by Python before its constructor's attributes exist (Qt can
        still deliver an event then; VTK's ``__getattr__`` would recurse looking for them)."""
        return self.__dict__.get("_finalized", True)

    def Finalize(self) -> None:  # noqa: N802
        """Release the OpenGL context for good; nothing renders afterwards (idempotent)."""
        if self._gone:
            return
        self._finalized = True
        self.render_window.RemoveObserver(self._end_observer)
        self.interactor.EnableRenderOff()
        self.render_window.Finalize()

    @property
    def finalized(self) -> bool:
        return self._gone

    def render(self) -> None:
        """Draw one frame now and present it (nothing after :meth:`Finalize`)."""
        if self._gone:
            return
        self.Initialize()
        self.render_window.Render()

    def _frame_done(self, _caller, _event) -> None:
        self.rendered.emit()

    # -- Qt events that would draw ---------------------------------------------------------------
    def paintEvent(self, event: QtGui.QPaintEvent) -> None:  # noqa: N802 (Qt API)
        if not self._gone:
            self.Initialize()
            super().paintEvent(event)

    def resizeEvent(self, event: QtGui.QResizeEvent) -> None:  # noqa: N802
        if not self._gone:
            super().resizeEvent(event)

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802
        self.Finalize()

    def _mouse_allowed(self) -> bool:
        if self._gone:
            return False
        self.Initialize()
        return True

    def mousePressEvent(self, event) -> None:  # noqa: N802
        if self._mouse_allowed():
            super().mousePressEvent(event)

    mouseDoubleClickEvent = mousePressEvent

    def mouseReleaseEvent(self, event) -> None:  # noqa: N802
        if self._mouse_allowed():
            super().mouseReleaseEvent(event)

    def mouseMoveEvent(self, event) -> None:  # noqa: N802
        if self._mouse_allowed():
            super().mouseMoveEvent(event)

    def wheelEvent(self, event) -> None:  # noqa: N802
        if self._mouse_allowed():
            super().wheelEvent(event)

    def keyPressEvent(self, event) -> None:  # noqa: N802
        # VTK's key bindings (e.g. 'e' or 'q' end the interactor, 'w' wireframe) make no sense
        # here: keys go to Qt.
        event.ignore()

    def keyReleaseEvent(self, event) -> None:  # noqa: N802
        event.ignore()

    # -- the picture -----------------------------------------------------------------------------
    def image(self) -> QtGui.QImage:
        """The picture now on screen, read back from OpenGL after a fresh frame: an RGB
        ``QImage`` of the render window's size (device pixels; the widget's device pixel ratio
        set). A null image after :meth:`Finalize`."""
        if self._gone:
            return QtGui.QImage()
        self.render()
        grabber = vtkWindowToImageFilter()
        grabber.SetInput(self.render_window)
        grabber.SetInputBufferTypeToRGB()
        grabber.ReadFrontBufferOff()  # the frame just drawn, whatever covers the window
        grabber.ShouldRerenderOff()
        grabber.Update()
        data = grabber.GetOutput()
        width, height, _ = data.GetDimensions()
        rows = vtk_to_numpy(data.GetPointData().GetScalars()).reshape(height, width, 3)[::-1].copy()
        image = QtGui.QImage(rows.data, width, height, 3 * width, QtGui.QImage.Format_RGB888).copy()
        image.setDevicePixelRatio(self.devicePixelRatioF())
        return image
