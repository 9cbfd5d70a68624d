"""The live session's pose part: a pose that lacks a segment is refused by name, the figure is
built once per pose and display mode, the joint angles follow every pose taken."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core import rotation, skeleton
from mimucap.session.views.live_pose import LivePose


def _pose(model, angle_rad: float = 0.0) -> dict[str, np.ndarray]:
    """Every segment upright except the right shank, turned ``angle_rad`` about its z axis."""
    q = {name: rotation.identity() for name in model.segment_names}
    q["shank_r"] = rotation.from_axis_angle(np.array([0.0, 0.0, 1.0]), angle_rad)
    return q


def test_a_pose_without_a_segment_of_the_model_is_refused_by_name():
    model = skeleton.load_model("ten_segment")
    pose = LivePose(model, 1.75, window_s=10.0, rate_hz=100.0)
    q = _pose(model)
    del q["forearm_l"]
    with pytest.raises(ValueError, match="lacks segments of the ten_segment model: forearm_l"):
        pose.take(0.0, q)
    assert pose.frame() is None and pose.figure_of(_pose(model)) is None


def test_the_figure_is_built_once_per_pose_and_display_mode():
    model = skeleton.load_model("ten_segment")
    pose = LivePose(model, 1.75, window_s=10.0, rate_hz=100.0)
    pose.take(0.0, _pose(model))
    first = pose.frame()
    assert pose.frame() is first  # asked again: the same picture
    pose.set_display_mode("body")
    second = pose.frame()
    assert second[0] != first[0]
    pose.take(0.01, _pose(model, 0.3))
    assert pose.frame()[0] not in (first[0], second[0])
    with pytest.raises(ValueError):
        pose.set_display_mode("sideways")


def test_the_joint_angles_follow_every_pose_taken():
    model = skeleton.load_model("ten_segment")
    pose = LivePose(model, 1.75, window_s=10.0, rate_hz=100.0)
    angles = np.radians([0.0, 10.0, 20.0, 30.0])
    for k, angle in enumerate(angles):
        pose.take(0.01 * k, _pose(model, angle))
    t, knee = pose.joint_series("knee_r", 1.0)
    np.testing.assert_allclose(t, 0.01 * np.arange(4))
    expected = skeleton.joint_angles_deg(model, {s: np.array([_pose(model, a)[s] for a in angles])
                                                 for s in model.segment_names})
    np.testing.assert_allclose(knee[:, 0], expected["knee_r_flexion_deg"], atol=1e-9)
    assert np.ptp(np.abs(knee[:, 0])) == pytest.approx(30.0, abs=1e-6)
