"""The vectorised figure builder places every piece where a plain per-piece construction does.

The reference below builds each matrix on its own, straight from the definitions in
:mod:`mimucap.session.views.skeleton_figure`'s docstrings (unit cylinder along scene y, its x axis along the
segment's anterior axis made orthogonal, unit spheres scaled by their radius), so that the
vectorised :meth:`FigureBuilder.build` can be checked on random poses of both models in both
display modes.
"""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core import rotation, skeleton
from mimucap.session.views.skeleton_figure import (
    CONNECTOR_RADIUS_FACTOR,
    END_CAP_RADIUS_FACTOR,
    JOINT_RADIUS_FACTOR,
    MARKER_RADIUS_FACTOR,
    MIN_CONNECTOR_M,
    R_SCENE_FROM_WORLD,
    FigureBuilder,
)

TOLERANCE = 1e-9


def _reference_capsule(p0, p1, x_hint, radius):
    """Unit cylinder (radius 1, height 1 along y, centred) onto the capsule body p0 → p1."""
    length = np.linalg.norm(p1 - p0)
    y = (p1 - p0) / length if length > 0 else np.array([0.0, 1.0, 0.0])
    x = x_hint - np.dot(x_hint, y) * y
    if np.linalg.norm(x) < 1e-9:
        helper = np.array([1.0, 0.0, 0.0]) if abs(y[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
        x = helper - np.dot(helper, y) * y
    x = x / np.linalg.norm(x)
    matrix = np.eye(4)
    matrix[:3, :3] = np.column_stack((x * radius, y * length, np.cross(x, y) * radius))
    matrix[:3, 3] = (p0 + p1) / 2.0
    return matrix


def _reference_sphere(center, radius):
    matrix = np.diag([radius, radius, radius, 1.0])
    matrix[:3, 3] = center
    return matrix


def _reference_build(model, height_m, poses, mode, heading_ref_rad, origin_world_m):
    """One frame of the figure, piece by piece (see the module doc of figure.py)."""
    radius = {s.name: s.radius_ratio * height_m for s in model.segments}
    root = poses[model.root]
    if mode == "body":
        x_root = rotation.rotate(root.q_world_from_segment, [1.0, 0.0, 0.0])
        heading = np.arctan2(-x_root[0], x_root[1]) if np.hypot(x_root[0], x_root[1]) >= 1e-9 else 0.0
        alpha = np.pi - heading
        shift = np.array([root.proximal_m[0], root.proximal_m[1], 0.0])
    else:
        alpha = 0.0 if heading_ref_rad is None else np.pi - heading_ref_rad
        shift = np.array([origin_world_m[0], origin_world_m[1], 0.0])
    c, s = np.cos(alpha), np.sin(alpha)
    r_display = R_SCENE_FROM_WORLD @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def scene(p_world):
        return r_display @ (np.asarray(p_world) - shift)

    prox = {name: scene(poses[name].proximal_m) for name in model.segment_names}
    dist = {name: scene(poses[name].distal_m) for name in model.segment_names}
    front = {name: r_display @ rotation.rotate(poses[name].q_world_from_segment, [1.0, 0.0, 0.0])
             for name in model.segment_names}

    segments = [_reference_capsule(prox[n], dist[n], front[n], radius[n]) for n in model.segment_names]
    markers = []
    for name, matrix in zip(model.segment_names, segments):
        x_unit = matrix[:3, 0] / radius[name]
        markers.append(_reference_sphere((prox[name] + dist[name]) / 2 + x_unit * radius[name],
                                         MARKER_RADIUS_FACTOR * radius[name]))

    connectors, distal_joints = [], set()
    for seg in model.segments[1:]:
        parent = model.segment(seg.parent)
        attach, direction = np.array(seg.attach_ratio), np.array(parent.direction)
        along = attach @ direction
        if np.linalg.norm(attach - along * direction) * height_m >= MIN_CONNECTOR_M:
            fraction = along / parent.length_ratio
            anchor = prox[parent.name] + fraction * (dist[parent.name] - prox[parent.name])
            connectors.append(_reference_capsule(anchor, prox[seg.name], front[parent.name],
                                                 CONNECTOR_RADIUS_FACTOR * radius[parent.name]))
        elif abs(along - parent.length_ratio) * height_m < MIN_CONNECTOR_M:
            distal_joints.add(parent.name)

    joints = [_reference_sphere(prox[model.root], 0.8 * radius[model.root])]
    joints += [_reference_sphere(prox[seg.name], JOINT_RADIUS_FACTOR * min(radius[seg.name], radius[seg.parent]))
               for seg in model.segments if seg.joint is not None]
    joints += [_reference_sphere(dist[name], END_CAP_RADIUS_FACTOR * radius[name]) for name in model.segment_names if name not in distal_joints]

    world = np.eye(4)
    world[:3, :3] = r_display
    world[:3, 3] = -r_display @ shift
    return {
        "segment_matrices": np.array(segments), "marker_matrices": np.array(markers),
        "connector_matrices": np.array(connectors).reshape(-1, 4, 4), "joint_matrices": np.array(joints),
        "root_scene_m": prox[model.root], "root_world_m": poses[model.root].proximal_m,
        "world_matrix": world, "heading_alpha_rad": alpha,
    }


def _random_pose(model, rng):
    """Random segment orientations, at times with segments sharing their parent's orientation
    (straight limbs) so that the connector and joint placements meet aligned axes too."""
    q = {name: rotation.normalize(rng.normal(size=4)) for name in model.segment_names}
    for seg in model.segments[1:]:
        if rng.random() < 0.3:
            q[seg.name] = q[seg.parent]
    return q


@pytest.mark.parametrize("model_name", skeleton.MODEL_NAMES)
@pytest.mark.parametrize("mode", ["world", "body"])
def test_vectorised_build_matches_the_piecewise_reference(model_name, mode):
    model = skeleton.load_model(model_name)
    rng = np.random.default_rng(17 if mode == "world" else 29)
    for trial in range(25):
        height = rng.uniform(1.2, 2.1)
        builder = FigureBuilder(model, height)
        q = _random_pose(model, rng)
        poses = skeleton.forward_kinematics(model, q, height, rng.normal(size=3))
        heading_ref = None if trial % 3 == 0 else rng.uniform(-np.pi, np.pi)
        origin = rng.normal(size=2)
        geometry = builder.build(poses, mode=mode, heading_ref_rad=heading_ref, origin_world_m=origin)
        expected = _reference_build(model, height, poses, mode, heading_ref, origin)
        assert geometry.segment_names == model.segment_names
        assert len(geometry.connector_names) == len(expected["connector_matrices"])
        assert len(geometry.joint_names) == len(expected["joint_matrices"])
        assert geometry.heading_alpha_rad == pytest.approx(expected["heading_alpha_rad"], abs=TOLERANCE)
        for field in ("segment_matrices", "marker_matrices", "connector_matrices", "joint_matrices",
                      "root_scene_m", "root_world_m", "world_matrix"):
            np.testing.assert_allclose(getattr(geometry, field), expected[field], rtol=0, atol=TOLERANCE,
                                       err_msg=f"{model_name} {mode} trial {trial}: {field}")


@pytest.mark.parametrize("model_name", skeleton.MODEL_NAMES)
def test_build_from_arrays_equals_build_from_poses(model_name):
    model = skeleton.load_model(model_name)
    rng = np.random.default_rng(5)
    builder = FigureBuilder(model, 1.75)
    q = _random_pose(model, rng)
    stacked = np.array([q[name] for name in model.segment_names])
    proximal, distal = skeleton.forward_kinematics_stacked(model, stacked, 1.75)
    poses = skeleton.forward_kinematics(model, q, 1.75)
    for mode in ("world", "body"):
        a = builder.build(poses, mode=mode, heading_ref_rad=0.4)
        b = builder.build_arrays(proximal, distal, stacked, mode=mode, heading_ref_rad=0.4)
        for field in ("segment_matrices", "marker_matrices", "connector_matrices", "joint_matrices", "world_matrix"):
            np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    with pytest.raises(ValueError, match="model order"):
        builder.build_arrays(proximal[:-1], distal, stacked)


def test_degenerate_capsules_stay_finite():
    """A zero-length piece and an anterior axis along the long axis still give finite,
    orthogonal placements (the helper axes of the module doc)."""
    model = skeleton.load_model("ten_segment")
    builder = FigureBuilder(model, 1.75)
    q = {name: skeleton.q_world_from_body_facing(0.0) for name in model.segment_names}
    stacked = np.array([q[name] for name in model.segment_names])
    proximal, distal = skeleton.forward_kinematics_stacked(model, stacked, 1.75)
    distal = distal.copy()
    distal[1] = proximal[1]  # zero-length thorax
    # Thigh along its own anterior axis: the hint is parallel to the long axis.
    thigh = model.segment_names.index("thigh_r")
    anterior = rotation.rotate(stacked[thigh], [1.0, 0.0, 0.0])
    distal[thigh] = proximal[thigh] + 0.4 * anterior
    geometry = builder.build_arrays(proximal, distal, stacked)
    assert np.all(np.isfinite(geometry.segment_matrices))
    for index in (1, thigh):
        x, y, z = (geometry.segment_matrices[index][:3, k] for k in range(3))
        assert abs(np.dot(x, z)) < 1e-12 and np.linalg.norm(x) > 0
    poses = {name: skeleton.SegmentPose(proximal[i], distal[i], stacked[i])
             for i, name in enumerate(model.segment_names)}
    expected = _reference_build(model, 1.75, poses, "world", None, (0.0, 0.0))
    np.testing.assert_allclose(geometry.segment_matrices, expected["segment_matrices"], rtol=0, atol=TOLERANCE)
