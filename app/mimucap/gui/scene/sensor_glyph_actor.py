"""The sensors on the outline before a body calibration, as one VTK actor of small boxes with axes.

Each sensor of a :class:`~mimucap.session.views.skeleton_figure.SensorGlyphs` is a box (the unit
cube placed by its matrix: the sensor's x, y and z axes in the scene, its side, its centre)
coloured by the state of the sensor (:data:`~mimucap.gui.scene.skeleton_actor.TINTS`), and three
bars along its axes: x red, y green, z blue (the colours of the world axes on the floor), so that
the way a sensor turns, heading included, is seen on screen. Every copy lives in one polydata
(:mod:`mimucap.gui.scene.placed_copies`), rebuilt only when the set of sensors changes.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray
from vtkmodules.vtkFiltersSources import vtkCubeSource
from vtkmodules.vtkRenderingCore import vtkPolyDataMapper, vtkRenderer

from mimucap.gui.scene.placed_copies import PlacedCopies, rgb_bytes, unit_shape
from mimucap.gui.scene.polydata import colour_by_point_rgb, shaded_mesh
from mimucap.gui.scene.skeleton_actor import TINTS, figure_actor
from mimucap.session.views.skeleton_figure import SensorGlyphs

#: The axis bars' colours: x, y, z.
AXIS_COLOURS = ((0.86, 0.20, 0.18), (0.20, 0.68, 0.25), (0.20, 0.40, 0.90))
#: An axis bar's length from the box's centre and its thickness, in box sides.
AXIS_LENGTH, AXIS_THICKNESS = 1.25, 0.16


def _axis_bar_matrices() -> NDArray[np.float64]:
    """``(3, 4, 4)`` placing the unit cube as the bars along the box's x, y and z axes (in the
    box's own unit frame): from its centre out to :data:`AXIS_LENGTH`."""
    bars = np.zeros((3, 4, 4))
    for axis in range(3):
        scale = np.full(3, AXIS_THICKNESS)
        scale[axis] = AXIS_LENGTH
        bars[axis, :3, :3] = np.diag(scale)
        bars[axis, axis, 3] = 0.5 * AXIS_LENGTH
        bars[axis, 3, 3] = 1.0
    return bars


class SensorGlyphActor:
    """The sensors' glyphs in ``renderer``, hidden until :meth:`update`."""

    def __init__(self, renderer: vtkRenderer) -> None:
        self.renderer = renderer
        self._cube = unit_shape(vtkCubeSource())
        self._bars = _axis_bar_matrices()
        self.sensor_ids: tuple[str, ...] = ()
        self.segments: tuple[str, ...] = ()
        self._states: dict[str, str] = {}
        self._copies = PlacedCopies(self._cube, 0, 0)
        self._points = np.zeros((0, 3))
        self._normals = np.zeros((0, 3))
        self._colours = np.zeros((0, 3), dtype=np.uint8)
        self.actor = None

    def _rebuild(self, sensor_ids: tuple[str, ...], segments: tuple[str, ...]) -> None:
        """A new buffer for these sensors: a box and three bars each."""
        if self.actor is not None:
            self.renderer.RemoveActor(self.actor)
        self.sensor_ids, self.segments = sensor_ids, segments
        self._copies = PlacedCopies(self._cube, 4 * len(sensor_ids), 0)
        n_points = self._copies.stop
        self._points = np.zeros((n_points, 3))
        self._normals = np.zeros((n_points, 3))
        self._normals[:, 2] = 1.0
        self._colours = np.empty((n_points, 3), dtype=np.uint8)
        for k in range(len(sensor_ids)):
            for axis, colour in enumerate(AXIS_COLOURS):
                self._colours[self._copies.vertex_range(4 * k + 1 + axis)] = rgb_bytes(colour)
        self._states = {}
        self.polydata, (self._vtk_points, self._vtk_normals, self._vtk_colours) = shaded_mesh(
            self._points, self._normals, self._colours, self._copies.triangles())
        mapper = vtkPolyDataMapper()
        mapper.SetInputData(self.polydata)
        colour_by_point_rgb(mapper)
        self.actor = figure_actor(mapper)
        self.renderer.AddActor(self.actor)

    def update(self, glyphs: SensorGlyphs, states: Mapping[str, str]) -> None:
        """Place every sensor of ``glyphs`` and colour its box by the state of the sensor on its
        segment (segment → a key of :data:`TINTS`; ``no_sensor`` when unknown); shows them."""
        if (glyphs.sensor_ids, glyphs.segments) != (self.sensor_ids, self.segments) or self.actor is None:
            self._rebuild(tuple(glyphs.sensor_ids), tuple(glyphs.segments))
        boxes = np.asarray(glyphs.matrices, dtype=float)
        placed = np.empty((4 * len(boxes), 4, 4))
        placed[0::4] = boxes
        for axis in range(3):
            placed[1 + axis::4] = boxes @ self._bars[axis]
        self._copies.place(placed, self._points, self._normals)
        self.set_states(states)
        for array in (self._vtk_points, self._vtk_normals):
            array.Modified()
        self.polydata.Modified()
        self.actor.VisibilityOn()

    def set_states(self, states: Mapping[str, str]) -> None:
        """Colour each box by the state of the sensor on its segment (as :meth:`update`),
        leaving the boxes where they are."""
        changed = False
        for k, segment in enumerate(self.segments):
            state = states.get(segment, "no_sensor")
            if state not in TINTS:
                raise ValueError(f"unknown sensor state {state!r} for segment {segment}")
            if self._states.get(segment) != state:
                self._colours[self._copies.vertex_range(4 * k)] = rgb_bytes(TINTS[state])
                self._states[segment] = state
                changed = True
        if changed:
            self._vtk_colours.Modified()

    def hide(self) -> None:
        """Hide the glyphs until the next :meth:`update`."""
        if self.actor is not None:
            self.actor.VisibilityOff()

    @property
    def visible(self) -> bool:
        return self.actor is not None and bool(self.actor.GetVisibility())

    def remove(self) -> None:
        """Take the glyphs out of their renderer."""
        if self.actor is not None:
            self.renderer.RemoveActor(self.actor)
            self.actor = None
            self.sensor_ids, self.segments = (), ()

    def tint_of(self, sensor_id: str) -> str:
        """The sensor state ``sensor_id``'s box is coloured with."""
        return self._states.get(self.segments[self.sensor_ids.index(sensor_id)], "no_sensor")

    def box_vertices(self, sensor_id: str) -> NDArray[np.float64]:
        """The box vertices of ``sensor_id``'s glyph as shown (scene frame, metres), ``(n, 3)``."""
        return self._points[self._copies.vertex_range(4 * self.sensor_ids.index(sensor_id))].copy()
