"""The 3D figure shows exactly the geometry it is given: capsule surfaces from the segment
matrices, spheres at the joint and marker centres, tints per segment."""

from __future__ import annotations

import numpy as np
import pytest
from vtkmodules.vtkRenderingCore import vtkRenderer

from mimucap.core import skeleton
from mimucap.gui.scene.skeleton_actor import TINTS, SkeletonActor
from mimucap.session.views.skeleton_figure import FigureBuilder


@pytest.fixture(params=["ten_segment", "fifteen_segment"])
def figure(request):
    model = skeleton.load_model(request.param)
    builder = FigureBuilder(model, 1.75)
    rng = np.random.default_rng(3)
    q = {name: (lambda v: v / np.linalg.norm(v))(rng.normal(size=4)) for name in model.segment_names}
    geometry = builder.build(skeleton.forward_kinematics(model, q, 1.75), mode="world")
    renderer = vtkRenderer()
    actor = SkeletonActor(renderer, builder)
    return actor, geometry, renderer


def test_hidden_until_the_first_frame_then_shown(figure):
    actor, geometry, renderer = figure
    assert not actor.visible and not actor.sphere_actor.GetVisibility()
    actor.update(geometry)
    assert actor.visible and actor.sphere_actor.GetVisibility()
    assert renderer.GetActors().GetNumberOfItems() == 2
    actor.remove()
    assert renderer.GetActors().GetNumberOfItems() == 0


def test_capsules_lie_on_the_segments_surfaces(figure):
    actor, geometry, _ = figure
    actor.update(geometry)
    for name, matrix in zip(geometry.segment_names, geometry.segment_matrices):
        vertices = actor.vertices_of_segment(name)
        # Back in the unit cylinder's frame every vertex is at radius 1, |y| <= 1/2.
        local = np.linalg.solve(matrix[:3, :3], (vertices - matrix[:3, 3]).T).T
        np.testing.assert_allclose(np.hypot(local[:, 0], local[:, 2]), 1.0, atol=1e-9)
        assert np.all(np.abs(local[:, 1]) <= 0.5 + 1e-9)
        normals = actor._normals[actor._segments.vertex_range(geometry.segment_names.index(name))]
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-9)
        radial = vertices - (matrix[:3, 3] + np.outer(local[:, 1], matrix[:3, 1]))
        assert np.all(np.einsum("ij,ij->i", normals, radial) > 0)  # pointing outwards


def test_spheres_sit_at_the_joint_and_marker_centres(figure):
    actor, geometry, _ = figure
    actor.update(geometry)
    centres, radii = actor.spheres()
    expected = np.concatenate([geometry.joint_matrices, geometry.marker_matrices])
    np.testing.assert_allclose(centres, expected[:, :3, 3], atol=1e-12)
    np.testing.assert_allclose(radii, expected[:, 0, 0], rtol=1e-6)


def test_tints_colour_only_the_segment_concerned(figure):
    actor, geometry, _ = figure
    actor.update(geometry)
    assert actor.set_tints({"pelvis": "ok", "thorax": "stale"})
    assert not actor.set_tints({"pelvis": "ok", "thorax": "stale"})  # nothing changed
    assert actor.tint_of("pelvis") == "ok" and actor.tint_of("thorax") == "stale"
    assert actor.tint_of("shank_r") == "no_sensor"
    index = geometry.segment_names.index("thorax")
    colours = actor._colours[actor._segments.vertex_range(index)]
    assert np.all(colours == np.round(255 * np.array(TINTS["stale"])))
    with pytest.raises(ValueError, match="unknown sensor state"):
        actor.set_tints({"pelvis": "purple"})


def test_a_geometry_of_another_model_is_refused():
    ten = FigureBuilder(skeleton.load_model("ten_segment"), 1.75)
    fifteen_model = skeleton.load_model("fifteen_segment")
    fifteen = FigureBuilder(fifteen_model, 1.75)
    q = {name: np.array([1.0, 0.0, 0.0, 0.0]) for name in fifteen_model.segment_names}
    geometry = fifteen.build(skeleton.forward_kinematics(fifteen_model, q, 1.75))
    actor = SkeletonActor(vtkRenderer(), ten)
    with pytest.raises(ValueError, match="another skeleton model"):
        actor.update(geometry)


def test_capsules_are_lit_by_vtk_with_outward_normals_that_move_with_them(figure):
    from vtkmodules.util.numpy_support import vtk_to_numpy

    from mimucap.gui.scene.skeleton_actor import AMBIENT, DIFFUSE, SPECULAR, SPECULAR_POWER

    actor, geometry, _ = figure
    for prop in (actor.actor.GetProperty(), actor.sphere_actor.GetProperty()):
        assert prop.GetLighting()
        assert (prop.GetAmbient(), prop.GetDiffuse(), prop.GetSpecular(), prop.GetSpecularPower()) == pytest.approx(
            (AMBIENT, DIFFUSE, SPECULAR, SPECULAR_POWER))
    actor.update(geometry)
    drawn = vtk_to_numpy(actor.polydata.GetPointData().GetNormals())
    np.testing.assert_allclose(np.linalg.norm(drawn, axis=1), 1.0, atol=1e-9)
    for index, name in enumerate(geometry.segment_names):
        matrix = geometry.segment_matrices[index]
        axis = matrix[:3, 1] / np.linalg.norm(matrix[:3, 1])
        vertices = actor.vertices_of_segment(name)
        normals = drawn[actor._segments.vertex_range(index)]
        radial = vertices - matrix[:3, 3]
        radial -= (radial @ axis)[:, None] * axis  # from the capsule's axis to the vertex
        radial /= np.linalg.norm(radial, axis=1)[:, None]
        np.testing.assert_allclose(normals, radial, atol=1e-6, err_msg=name)  # outward, across the axis
