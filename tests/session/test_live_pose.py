"""The live session's pose part: a pose that lacks a segment is refused by name, the figure is
built once per pose and display mode, the joint angles follow every pose taken; an uncalibrated
pose is drawn as the outline and keeps no joint angles."""

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


def test_an_uncalibrated_pose_is_the_outline_and_keeps_no_joint_angles():
    """Poses made from the sensors' own axes (before a body calibration) give the outline with
    the sensors on it, no joint angles and no figure of the truth; the angles of calibrated poses
    taken before are dropped, and those taken after start afresh."""
    model = skeleton.load_model("ten_segment")
    pose = LivePose(model, 1.75, window_s=10.0, rate_hz=100.0)
    pose.take(0.00, _pose(model, 0.1))
    pose.take(0.01, _pose(model, 0.2))
    assert len(pose.joint_series("knee_r", 1.0)[0]) == 2 and not pose.frame()[1].outline
    worn = {"S10": "shank_r", "S01": "pelvis"}
    pose.take(0.02, _pose(model, 0.3), segment_of_sensor=worn)
    _, geometry = pose.frame()
    assert geometry.outline and set(geometry.sensor_glyphs.sensor_ids) == set(worn)
    assert len(pose.joint_series("knee_r", 1.0)[0]) == 0 and pose.figure_of(_pose(model)) is None
    pose.take(0.03, _pose(model, 0.4))
    t, _angles = pose.joint_series("knee_r", 1.0)
    np.testing.assert_allclose(t, [0.03])
    assert not pose.frame()[1].outline and pose.figure_of(_pose(model)) is not None
