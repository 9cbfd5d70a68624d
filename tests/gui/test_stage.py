"""The stage's world axes: three coloured arrows along E, N and Up, named at their tips."""

from __future__ import annotations

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkRenderingCore import vtkRenderer

from mimucap.gui.scene.environment import (AXES_COLOURS, AXES_LENGTH_M, AXES_ORIGIN_WORLD_M,
                                           AXES_TIP_RADIUS_M, AXIS_LABEL_POSITION, Stage, _axes_mesh)


def test_each_axis_is_an_arrow_of_its_colour_from_the_origin_along_its_direction():
    mesh = _axes_mesh()
    points = vtk_to_numpy(mesh.GetPoints().GetData())
    colours = vtk_to_numpy(mesh.GetPointData().GetScalars())
    assert mesh.GetPointData().GetNormals() is not None
    for axis, colour in enumerate(AXES_COLOURS):
        mine = points[np.all(colours == np.round(255 * np.array(colour)), axis=1)]
        assert len(mine) > 20
        along = mine[:, axis]
        across = np.delete(mine, axis, axis=1)
        assert along.min() > -1e-6 and abs(along.max() - AXES_LENGTH_M) < 1e-6  # from the origin to the apex
        assert np.abs(across).max() <= AXES_TIP_RADIUS_M + 1e-6


def test_axis_names_stand_beyond_the_tips_and_follow_the_world_matrix():
    stage = Stage(vtkRenderer())
    turn = np.eye(4)
    turn[:3, :3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]  # 90° about Up
    turn[:3, 3] = (1.0, 2.0, 0.0)
    stage.set_world_matrix(turn)
    labels = {label.GetInput(): label.GetPositionCoordinate().GetValue() for label in stage.axis_labels}
    origin = turn[:3, :3] @ np.array(AXES_ORIGIN_WORLD_M) + turn[:3, 3]
    reach = AXIS_LABEL_POSITION * AXES_LENGTH_M
    np.testing.assert_allclose(labels["E"], origin + turn[:3, :3] @ (reach, 0.0, 0.0), atol=1e-12)
    np.testing.assert_allclose(labels["N"], origin + turn[:3, :3] @ (0.0, reach, 0.0), atol=1e-12)
    np.testing.assert_allclose(labels["Up"], origin + (0.0, 0.0, reach), atol=1e-12)
    stage.set_visible(floor=True, axes=False)
    assert not any(label.GetVisibility() for label in stage.axis_labels)


def test_the_scene_tests_projection_matches_vtks_own_for_any_camera():
    from vtkmodules.vtkRenderingCore import vtkRenderWindow

    from tests.gui.scene_projection import world_to_display

    window = vtkRenderWindow()
    window.OffScreenRenderingOn()
    window.SetSize(483, 560)
    renderer = vtkRenderer()
    window.AddRenderer(renderer)
    rng = np.random.default_rng(7)
    points = rng.uniform(-3.0, 3.0, size=(40, 3))
    camera = renderer.GetActiveCamera()
    for position, view_angle, viewport in (((0.0, -6.0, 1.0), 30.0, (0, 0, 1, 1)),
                                           ((4.0, 3.0, 5.0), 45.0, (0, 0, 1, 1)),
                                           ((-2.0, 5.0, -1.0), 20.0, (0.2, 0.1, 0.9, 0.8))):
        renderer.SetViewport(*viewport)
        camera.SetPosition(*position)
        camera.SetFocalPoint(0.0, 0.0, 0.5)
        camera.SetViewUp(0.0, 0.0, 1.0)
        camera.SetViewAngle(view_angle)
        camera.SetClippingRange(0.5, 20.0)
        expected = []
        for point in points:
            renderer.SetWorldPoint(*point, 1.0)
            renderer.WorldToDisplay()
            expected.append(renderer.GetDisplayPoint())
        np.testing.assert_allclose(world_to_display(renderer, points), expected, rtol=1e-9, atol=1e-6)


def test_floor_grids_are_square_line_grids_of_their_size_and_spacing():
    from mimucap.gui.scene.environment import _grid_lines

    grid = _grid_lines(10.0, 0.5)
    segments = vtk_to_numpy(grid.GetPoints().GetData()).reshape(-1, 2, 3)
    assert grid.GetNumberOfLines() == len(segments) == 2 * 21
    assert np.all(segments[:, :, 2] == 0.0)  # on the floor
    along_y, along_x = segments[:21], segments[21:]
    np.testing.assert_allclose(along_y[:, 0, 0], np.arange(-5.0, 5.01, 0.5))
    np.testing.assert_allclose(along_y[:, :, 0], along_y[:, ::-1, 0])  # straight along y
    np.testing.assert_allclose(along_y[:, :, 1], [[-5.0, 5.0]] * 21)
    np.testing.assert_allclose(along_x[:, :, :2], along_y[:, :, 1::-1])  # the mirror image


def test_fine_floor_patch_leaves_the_coarse_lines_alone_and_fades_into_the_background_at_its_edge():
    from mimucap.gui.scene.environment import BACKGROUND, GRID_COLOUR, _fading_patch_lines

    patch = _fading_patch_lines(10.0, 0.5, 2.5, 2.5)
    points = vtk_to_numpy(patch.GetPoints().GetData())
    colours = vtk_to_numpy(patch.GetPointData().GetScalars()).astype(float)
    segments = vtk_to_numpy(patch.GetLines().GetConnectivityArray()).reshape(-1, 2)
    assert np.all(points[:, 2] == 0.0)
    ends = points[segments]
    along_y = np.isclose(ends[:, 0, 0], ends[:, 1, 0])
    line_at = np.where(along_y, ends[:, 0, 0], ends[:, 0, 1])  # x of a line along y, y of one along x
    assert np.all(np.isclose(ends[along_y, 0, 0], ends[along_y, 1, 0]))
    assert np.all(np.isclose(ends[~along_y, 0, 1], ends[~along_y, 1, 1]))  # the others run along x
    fine = np.arange(-5.0, 5.01, 0.5)
    expected = fine[~np.isclose(np.remainder(fine, 2.5), 0.0) & ~np.isclose(np.remainder(fine, 2.5), 2.5)]
    np.testing.assert_allclose(np.unique(line_at.round(6)), expected)  # none on a coarse line
    assert len(expected) == 16 and len(segments) == 2 * 16 * 20  # cut at each 0.5 m crossing
    np.testing.assert_allclose(np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1), 0.5)
    grid, background = 255 * np.array(GRID_COLOUR), 255 * np.array(BACKGROUND)
    from_edge = 5.0 - np.max(np.abs(points[:, :2]), axis=1)
    np.testing.assert_allclose(colours[from_edge >= 2.5], np.broadcast_to(grid, colours[from_edge >= 2.5].shape), atol=0.5)
    np.testing.assert_allclose(colours[from_edge == 0.0], np.broadcast_to(background, colours[from_edge == 0.0].shape), atol=0.5)
    halfway = np.isclose(from_edge, 1.0)  # 40 % of the way from the background to the grid colour
    np.testing.assert_allclose(colours[halfway], np.broadcast_to(background + 0.4 * (grid - background),
                                                                  colours[halfway].shape), atol=0.5)


def test_the_floor_follows_the_figure_on_the_coarse_lines_however_far_it_walks():
    from mimucap.gui.scene.environment import FLOOR_COARSE_SPACING_M, FLOOR_SPACING_M, floor_centre

    assert floor_centre((0.3, -1.1)) == (0.0, 0.0)
    assert floor_centre((3.9, -6.4)) == (5.0, -7.5)
    assert floor_centre((40.0, -99.0)) == (40.0, -100.0)  # no edge of the world: 15 m around the figure
    assert floor_centre((float("nan"), 1.0)) == (0.0, 0.0)
    assert (FLOOR_COARSE_SPACING_M / FLOOR_SPACING_M) % 1 == 0  # patch lines fall on fine positions

    stage = Stage(vtkRenderer())
    turn = np.eye(4)
    turn[:3, :3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]  # 90° about Up
    turn[:3, 3] = (1.0, 2.0, 0.0)
    figure_world = np.array([31.2, -2.4, 0.9])
    stage.set_world_matrix(turn, figure_world)
    assert stage.floor_centre == (30.0, -2.5)
    expected = turn.copy()
    expected[:3, 3] = turn[:3, :3] @ (30.0, -2.5, 0.0) + turn[:3, 3]
    for actor in (stage.grid, stage.fine_grid):  # both grids, centred under the figure
        placed = actor.GetUserMatrix()
        np.testing.assert_allclose([[placed.GetElement(i, j) for j in range(4)] for i in range(4)], expected,
                                   atol=1e-12)
    stage.set_visible(floor=False, axes=True)
    assert not stage.grid.GetVisibility() and not stage.fine_grid.GetVisibility()
