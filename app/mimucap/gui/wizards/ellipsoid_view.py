"""Live views of a magnetometer calibration: a VTK 3D view and a pyqtgraph |field| plot.

:class:`EllipsoidView` (VTK, two side-by-side viewports, both in the sensor frame, µT):

* left, *raw*: the raw samples as a point cloud coloured by time (early blue → late red) and
  the fitted ellipsoid, translucent, with its centre (the hard-iron offset);
* right, *corrected*: the corrected samples ``soft_iron · (raw − offset)`` with a translucent
  sphere of the field radius around the origin: a good calibration puts them on it.

:class:`FieldMagnitudePlot` plots ``|raw|`` and ``|corrected|`` against time with the field
radius as a dashed line: the corrected curve should be flat.

Neither computes anything: they show a :class:`~mimucap.session.views.magcal_display.MagcalDisplay`
(samples thinned, corrected, their magnitudes, the ellipsoid's matrix); the callers throttle
how often they call ``set_data``.
"""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PyQt5 import QtGui, QtWidgets
from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
from vtkmodules.vtkCommonCore import vtkLookupTable, vtkPoints
from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData
from vtkmodules.vtkCommonMath import vtkMatrix4x4
from vtkmodules.vtkFiltersSources import vtkSphereSource
from vtkmodules.vtkRenderingAnnotation import vtkAxesActor
from vtkmodules.vtkRenderingCore import (
    vtkActor,
    vtkPolyDataMapper,
    vtkRenderer,
    vtkTextActor,
)

from mimucap.core.magcal.fit import EllipsoidFit
from mimucap.gui.vtk_widget import VtkWidget
from mimucap.session.views.magcal_display import MagcalDisplay

ELLIPSOID_COLOUR = (0.95, 0.62, 0.18)
SPHERE_COLOUR = (0.35, 0.75, 0.45)
BACKGROUND = (0.11, 0.12, 0.15)
#: Where the cameras look from (unit vector, sensor frame) and how far, in cloud sizes.
CAMERA_DIRECTION = (0.5513, -0.6515, 0.5212)
CAMERA_DISTANCE = 7.5


class _Cloud:
    """A point cloud actor whose points and per-point scalars are replaced at once."""

    def __init__(self, renderer: vtkRenderer, lookup: vtkLookupTable | None, colour=(1.0, 1.0, 1.0)) -> None:
        self.polydata = vtkPolyData()
        self.mapper = vtkPolyDataMapper()
        self.mapper.SetInputData(self.polydata)
        if lookup is not None:
            self.mapper.SetLookupTable(lookup)
            self.mapper.SetScalarRange(0.0, 1.0)
            self.mapper.ScalarVisibilityOn()
        else:
            self.mapper.ScalarVisibilityOff()
        self.actor = vtkActor()
        self.actor.SetMapper(self.mapper)
        self.actor.GetProperty().SetPointSize(4.0)
        self.actor.GetProperty().SetColor(*colour)
        renderer.AddActor(self.actor)
        self.count = 0

    def set(self, points: np.ndarray, scalars: np.ndarray | None = None) -> None:
        points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        n = points.shape[0]
        vtk_points = vtkPoints()
        vtk_points.SetData(numpy_to_vtk(points, deep=True))
        cells = vtkCellArray()
        ids = np.arange(n + 1, dtype=np.int64)  # one vertex cell per point
        cells.SetData(numpy_to_vtkIdTypeArray(ids, deep=True), numpy_to_vtkIdTypeArray(ids[:n].copy(), deep=True))
        self.polydata.SetPoints(vtk_points)
        self.polydata.SetVerts(cells)
        if scalars is not None:
            self.polydata.GetPointData().SetScalars(numpy_to_vtk(np.ascontiguousarray(scalars, dtype=np.float64), deep=True))
        self.polydata.Modified()
        self.count = n


def _surface(renderer: vtkRenderer, colour, opacity: float) -> tuple[vtkActor, vtkSphereSource]:
    sphere = vtkSphereSource()
    sphere.SetRadius(1.0)
    sphere.SetThetaResolution(36)
    sphere.SetPhiResolution(24)
    sphere.Update()
    mapper = vtkPolyDataMapper()
    mapper.SetInputConnection(sphere.GetOutputPort())
    actor = vtkActor()
    actor.SetMapper(mapper)
    prop = actor.GetProperty()
    prop.SetColor(*colour)
    prop.SetOpacity(opacity)
    prop.SetEdgeVisibility(True)
    prop.SetEdgeColor(*[0.6 * c for c in colour])
    actor.SetUserMatrix(vtkMatrix4x4())
    actor.VisibilityOff()
    renderer.AddActor(actor)
    return actor, sphere


def _set_matrix(actor: vtkActor, matrix: np.ndarray) -> None:
    target = actor.GetUserMatrix()
    for row in range(4):
        for col in range(4):
            target.SetElement(row, col, float(matrix[row, col]))
    target.Modified()
    actor.Modified()


def _label(renderer: vtkRenderer, text: str) -> vtkTextActor:
    actor = vtkTextActor()
    actor.SetInput(text)
    actor.GetTextProperty().SetFontSize(15)
    actor.GetTextProperty().SetColor(0.9, 0.9, 0.92)
    actor.GetPositionCoordinate().SetCoordinateSystemToNormalizedViewport()
    actor.GetPositionCoordinate().SetValue(0.02, 0.02)
    renderer.AddViewProp(actor)
    return actor


class EllipsoidView(QtWidgets.QWidget):
    """Raw samples with the fitted ellipsoid (left) and corrected samples on the field sphere
    (right), in the sensor frame (µT)."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.vtk_widget = VtkWidget(self)
        self.vtk_widget.setObjectName("ellipsoidVtk")
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.vtk_widget)
        self.setMinimumSize(420, 260)
        self.render_window = self.vtk_widget.render_window
        lookup = vtkLookupTable()
        lookup.SetHueRange(0.66, 0.0)  # blue (early) → red (late)
        lookup.SetSaturationRange(0.85, 0.85)
        lookup.SetValueRange(1.0, 1.0)
        lookup.Build()
        self.raw_renderer, self.corrected_renderer = vtkRenderer(), vtkRenderer()
        self.raw_renderer.SetViewport(0.0, 0.0, 0.5, 1.0)
        self.corrected_renderer.SetViewport(0.5, 0.0, 1.0, 1.0)
        for renderer in (self.raw_renderer, self.corrected_renderer):
            renderer.SetBackground(*BACKGROUND)
            self.render_window.AddRenderer(renderer)
        self.raw_cloud = _Cloud(self.raw_renderer, lookup)
        self.corrected_cloud = _Cloud(self.corrected_renderer, lookup)
        self.ellipsoid_actor, _ = _surface(self.raw_renderer, ELLIPSOID_COLOUR, 0.22)
        self.sphere_actor, _ = _surface(self.corrected_renderer, SPHERE_COLOUR, 0.18)
        self.raw_label = _label(self.raw_renderer, "raw samples (colour: time)")
        self.corrected_label = _label(self.corrected_renderer, "corrected samples")
        axes = vtkAxesActor()
        axes.SetTotalLength(10.0, 10.0, 10.0)
        axes.SetShaftTypeToCylinder()
        axes.AxisLabelsOff()
        self.corrected_renderer.AddActor(axes)
        self._axes = axes
        self.interactor = self.vtk_widget.interactor
        self._initialized = False
        self._alive = True
        self._framed_size: float | None = None
        self._framed_centre = np.zeros(3)
        self.fit_shown: EllipsoidFit | None = None
        self.updates = 0

    def start(self) -> None:
        """Initialise the interactor (once the widget exists on screen)."""
        if not self._initialized and self._alive:
            self.vtk_widget.Initialize()
            self._initialized = True

    def set_data(self, display: MagcalDisplay) -> None:
        """Show one update of the samples and the fit (:func:`~mimucap.session.views.magcal_display.magcal_display`)."""
        self.raw_cloud.set(display.raw_uT, display.time_fraction)
        self.fit_shown = display.fit
        if display.fit is None:
            self.ellipsoid_actor.VisibilityOff()
            self.sphere_actor.VisibilityOff()
            self.corrected_cloud.set(np.zeros((0, 3)), np.zeros(0))
            self.raw_label.SetInput(f"raw samples (colour: time)\n{display.count} shown, no fit yet")
        else:
            _set_matrix(self.ellipsoid_actor, display.ellipsoid_matrix)
            self.ellipsoid_actor.VisibilityOn()
            _set_matrix(self.sphere_actor, np.diag([display.field_uT, display.field_uT, display.field_uT, 1.0]))
            self.sphere_actor.VisibilityOn()
            self.corrected_cloud.set(display.corrected_uT, display.time_fraction)
            centre = display.centre_uT
            self.raw_label.SetInput(
                "raw samples (colour: time)\nand fitted ellipsoid\n"
                f"offset {centre[0]:.1f}, {centre[1]:.1f}, {centre[2]:.1f} µT"
            )
            self.corrected_label.SetInput(f"corrected samples\non the {display.field_uT:.1f} µT sphere")
        if display.count > 10:
            self._frame_camera(display)
        self.updates += 1
        self.render()

    def _frame_camera(self, display: MagcalDisplay) -> None:
        """Look at the raw cloud (left) and the corrected one (right, around the origin) from
        the same oblique direction, far enough back for the whole cloud to fit the half-width
        viewport. Reframed only when the cloud's size changed, or its centre moved, by more than
        15 % of its size (another sensor shown), so that a view the user turned stays put while
        samples arrive."""
        size = display.extent_uT
        centre = np.asarray(display.centre_uT, dtype=float)
        if (self._framed_size is not None and abs(size - self._framed_size) <= 0.15 * self._framed_size
                and np.linalg.norm(centre - self._framed_centre) <= 0.15 * self._framed_size):
            return
        self._framed_size, self._framed_centre = size, centre
        for renderer, focal, extent in ((self.raw_renderer, display.centre_uT, size),
                                        (self.corrected_renderer, (0.0, 0.0, 0.0), display.field_uT or size)):
            camera = renderer.GetActiveCamera()
            camera.SetFocalPoint(*focal)
            camera.SetPosition(*(np.asarray(focal) + CAMERA_DISTANCE * extent * np.asarray(CAMERA_DIRECTION)))
            camera.SetViewUp(0.0, 0.0, 1.0)
            camera.SetViewAngle(30.0)

    def render(self) -> None:
        """Render now (only when shown)."""
        if not self._alive or not self.isVisible():
            return
        self.start()
        self.raw_renderer.ResetCameraClippingRange()
        self.corrected_renderer.ResetCameraClippingRange()
        self.vtk_widget.render()

    def reset(self) -> None:
        """Forget the data and the camera framing (a new recording)."""
        self.raw_cloud.set(np.zeros((0, 3)), np.zeros(0))
        self.corrected_cloud.set(np.zeros((0, 3)), np.zeros(0))
        self.ellipsoid_actor.VisibilityOff()
        self.sphere_actor.VisibilityOff()
        self._framed_size = None
        self.fit_shown = None

    def shutdown(self) -> None:
        """Release the OpenGL context; nothing renders afterwards."""
        if self._alive:
            self._alive = False
            self.vtk_widget.Finalize()

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802 (Qt API)
        self.shutdown()
        super().closeEvent(event)

    def grab_image(self) -> QtGui.QImage:
        """The VTK view as an RGB ``QImage`` (rendered now)."""
        self.start()
        self.vtk_widget.render()
        return self.vtk_widget.image()


class FieldMagnitudePlot(pg.PlotWidget):
    """``|raw|`` (grey) and ``|corrected|`` (green) field magnitude in µT against time (s),
    with the fitted field radius dashed."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setBackground("w")
        self.setLabel("left", "|field|", units="µT")
        self.setLabel("bottom", "time", units="s")
        self.addLegend(offset=(10, 10))
        self.showGrid(x=True, y=True, alpha=0.25)
        self.raw_curve = self.plot(pen=pg.mkPen((120, 120, 128), width=1.5), name="before correction")
        self.corrected_curve = self.plot(pen=pg.mkPen((44, 160, 44), width=2), name="after correction")
        self.field_line = pg.InfiniteLine(angle=0, pen=pg.mkPen((44, 160, 44), style=pg.QtCore.Qt.DashLine))
        self.field_line.setVisible(False)
        self.addItem(self.field_line)
        self.setMinimumHeight(150)

    def set_data(self, display: MagcalDisplay) -> None:
        """Show ``|raw|`` and ``|corrected|`` of one update (:class:`MagcalDisplay`)."""
        self.raw_curve.setData(display.t_s, display.raw_norm_uT)
        if display.fit is None:
            self.corrected_curve.setData([], [])
            self.field_line.setVisible(False)
        else:
            self.corrected_curve.setData(display.t_s, display.corrected_norm_uT)
            self.field_line.setValue(display.field_uT)
            self.field_line.setVisible(True)
