"""VTK actors of the skeleton figure: shaded capsules, joint spheres, anterior markers.

The actors are created once per skeleton model (:class:`SkeletonActor`); every frame only
their user matrices change, taken as they are from a
:class:`mimucap.session.figure.FigureGeometry` (scene frame, metres). Each segment capsule
is tinted by the state of the sensor on it (:data:`TINTS`).
"""

from __future__ import annotations

from collections.abc import Mapping

from vtkmodules.vtkCommonMath import vtkMatrix4x4
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


def _shared_source(source) -> vtkPolyDataMapper:
    source.Update()  # a static mapper never asks its input to execute: run it once here
    mapper = vtkPolyDataMapper()
    mapper.SetInputConnection(source.GetOutputPort())
    mapper.StaticOn()  # geometry never changes: only actor matrices do
    return mapper


def _make_actor(mapper: vtkPolyDataMapper, colour, specular: float = 0.35) -> vtkActor:
    actor = vtkActor()
    actor.SetMapper(mapper)
    prop = actor.GetProperty()
    prop.SetColor(*colour)
    prop.SetInterpolationToPhong()
    prop.SetAmbient(0.12)
    prop.SetDiffuse(0.85)
    prop.SetSpecular(specular)
    prop.SetSpecularPower(25.0)
    actor.SetUserMatrix(vtkMatrix4x4())
    actor.VisibilityOff()
    return actor


def _set_matrix(actor: vtkActor, matrix) -> None:
    target = actor.GetUserMatrix()
    for row in range(4):
        for col in range(4):
            target.SetElement(row, col, float(matrix[row, col]))
    target.Modified()
    actor.Modified()


class SkeletonActor:
    """All actors of one figure, added to ``renderer`` and hidden until the first frame.

    Args:
        renderer: the VTK renderer of the 3D view.
        builder: the :class:`FigureBuilder` whose geometry this figure shows (names fixed).
    """

    def __init__(self, renderer: vtkRenderer, builder: FigureBuilder) -> None:
        self.renderer = renderer
        cylinder = vtkCylinderSource()
        cylinder.SetRadius(1.0)
        cylinder.SetHeight(1.0)
        cylinder.SetResolution(18)
        cylinder.CappingOff()
        sphere = vtkSphereSource()
        sphere.SetRadius(1.0)
        sphere.SetThetaResolution(18)
        sphere.SetPhiResolution(12)
        self._sources = (cylinder, sphere)  # an output port does not keep its producer alive
        self._cylinder_mapper = _shared_source(cylinder)
        self._sphere_mapper = _shared_source(sphere)
        self.segment_actors = {
            name: _make_actor(self._cylinder_mapper, TINTS["no_sensor"]) for name in builder.segment_names
        }
        self.connector_actors = [
            _make_actor(self._cylinder_mapper, CONNECTOR_COLOUR) for _ in builder.connector_names
        ]
        self.joint_actors = [
            _make_actor(self._sphere_mapper, JOINT_COLOUR, specular=0.5) for _ in builder.joint_names
        ]
        self.marker_actors = [
            _make_actor(self._sphere_mapper, MARKER_COLOUR, specular=0.1) for _ in builder.segment_names
        ]
        self._tints: dict[str, str] = {}
        for actor in self.actors():
            renderer.AddActor(actor)

    def actors(self) -> list[vtkActor]:
        """Every actor of the figure."""
        return [*self.segment_actors.values(), *self.connector_actors, *self.joint_actors, *self.marker_actors]

    def remove(self) -> None:
        """Take the figure out of its renderer."""
        for actor in self.actors():
            self.renderer.RemoveActor(actor)

    def update(self, geometry: FigureGeometry) -> None:
        """Move every actor to ``geometry`` (and show them)."""
        for name, matrix in zip(geometry.segment_names, geometry.segment_matrices):
            _set_matrix(self.segment_actors[name], matrix)
        for actor, matrix in zip(self.connector_actors, geometry.connector_matrices):
            _set_matrix(actor, matrix)
        for actor, matrix in zip(self.joint_actors, geometry.joint_matrices):
            _set_matrix(actor, matrix)
        for actor, matrix in zip(self.marker_actors, geometry.marker_matrices):
            _set_matrix(actor, matrix)
        for actor in self.actors():
            actor.VisibilityOn()

    def set_tints(self, states: Mapping[str, str]) -> None:
        """Colour each segment by its sensor state name (a key of :data:`TINTS`)."""
        for name, actor in self.segment_actors.items():
            state = states.get(name, "no_sensor")
            if self._tints.get(name) == state:
                continue
            if state not in TINTS:
                raise ValueError(f"unknown sensor state {state!r} for segment {name}")
            actor.GetProperty().SetColor(*TINTS[state])
            self._tints[name] = state

    def tint_of(self, segment: str) -> str:
        """The sensor state a segment is currently tinted with."""
        return self._tints.get(segment, "no_sensor")
