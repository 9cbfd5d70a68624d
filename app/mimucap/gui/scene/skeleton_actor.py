"""The skeleton figure as two VTK actors: shaded capsules, and joint spheres with anterior markers.

Capsules (segments and the connectors between them) are copies of one unit template (an open
cylinder along +y, radius 1, height 1, centred at the origin) placed by their ``(4, 4)``
matrices from a :class:`mimucap.session.views.skeleton_figure.FigureGeometry` (scene frame, metres). All
copies live in a single ``vtkPolyData`` drawn by a single actor: each frame moves the vertices
and normals in place (``points = M[:3, :3] @ p + M[:3, 3]``, ``normals ∝ M[:3, :3]^-T @ n``),
one buffer upload and one draw call for the whole figure, where one actor per piece would
cost a draw call, a matrix and a state change each.

Spheres (joints and markers; a sphere's matrix is its radius times a rotation, plus its
centre) are drawn by VTK's sphere impostor mapper: one point each, ray-traced per pixel, so a
perfectly round sphere costs no triangles (35 meshed spheres were ~60 % of the figure's
render time without a GPU; ``bench/bench_gui.py``). Segment capsules carry the colour of
the state of the sensor on them (:data:`TINTS`) as per-vertex colours.

Both actors are lit by VTK (the stage's headlight) with one material: :data:`AMBIENT`,
:data:`DIFFUSE`, :data:`SPECULAR`, :data:`SPECULAR_POWER`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
from vtkmodules.vtkFiltersCore import vtkTriangleFilter
from vtkmodules.vtkFiltersSources import vtkCylinderSource
from vtkmodules.vtkRenderingCore import vtkActor, vtkPolyDataMapper, vtkRenderer
from vtkmodules.vtkRenderingOpenGL2 import vtkOpenGLSphereMapper

from mimucap.gui.scene.polydata import colour_by_point_rgb, polydata
from mimucap.session.views.skeleton_figure import FigureBuilder, FigureGeometry

#: Segment colour (RGB 0..1) for each sensor state (see ``mimucap.session.live.status``).
TINTS: dict[str, tuple[float, float, float]] = {
    "ok": (0.50, 0.70, 0.92),
    "mag_uncalibrated": (0.95, 0.72, 0.30),
    "stale": (0.90, 0.32, 0.30),
    "no_sensor": (0.62, 0.62, 0.64),
}
#: The ghost figure (the simulator's truth shown beside the estimate): colour and opacity.
GHOST_COLOUR = (0.85, 0.88, 0.90)
GHOST_OPACITY = 0.35
JOINT_COLOUR = (0.92, 0.92, 0.90)
CONNECTOR_COLOUR = (0.78, 0.78, 0.80)
MARKER_COLOUR = (0.15, 0.18, 0.25)
#: Capsule material, lit by a headlight: ambient and diffuse parts of the base colour, and a
#: white highlight of this strength and exponent.
AMBIENT, DIFFUSE, SPECULAR, SPECULAR_POWER = 0.22, 0.78, 0.30, 12.0
#: Facets of the unit capsule: with per-pixel lighting, enough for a round outline at figure
#: size on screen.
CYLINDER_RESOLUTION = 20


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


def _figure_actor(mapper) -> vtkActor:
    """A hidden actor with the figure's material (:data:`AMBIENT`, :data:`DIFFUSE`,
    :data:`SPECULAR`, :data:`SPECULAR_POWER`)."""
    actor = vtkActor()
    actor.SetMapper(mapper)
    prop = actor.GetProperty()
    prop.SetAmbient(AMBIENT)
    prop.SetDiffuse(DIFFUSE)
    prop.SetSpecular(SPECULAR)
    prop.SetSpecularPower(SPECULAR_POWER)
    actor.VisibilityOff()
    return actor


class SkeletonActor:
    """The figure of one skeleton model, added to ``renderer`` and hidden until the first frame.

    Args:
        renderer: the VTK renderer of the 3D view.
        builder: the :class:`FigureBuilder` whose geometry this figure shows (names fixed), or
            anything with its ``segment_names``, ``connector_names`` and ``joint_names``.
    """

    def __init__(self, renderer: vtkRenderer, builder: FigureBuilder) -> None:
        self.renderer = renderer
        self.segment_names = tuple(builder.segment_names)
        cylinder = _unit_cylinder()
        n_segments, n_connectors = len(builder.segment_names), len(builder.connector_names)
        n_joints = len(builder.joint_names)
        self._segments = _Batch(cylinder, n_segments, 0)
        self._connectors = _Batch(cylinder, n_connectors, self._segments.stop)
        n_points = self._connectors.stop

        self._points = np.zeros((n_points, 3))
        self._normals = np.zeros((n_points, 3))
        self._normals[:, 2] = 1.0
        self._colours = np.empty((n_points, 3), dtype=np.uint8)
        self._colours[: self._segments.stop] = _rgb(TINTS["no_sensor"])
        self._colours[self._connectors.first:self._connectors.stop] = _rgb(CONNECTOR_COLOUR)

        # VTK arrays that share memory with the numpy arrays above (kept referenced).
        self._vtk_points = numpy_to_vtk(self._points, deep=False)
        self._vtk_normals = numpy_to_vtk(self._normals, deep=False)
        self._vtk_normals.SetName("Normals")
        self._vtk_colours = numpy_to_vtk(self._colours, deep=False)
        self._vtk_colours.SetName("Colours")
        triangles = np.concatenate([b.triangles() for b in (self._segments, self._connectors)])
        self.polydata = polydata(self._vtk_points, triangles)
        self.polydata.GetPointData().SetNormals(self._vtk_normals)
        self.polydata.GetPointData().SetScalars(self._vtk_colours)
        mapper = vtkPolyDataMapper()
        mapper.SetInputData(self.polydata)
        colour_by_point_rgb(mapper)
        self.actor = _figure_actor(mapper)
        # Closed shapes (the open capsule ends sit inside the joint spheres): their far sides
        # are never seen, so they are not drawn.
        self.actor.GetProperty().BackfaceCullingOn()

        # Joints then markers: one point each, with its radius and colour.
        n_spheres = n_joints + n_segments
        self._centres = np.zeros((n_spheres, 3))
        self._radii = np.zeros(n_spheres, dtype=np.float32)
        self._sphere_colours = np.empty((n_spheres, 3), dtype=np.uint8)
        self._sphere_colours[:n_joints] = _rgb(JOINT_COLOUR)
        self._sphere_colours[n_joints:] = _rgb(MARKER_COLOUR)
        self._vtk_centres = numpy_to_vtk(self._centres, deep=False)
        self._vtk_radii = numpy_to_vtk(self._radii, deep=False)
        self._vtk_radii.SetName("radius")
        self._vtk_sphere_colours = numpy_to_vtk(self._sphere_colours, deep=False)
        self._vtk_sphere_colours.SetName("Colours")
        self.sphere_polydata = polydata(self._vtk_centres, np.arange(n_spheres).reshape(-1, 1))
        self.sphere_polydata.GetPointData().AddArray(self._vtk_radii)
        self.sphere_polydata.GetPointData().SetScalars(self._vtk_sphere_colours)
        sphere_mapper = vtkOpenGLSphereMapper()
        sphere_mapper.SetInputData(self.sphere_polydata)
        sphere_mapper.SetScaleArray("radius")
        colour_by_point_rgb(sphere_mapper)
        self.sphere_actor = _figure_actor(sphere_mapper)
        self._tints: dict[str, str] = {}
        for actor in (self.actor, self.sphere_actor):
            renderer.AddActor(actor)

    def make_ghost(self) -> None:
        """Draw this figure as a ghost: one pale, translucent colour, no tints (the simulator's
        truth beside the estimate)."""
        self._colours[:] = _rgb(GHOST_COLOUR)
        self._sphere_colours[:] = _rgb(GHOST_COLOUR)
        self._vtk_colours.Modified()
        self._vtk_sphere_colours.Modified()
        for actor in (self.actor, self.sphere_actor):
            actor.GetProperty().SetOpacity(GHOST_OPACITY)
            actor.SetPickable(False)

    def hide(self) -> None:
        """Hide the figure until the next :meth:`update`."""
        self.actor.VisibilityOff()
        self.sphere_actor.VisibilityOff()

    @property
    def visible(self) -> bool:
        """True once a frame has been shown."""
        return bool(self.actor.GetVisibility())

    def remove(self) -> None:
        """Take the figure out of its renderer."""
        for actor in (self.actor, self.sphere_actor):
            self.renderer.RemoveActor(actor)

    def update(self, geometry: FigureGeometry) -> None:
        """Move every piece to ``geometry`` (and show the figure)."""
        if tuple(geometry.segment_names) != self.segment_names:
            raise ValueError("the geometry belongs to another skeleton model than this figure")
        self._segments.place(np.asarray(geometry.segment_matrices), self._points, self._normals)
        self._connectors.place(np.asarray(geometry.connector_matrices), self._points, self._normals)
        spheres = np.concatenate([np.asarray(geometry.joint_matrices), np.asarray(geometry.marker_matrices)])
        self._centres[:] = spheres[:, :3, 3]
        self._radii[:] = np.linalg.norm(spheres[:, :3, 0], axis=1)
        for array in (self._vtk_points, self._vtk_normals, self._vtk_centres, self._vtk_radii):
            array.Modified()
        self.polydata.Modified()
        self.sphere_polydata.Modified()
        self.actor.VisibilityOn()
        self.sphere_actor.VisibilityOn()

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

    def spheres(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Centres ``(n, 3)`` (scene frame, metres) and radii ``(n,)`` of the joint spheres,
        then the markers, as shown."""
        return self._centres.copy(), self._radii.astype(float)

    def tint_of(self, segment: str) -> str:
        """The sensor state a segment is currently tinted with."""
        return self._tints.get(segment, "no_sensor")

    def vertices_of_segment(self, segment: str) -> NDArray[np.float64]:
        """The capsule vertices of ``segment`` as shown (scene frame, metres), ``(n, 3)``."""
        return self._points[self._segments.vertex_range(self.segment_names.index(segment))].copy()
