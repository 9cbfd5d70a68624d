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
    labels = dict(stage.axis_labels())
    origin = turn[:3, :3] @ np.array(AXES_ORIGIN_WORLD_M) + turn[:3, 3]
    reach = AXIS_LABEL_POSITION * AXES_LENGTH_M
    np.testing.assert_allclose(labels["E"], origin + turn[:3, :3] @ (reach, 0.0, 0.0), atol=1e-12)
    np.testing.assert_allclose(labels["N"], origin + turn[:3, :3] @ (0.0, reach, 0.0), atol=1e-12)
    np.testing.assert_allclose(labels["Up"], origin + (0.0, 0.0, reach), atol=1e-12)
    stage.set_visible(floor=True, axes=False)
    assert stage.axis_labels() == []
