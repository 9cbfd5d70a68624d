"""The stage of the 3D view: floor grid, world axes, a camera light and the background.

The floor is a grid of lines (no solid plane) around the figure: a line every 2.5 m over
30 m × 30 m, and a line every 0.5 m over the central 10 m × 10 m. It moves with the figure in
2.5 m steps, so its lines always fall on the same floor positions and a subject walking any
distance always has 15 m of floor around them. The fine lines fade into the background over
the patch's outer 2.5 m, so the patch has no visible edge and its steps do not make lines pop
in and out beside the figure. The world
axes (E, N, Up; 0.5 m, standing at :data:`AXES_ORIGIN_WORLD_M`) are built in **world**
coordinates (ENU, metres) and placed in the scene by the frame's
``FigureGeometry.world_matrix``, so they turn with the display mode like the figure does.
The axes' names are VTK text actors (:attr:`Stage.axis_labels`) anchored just beyond each
arrow's tip: each name is rasterised once into a texture, and only its place on screen is
computed per frame.
"""

from __future__ import annotations

import numpy as np
from vtkmodules.util.numpy_support import numpy_to_vtk
from vtkmodules.vtkCommonDataModel import vtkPolyData
from vtkmodules.vtkCommonMath import vtkMatrix4x4
from vtkmodules.vtkCommonTransforms import vtkTransform
from vtkmodules.vtkFiltersCore import vtkAppendPolyData, vtkPolyDataNormals
from vtkmodules.vtkFiltersGeneral import vtkTransformFilter
from vtkmodules.vtkFiltersSources import vtkConeSource, vtkCylinderSource
from vtkmodules.vtkRenderingCore import vtkActor, vtkLight, vtkPolyDataMapper, vtkRenderer, vtkTextActor

from mimucap.gui.scene.polydata import colour_by_point_rgb, polydata

#: The floor grid (m) around the figure: coarse lines over a square of FLOOR_SIZE_M, fine ones
#: over a central patch of FLOOR_FINE_SIZE_M. Far away, fine lines would crowd into a grey
#: band (and cost rasterising line by line for nothing to see).
FLOOR_SIZE_M, FLOOR_COARSE_SPACING_M = 30.0, 2.5
FLOOR_FINE_SIZE_M, FLOOR_SPACING_M = 10.0, 0.5
#: The fine lines fade from the grid colour to the background over this margin (m) inside the
#: patch's edge.
FLOOR_FINE_FADE_M = 2.5
AXES_LENGTH_M = 0.5
#: Each axis: a shaft of this radius, then a cone tip of this length and base radius (m).
AXES_SHAFT_RADIUS_M, AXES_TIP_LENGTH_M, AXES_TIP_RADIUS_M = 0.008, 0.1, 0.03
AXES_COLOURS = ((1.0, 0.0, 0.0), (0.0, 0.8, 0.0), (0.0, 0.0, 1.0))  # E, N, Up
#: Where the world axes stand on the floor (world ENU, metres): beside the figure, not inside it.
AXES_ORIGIN_WORLD_M = (-0.75, 0.5, 0.0)
#: Where an axis name stands along its axis, as a fraction of the axis length.
AXIS_LABEL_POSITION = 1.22
AXIS_NAMES = ("E", "N", "Up")
#: The axes' names: bold, this size (points at 72 dots per inch: the render window's DPI
#: follows the screen's pixel ratio), white with a dark shadow so they read on floor and sky.
AXIS_LABEL_FONT_SIZE = 15
BACKGROUND = (0.25, 0.28, 0.34)
GRID_COLOUR = (0.62, 0.65, 0.70)


def _line_positions(size_m: float, spacing_m: float) -> np.ndarray:
    """Where a square grid ``size_m`` wide, centred on the origin, has its lines: every
    ``spacing_m`` from ``-size_m / 2`` to ``size_m / 2`` (metres)."""
    half = size_m / 2.0
    return np.linspace(-half, half, int(round(size_m / spacing_m)) + 1)


def _placed_at(matrix: np.ndarray, origin_world_m) -> np.ndarray:
    """The ``(4, 4)`` world→scene ``matrix`` for a piece built around the world origin and
    standing at ``origin_world_m`` ``(3,)`` instead (world ENU, metres)."""
    placed = matrix.copy()
    placed[:3, 3] = matrix[:3, :3] @ np.asarray(origin_world_m, dtype=float) + matrix[:3, 3]
    return placed


def _grid_lines(size_m: float, spacing_m: float) -> vtkPolyData:
    """A square grid of straight line cells, ``size_m`` wide with a line every ``spacing_m``
    along x and along y (world, metres, on the floor, centred on the origin): two points per
    line, where a wireframe plane has one cell per square."""
    half = size_m / 2.0
    across = _line_positions(size_m, spacing_m)
    n = len(across)
    points = np.zeros((4 * n, 3))  # lines along y (x = c), then along x (y = c); two ends each
    points[0:2 * n:2, :2] = np.c_[across, np.full(n, -half)]
    points[1:2 * n:2, :2] = np.c_[across, np.full(n, half)]
    points[2 * n:, :2] = points[: 2 * n, 1::-1]
    return polydata(numpy_to_vtk(points, deep=True), np.arange(4 * n).reshape(-1, 2))


def _fading_patch_lines(size_m: float, spacing_m: float, coarse_spacing_m: float, fade_m: float) -> vtkPolyData:
    """The fine floor patch: a square grid ``size_m`` wide with a line every ``spacing_m``
    (world, metres, on the floor, centred on the origin), without the lines the coarse grid
    draws (multiples of ``coarse_spacing_m``), each line cut at every crossing so that its
    colour can fade. Point scalars (RGB bytes): :data:`GRID_COLOUR` up to ``fade_m`` from the
    patch's edge, then linearly towards :data:`BACKGROUND`, reached at the edge (distance from
    the centre measured as ``max(|x|, |y|)``, the patch's square shape)."""
    half = size_m / 2.0
    across = _line_positions(size_m, spacing_m)
    on_coarse = np.isclose(np.remainder(across + coarse_spacing_m / 2.0, coarse_spacing_m), coarse_spacing_m / 2.0)
    kept = across[~on_coarse]
    n_lines, n_points = len(kept), len(across)
    # lines along y (x = c), then along x (y = c); each has a point at every crossing
    along_y = np.zeros((n_lines, n_points, 3))
    along_y[:, :, 0] = kept[:, None]
    along_y[:, :, 1] = across[None, :]
    along_x = along_y[:, :, [1, 0, 2]]
    points = np.concatenate((along_y, along_x)).reshape(-1, 3)
    start = np.arange(2 * n_lines)[:, None] * n_points + np.arange(n_points - 1)[None, :]
    segments = np.stack((start.ravel(), start.ravel() + 1), axis=1)
    lines = polydata(numpy_to_vtk(points, deep=True), segments)
    from_edge = half - np.max(np.abs(points[:, :2]), axis=1)
    weight = np.clip(from_edge / fade_m, 0.0, 1.0)[:, None]
    background, grid = np.asarray(BACKGROUND), np.asarray(GRID_COLOUR)
    rgb = np.round(255.0 * (background + weight * (grid - background))).astype(np.uint8)
    colours = numpy_to_vtk(rgb, deep=True)
    colours.SetName("Colours")
    lines.GetPointData().SetScalars(colours)
    return lines


def floor_centre(focus_world_xy) -> tuple[float, float]:
    """Where the floor grid is centred for a figure at ``focus_world_xy`` (world E, N, metres):
    the nearest multiple of the coarse spacing, so that the grid's lines fall on the same
    positions wherever the figure is (the origin for an unknown position)."""
    snapped = np.round(np.asarray(focus_world_xy, dtype=float) / FLOOR_COARSE_SPACING_M) * FLOOR_COARSE_SPACING_M
    x, y = np.nan_to_num(snapped, nan=0.0, posinf=0.0, neginf=0.0)
    return float(x), float(y)


def _axes_mesh() -> vtkPolyData:
    """The three world axes as one mesh (world frame, metres, from the origin): along E, N and
    Up a shaft and a cone tip, :data:`AXES_LENGTH_M` long in all, coloured :data:`AXES_COLOURS`
    (point scalars, RGB bytes). One mesh is one draw call, where VTK's axes actor makes six
    actors and rebuilds them whenever it moves."""
    shaft_length = AXES_LENGTH_M - AXES_TIP_LENGTH_M
    shaft = vtkCylinderSource()  # along +y, centred on the origin
    shaft.SetRadius(AXES_SHAFT_RADIUS_M)
    shaft.SetHeight(shaft_length)
    shaft.SetResolution(12)
    tip = vtkConeSource()  # along +x, centred on the origin, apex towards +x
    tip.SetRadius(AXES_TIP_RADIUS_M)
    tip.SetHeight(AXES_TIP_LENGTH_M)
    tip.SetResolution(16)
    along_x = vtkTransform()  # the shaft from the origin along +x
    along_x.PostMultiply()
    along_x.RotateZ(-90.0)
    along_x.Translate(shaft_length / 2.0, 0.0, 0.0)
    at_the_end = vtkTransform()  # the tip after the shaft
    at_the_end.Translate(shaft_length + AXES_TIP_LENGTH_M / 2.0, 0.0, 0.0)
    #: rotations (angle in degrees, axis) that turn +x onto E, N and Up
    onto_axis = ((0.0, (0.0, 0.0, 1.0)), (90.0, (0.0, 0.0, 1.0)), (-90.0, (0.0, 1.0, 0.0)))
    append = vtkAppendPolyData()
    for (angle, about), colour in zip(onto_axis, AXES_COLOURS):
        for source, placement in ((shaft, along_x), (tip, at_the_end)):
            transform = vtkTransform()
            transform.PostMultiply()
            transform.Concatenate(placement)
            transform.RotateWXYZ(angle, *about)
            moved = vtkTransformFilter()
            moved.SetInputConnection(source.GetOutputPort())
            moved.SetTransform(transform)
            moved.Update()
            piece = vtkPolyData()
            piece.ShallowCopy(moved.GetOutput())
            piece.GetPointData().SetNormals(None)  # made for the whole mesh below
            rgb = np.tile(np.round(255.0 * np.asarray(colour)).astype(np.uint8), (piece.GetNumberOfPoints(), 1))
            colours = numpy_to_vtk(rgb, deep=True)
            colours.SetName("Colours")
            piece.GetPointData().SetScalars(colours)
            append.AddInputData(piece)
    normals = vtkPolyDataNormals()  # sharp edges at the cone's base and the shaft's end
    normals.SetInputConnection(append.GetOutputPort())
    normals.SetFeatureAngle(60.0)
    normals.Update()
    mesh = vtkPolyData()
    mesh.ShallowCopy(normals.GetOutput())
    return mesh


def _line_actor(lines: vtkPolyData, user_matrix: vtkMatrix4x4) -> vtkActor:
    """An unlit actor drawing ``lines`` placed by ``user_matrix``: in their point colours (RGB
    bytes) when they have some, otherwise in the grid colour."""
    mapper = vtkPolyDataMapper()
    mapper.SetInputData(lines)
    mapper.SetResolveCoincidentTopologyToPolygonOffset()
    if lines.GetPointData().GetScalars() is not None:
        colour_by_point_rgb(mapper)
    actor = vtkActor()
    actor.SetMapper(mapper)
    prop = actor.GetProperty()
    prop.SetColor(*GRID_COLOUR)
    prop.LightingOff()
    actor.SetUserMatrix(user_matrix)
    return actor


def _axis_label(name: str) -> vtkTextActor:
    """The text actor of an axis name, centred on its anchor, which is given in the scene
    (metres) by :meth:`Stage.set_world_matrix`."""
    label = vtkTextActor()
    label.SetInput(name)
    label.GetPositionCoordinate().SetCoordinateSystemToWorld()
    text = label.GetTextProperty()
    text.SetFontSize(AXIS_LABEL_FONT_SIZE)
    text.BoldOn()
    text.SetColor(1.0, 1.0, 1.0)
    text.ShadowOn()
    text.SetJustificationToCentered()
    text.SetVerticalJustificationToCentered()
    label.PickableOff()
    return label


def scene_renderer() -> vtkRenderer:
    """A renderer set up for the skeleton scene.

    No FXAA, and no frustum culling: every prop stands in or near the view, and VTK's culler
    would compute all their bounds on every frame to find that out (2 % of a core at 60
    frames per second)."""
    renderer = vtkRenderer()
    renderer.SetUseFXAA(False)
    renderer.GetCullers().RemoveAllItems()
    return renderer


class Stage:
    """Floor, axes, lights and background of ``renderer``."""

    def __init__(self, renderer: vtkRenderer) -> None:
        self.renderer = renderer
        # Single-colour background, one light following the camera (a headlight: every part
        # the viewer sees is lit), and a floor made of grid lines only.
        renderer.GradientBackgroundOff()
        renderer.SetBackground(*BACKGROUND)
        renderer.RemoveAllLights()
        self.light = vtkLight()
        self.light.SetLightTypeToHeadlight()
        self.light.SetIntensity(1.0)
        renderer.AddLight(self.light)

        self._placed: np.ndarray | None = None  # the last world matrix applied
        self._floor_centre = (0.0, 0.0)  # world E, N of the floor grid's centre (m)
        self.floor_matrix = vtkMatrix4x4()  # places both grids
        self.axes_matrix = vtkMatrix4x4()
        # Keep the sources referenced: an output port does not keep its producer alive.
        self._grid_lines = _grid_lines(FLOOR_SIZE_M, FLOOR_COARSE_SPACING_M)
        self._patch_lines = _fading_patch_lines(FLOOR_FINE_SIZE_M, FLOOR_SPACING_M, FLOOR_COARSE_SPACING_M,
                                                FLOOR_FINE_FADE_M)
        self.grid = _line_actor(self._grid_lines, self.floor_matrix)
        self.fine_grid = _line_actor(self._patch_lines, self.floor_matrix)

        self._axes_mesh = _axes_mesh()
        axes_mapper = vtkPolyDataMapper()
        axes_mapper.SetInputData(self._axes_mesh)
        colour_by_point_rgb(axes_mapper)
        self.axes = vtkActor()
        self.axes.SetMapper(axes_mapper)
        axes_prop = self.axes.GetProperty()
        axes_prop.SetAmbient(0.25)
        axes_prop.SetDiffuse(0.75)
        axes_prop.BackfaceCullingOn()
        self.axes.SetUserMatrix(self.axes_matrix)
        self.axis_labels = tuple(_axis_label(name) for name in AXIS_NAMES)
        self.set_world_matrix(np.eye(4))

        for actor in (self.grid, self.fine_grid, self.axes):
            renderer.AddActor(actor)
        for label in self.axis_labels:
            renderer.AddViewProp(label)

    def set_world_matrix(self, matrix, focus_world_m=None) -> None:
        """Place floor and axes with a ``(4, 4)`` world→scene matrix (``FigureGeometry.world_matrix``),
        and the floor grid around ``focus_world_m`` ``(3,)`` (world ENU, metres: the figure's
        root, ``FigureGeometry.root_world_m``) when given."""
        matrix = np.asarray(matrix, dtype=float)
        centre = self._floor_centre if focus_world_m is None else floor_centre(np.asarray(focus_world_m)[:2])
        if self._placed is not None and np.array_equal(matrix, self._placed) and centre == self._floor_centre:
            return  # unchanged (the usual case in world mode): VTK has nothing to update
        self._placed = matrix.copy()
        self._floor_centre = centre
        self.floor_matrix.DeepCopy(_placed_at(matrix, (centre[0], centre[1], 0.0)).ravel())
        axes = _placed_at(matrix, AXES_ORIGIN_WORLD_M)
        self.axes_matrix.DeepCopy(axes.ravel())
        label_points = (AXIS_LABEL_POSITION * AXES_LENGTH_M) * axes[:3, :3].T + axes[:3, 3]  # scene, m
        for actor in (self.grid, self.fine_grid, self.axes):
            actor.Modified()
        for label, point in zip(self.axis_labels, label_points.tolist()):
            label.GetPositionCoordinate().SetValue(*point)

    @property
    def floor_centre(self) -> tuple[float, float]:
        """World E, N (m) of the centre of the floor grid."""
        return self._floor_centre

    def set_visible(self, floor: bool, axes: bool) -> None:
        """Show or hide the floor grid and the world axes."""
        self.grid.SetVisibility(floor)
        self.fine_grid.SetVisibility(floor)
        self.axes.SetVisibility(axes)
        for label in self.axis_labels:
            label.SetVisibility(axes)
