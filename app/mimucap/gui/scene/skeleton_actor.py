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

import numpy as np
from numpy.typing import NDArray
from vtkmodules.util.numpy_support import numpy_to_vtk
from vtkmodules.vtkFiltersSources import vtkCylinderSource
from vtkmodules.vtkRenderingCore import vtkActor, vtkPolyDataMapper, vtkRenderer
from vtkmodules.vtkRenderingOpenGL2 import vtkOpenGLSphereMapper

from mimucap.gui.scene.placed_copies import PlacedCopies, UnitShape, rgb_bytes, unit_shape
from mimucap.gui.scene.polydata import colour_by_point_rgb, polydata, shaded_mesh
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
#: The neutral outline before a body calibration: one calm grey for every piece, no tints (the
#: sensors' states are on their glyphs).
OUTLINE_COLOUR = (0.58, 0.60, 0.63)
#: Capsule material, lit by a headlight: ambient and diffuse parts of the base colour, and a
#: white highlight of this strength and exponent.
AMBIENT, DIFFUSE, SPECULAR, SPECULAR_POWER = 0.22, 0.78, 0.30, 12.0
#: Facets of the unit capsule: with per-pixel lighting, enough for a round outline at figure
#: size on screen.
CYLINDER_RESOLUTION = 20


def _unit_cylinder() -> UnitShape:
    cylinder = vtkCylinderSource()
    cylinder.SetRadius(1.0)
    cylinder.SetHeight(1.0)
    cylinder.SetResolution(CYLINDER_RESOLUTION)
    cylinder.CappingOff()
    return unit_shape(cylinder)


def figure_actor(mapper) -> vtkActor:
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
        self._segments = PlacedCopies(cylinder, n_segments, 0)
        self._connectors = PlacedCopies(cylinder, n_connectors, self._segments.stop)
        n_points = self._connectors.stop

        self._points = np.zeros((n_points, 3))
        self._normals = np.zeros((n_points, 3))
        self._normals[:, 2] = 1.0
        self._colours = np.empty((n_points, 3), dtype=np.uint8)
        self._colours[: self._segments.stop] = rgb_bytes(TINTS["no_sensor"])
        self._colours[self._connectors.first:self._connectors.stop] = rgb_bytes(CONNECTOR_COLOUR)

        # VTK arrays that share memory with the numpy arrays above (kept referenced).
        triangles = np.concatenate([b.triangles() for b in (self._segments, self._connectors)])
        self.polydata, (self._vtk_points, self._vtk_normals, self._vtk_colours) = shaded_mesh(
            self._points, self._normals, self._colours, triangles)
        mapper = vtkPolyDataMapper()
        mapper.SetInputData(self.polydata)
        colour_by_point_rgb(mapper)
        self.actor = figure_actor(mapper)
        # Closed shapes (the open capsule ends sit inside the joint spheres): their far sides
        # are never seen, so they are not drawn.
        self.actor.GetProperty().BackfaceCullingOn()

        # Joints then markers: one point each, with its radius and colour.
        n_spheres = n_joints + n_segments
        self._centres = np.zeros((n_spheres, 3))
        self._radii = np.zeros(n_spheres, dtype=np.float32)
        self._sphere_colours = np.empty((n_spheres, 3), dtype=np.uint8)
        self._sphere_colours[:n_joints] = rgb_bytes(JOINT_COLOUR)
        self._sphere_colours[n_joints:] = rgb_bytes(MARKER_COLOUR)
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
        self.sphere_actor = figure_actor(sphere_mapper)
        self._tints: dict[str, str] = {}
        self._outline = False
        for actor in (self.actor, self.sphere_actor):
            renderer.AddActor(actor)

    def make_ghost(self) -> None:
        """Draw this figure as a ghost: one pale, translucent colour, no tints (the simulator's
        truth beside the estimate)."""
        self._colours[:] = rgb_bytes(GHOST_COLOUR)
        self._sphere_colours[:] = rgb_bytes(GHOST_COLOUR)
        self._vtk_colours.Modified()
        self._vtk_sphere_colours.Modified()
        for actor in (self.actor, self.sphere_actor):
            actor.GetProperty().SetOpacity(GHOST_OPACITY)
            actor.SetPickable(False)

    @property
    def outline(self) -> bool:
        """Whether the figure is drawn as the neutral outline (:meth:`set_outline`)."""
        return self._outline

    def set_outline(self, on: bool) -> bool:
        """Draw the figure as the neutral outline (one grey, no tints) or as the tinted skeleton
        again (the tints last asked for); returns whether anything changed."""
        on = bool(on)
        if on == self._outline:
            return False
        self._outline = on
        n_joints = len(self._sphere_colours) - len(self.segment_names)
        if on:
            self._colours[:] = rgb_bytes(OUTLINE_COLOUR)
            self._sphere_colours[:] = rgb_bytes(OUTLINE_COLOUR)
        else:
            self._colours[self._connectors.first:self._connectors.stop] = rgb_bytes(CONNECTOR_COLOUR)
            self._sphere_colours[:n_joints] = rgb_bytes(JOINT_COLOUR)
            self._sphere_colours[n_joints:] = rgb_bytes(MARKER_COLOUR)
            states, self._tints = self._tints, {}
            for index, _name in enumerate(self.segment_names):
                self._colours[self._segments.vertex_range(index)] = rgb_bytes(TINTS["no_sensor"])
            self.set_tints(states)
        self._vtk_colours.Modified()
        self._vtk_sphere_colours.Modified()
        self.polydata.Modified()
        self.sphere_polydata.Modified()
        return True

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
            if not self._outline:  # the outline keeps its grey; the tint shows when it ends
                self._colours[self._segments.vertex_range(index)] = rgb_bytes(TINTS[state])
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
