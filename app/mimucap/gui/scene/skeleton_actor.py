"""The skeleton figure as one VTK actor: shaded capsules, joint spheres and anterior markers.

Every piece of the figure (segment capsule, connector, joint sphere, marker) is a copy of a
unit template (an open cylinder along +y, radius 1, height 1, centred at the origin; a
sphere of radius 1, coarser for the small markers) placed by its ``(4, 4)`` matrix from a
:class:`mimucap.session.figure.FigureGeometry` (scene frame, metres). All copies live in a
single ``vtkPolyData`` drawn by a single actor: each frame moves the vertices and normals
in place (``points = M[:3, :3] @ p + M[:3, 3]``, ``normals ∝ M[:3, :3]^-T @ n``). On software
OpenGL one draw call of ~15 000 triangles costs far less than ~60 actors of a few hundred
triangles each (``bench/bench_gui.py``). Segment capsules carry the colour of the state of
the sensor on them (:data:`TINTS`) as per-vertex colours.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray, vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkPoints
from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData
from vtkmodules.vtkFiltersCore import vtkTriangleFilter
from vtkmodules.vtkFiltersSources import vtkCylinderSource, vtkSphereSource
from vtkmodules.vtkRenderingCore import vtkActor, vtkPolyDataMapper, vtkRenderer

from mimucap.session.figure import FigureBuilder, FigureGeometry

#: Segment colour (RGB 0..1) for each sensor state (see ``mimucap.session.sensor_status``).
TINTS: dict[str, tuple[float, float, float]] = {
    "ok": (0.50, 0.70, 0.92),
    "mag_uncalibrated": (0.95, 0.72, 0.30),
    "stale": (0.90, 0.32, 0.30),
    "no_sensor": (0.62, 0.62, 0.64),
}
JOINT_COLOUR = (0.92, 0.92, 0.90)
CONNECTOR_COLOUR = (0.78, 0.78, 0.80)
MARKER_COLOUR = (0.15, 0.18, 0.25)
#: Facets of the unit shapes: enough for smooth Phong shading at figure size on screen, few
#: enough to keep software OpenGL fast (its cost grows with the triangle count).
CYLINDER_RESOLUTION = 16
SPHERE_RESOLUTION = (12, 8)  # (theta, phi)
MARKER_RESOLUTION = (8, 5)  # the anterior markers are a few pixels wide


@dataclass(frozen=True)
class _Template:
    """A unit shape: ``points``/``normals`` ``(n, 3)`` float, ``triangles`` ``(m, 3)`` int."""

    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    triangles: NDArray[np.int64]


def _template(source) -> _Template:
    triangulate = vtkTriangleFilter()
    triangulate.SetInputConnection(source.GetOutputPort())
    triangulate.Update()
    poly = triangulate.GetOutput()
    points = vtk_to_numpy(poly.GetPoints().GetData()).astype(float)
    normals = vtk_to_numpy(poly.GetPointData().GetNormals()).astype(float)
    connectivity = vtk_to_numpy(poly.GetPolys().GetConnectivityArray()).astype(np.int64)
    return _Template(points, normals, connectivity.reshape(-1, 3))


def _unit_cylinder() -> _Template:
    cylinder = vtkCylinderSource()
    cylinder.SetRadius(1.0)
    cylinder.SetHeight(1.0)
    cylinder.SetResolution(CYLINDER_RESOLUTION)
    cylinder.CappingOff()
    return _template(cylinder)


def _unit_sphere(resolution: tuple[int, int]) -> _Template:
    sphere = vtkSphereSource()
    sphere.SetRadius(1.0)
    sphere.SetThetaResolution(resolution[0])
    sphere.SetPhiResolution(resolution[1])
    return _template(sphere)


def _rgb(colour) -> NDArray[np.uint8]:
    return np.round(255.0 * np.asarray(colour)).astype(np.uint8)


class _Batch:
    """``count`` copies of ``template`` occupying vertices ``first`` … ``first + count * n - 1``."""

    def __init__(self, template: _Template, count: int, first: int) -> None:
        self.template = template
        self.count = count
        self.first = first
        self.stop = first + count * len(template.points)

    def vertex_range(self, index: int) -> slice:
        n = len(self.template.points)
        return slice(self.first + index * n, self.first + (index + 1) * n)

    def place(self, matrices: NDArray[np.float64], points_out: np.ndarray, normals_out: np.ndarray) -> None:
        """Write the vertices and unit normals of every copy placed by ``matrices`` ``(count, 4, 4)``."""
        if self.count == 0:
            return
        linear = matrices[:, :3, :3]
        # Row vectors: p' = p @ L^T + t ; n' ∝ n @ L^-1 (the inverse transpose, transposed).
        placed = self.template.points @ linear.transpose(0, 2, 1) + matrices[:, None, :3, 3]
        normals = self.template.normals @ np.linalg.inv(linear)
        normals /= np.sqrt(np.einsum("kni,kni->kn", normals, normals))[..., None]
        points_out[self.first:self.stop] = placed.reshape(-1, 3)
        normals_out[self.first:self.stop] = normals.reshape(-1, 3)

    def triangles(self) -> NDArray[np.int64]:
        n = len(self.template.points)
        offsets = self.first + n * np.arange(self.count)
        return (self.template.triangles[None, :, :] + offsets[:, None, None]).reshape(-1, 3)


class SkeletonActor:
    """The figure of one skeleton model, added to ``renderer`` and hidden until the first frame.

    Args:
        renderer: the VTK renderer of the 3D view.
        builder: the :class:`FigureBuilder` whose geometry this figure shows (names fixed).
    """

    def __init__(self, renderer: vtkRenderer, builder: FigureBuilder) -> None:
        self.renderer = renderer
        self.segment_names = tuple(builder.segment_names)
        cylinder, sphere, marker = _unit_cylinder(), _unit_sphere(SPHERE_RESOLUTION), _unit_sphere(MARKER_RESOLUTION)
        n_segments, n_connectors = len(builder.segment_names), len(builder.connector_names)
        n_joints = len(builder.joint_names)
        self._segments = _Batch(cylinder, n_segments, 0)
        self._connectors = _Batch(cylinder, n_connectors, self._segments.stop)
        self._joints = _Batch(sphere, n_joints, self._connectors.stop)
        self._markers = _Batch(marker, n_segments, self._joints.stop)
        batches = (self._segments, self._connectors, self._joints, self._markers)
        n_points = self._markers.stop

        self._points = np.zeros((n_points, 3))
        self._normals = np.zeros((n_points, 3))
        self._normals[:, 2] = 1.0
        self._colours = np.empty((n_points, 3), dtype=np.uint8)
        self._colours[: self._segments.stop] = _rgb(TINTS["no_sensor"])
        self._colours[self._connectors.first:self._connectors.stop] = _rgb(CONNECTOR_COLOUR)
        self._colours[self._joints.first:self._joints.stop] = _rgb(JOINT_COLOUR)
        self._colours[self._markers.first:self._markers.stop] = _rgb(MARKER_COLOUR)

        # VTK arrays that share memory with the numpy arrays above (kept referenced).
        self._vtk_points = numpy_to_vtk(self._points, deep=False)
        self._vtk_normals = numpy_to_vtk(self._normals, deep=False)
        self._vtk_normals.SetName("Normals")
        self._vtk_colours = numpy_to_vtk(self._colours, deep=False)
        self._vtk_colours.SetName("Colours")
        triangles = np.concatenate([b.triangles() for b in batches])
        offsets = np.arange(0, 3 * len(triangles) + 1, 3, dtype=np.int64)
        self._vtk_offsets = numpy_to_vtkIdTypeArray(offsets, deep=True)
        self._vtk_connectivity = numpy_to_vtkIdTypeArray(triangles.reshape(-1).astype(np.int64), deep=True)
        cells = vtkCellArray()
        cells.SetData(self._vtk_offsets, self._vtk_connectivity)
        points = vtkPoints()
        points.SetData(self._vtk_points)
        self.polydata = vtkPolyData()
        self.polydata.SetPoints(points)
        self.polydata.SetPolys(cells)
        self.polydata.GetPointData().SetNormals(self._vtk_normals)
        self.polydata.GetPointData().SetScalars(self._vtk_colours)

        mapper = vtkPolyDataMapper()
        mapper.SetInputData(self.polydata)
        mapper.SetColorModeToDirectScalars()
        mapper.SetScalarModeToUsePointData()
        mapper.ScalarVisibilityOn()
        self.actor = vtkActor()
        self.actor.SetMapper(mapper)
        prop = self.actor.GetProperty()
        prop.SetInterpolationToPhong()
        # Closed shapes (the open capsule ends sit inside the joint spheres): their far sides
        # are never seen, and skipping them halves the work of software OpenGL.
        prop.BackfaceCullingOn()
        prop.SetAmbient(0.12)
        prop.SetDiffuse(0.85)
        prop.SetSpecular(0.35)
        prop.SetSpecularPower(25.0)
        self.actor.VisibilityOff()
        self._tints: dict[str, str] = {}
        renderer.AddActor(self.actor)

    @property
    def visible(self) -> bool:
        """True once a frame has been shown."""
        return bool(self.actor.GetVisibility())

    def remove(self) -> None:
        """Take the figure out of its renderer."""
        self.renderer.RemoveActor(self.actor)

    def update(self, geometry: FigureGeometry) -> None:
        """Move every piece to ``geometry`` (and show the figure)."""
        if tuple(geometry.segment_names) != self.segment_names:
            raise ValueError("the geometry belongs to another skeleton model than this figure")
        self._segments.place(np.asarray(geometry.segment_matrices), self._points, self._normals)
        self._connectors.place(np.asarray(geometry.connector_matrices), self._points, self._normals)
        self._joints.place(np.asarray(geometry.joint_matrices), self._points, self._normals)
        self._markers.place(np.asarray(geometry.marker_matrices), self._points, self._normals)
        self._vtk_points.Modified()
        self._vtk_normals.Modified()
        self.polydata.Modified()
        self.actor.VisibilityOn()

    def set_tints(self, states: Mapping[str, str]) -> bool:
        """Colour each segment by its sensor state name (a key of :data:`TINTS`); returns
        whether any colour changed."""
        changed = False
        for index, name in enumerate(self.segment_names):
            state = states.get(name, "no_sensor")
            if self._tints.get(name) == state:
                continue
            if state not in TINTS:
                raise ValueError(f"unknown sensor state {state!r} for segment {name}")
            self._colours[self._segments.vertex_range(index)] = _rgb(TINTS[state])
            self._tints[name] = state
            changed = True
        if changed:
            self._vtk_colours.Modified()
            self.polydata.Modified()
        return changed

    def tint_of(self, segment: str) -> str:
        """The sensor state a segment is currently tinted with."""
        return self._tints.get(segment, "no_sensor")

    def vertices_of_segment(self, segment: str) -> NDArray[np.float64]:
        """The capsule vertices of ``segment`` as shown (scene frame, metres), ``(n, 3)``."""
        return self._points[self._segments.vertex_range(self.segment_names.index(segment))].copy()
