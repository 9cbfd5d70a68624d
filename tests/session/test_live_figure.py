"""The live pipeline's figure follows the conventions: east to the right, north away, y up."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core.simulate.config import SimulationConfig
from mimucap.session.views.camera import camera_preset, follow_shift
from mimucap.session.sources.feeds import SimulatorFeed
from mimucap.session.live.live_session import LiveSession, open_live_session


def _session(scenario: str, now: list[float]) -> LiveSession:
    """The simulated suit with ideal sensors mounted along their segments: before a body
    calibration each sensor's axes are shown as its segment's, which then are the segment's."""
    clock = lambda: now[0]  # noqa: E731
    config = SimulationConfig(scenario=scenario, errors="ideal", random_mounting=False)
    return LiveSession(SimulatorFeed(config, clock=clock), clock=clock)


def _segment_centre(geometry, name):
    return geometry.segment_matrices[geometry.segment_names.index(name)][:3, 3]


@pytest.fixture
def npose():
    """A subject standing in N-pose, facing north (simulator heading 0)."""
    now = [10.0]
    session = _session("npose", now)
    session.start()
    now[0] += 0.5
    assert session.step() > 0
    return session


def test_world_mode_shows_east_right_north_away_up_up(npose):
    _, geometry = npose.frame()
    height = npose.height_m
    right_arm, left_arm = _segment_centre(geometry, "upper_arm_r"), _segment_centre(geometry, "upper_arm_l")
    # Facing north, the subject's right hand points east: scene +x (right on screen).
    assert right_arm[0] > 0.1 and left_arm[0] < -0.1
    thorax, shank = _segment_centre(geometry, "thorax"), _segment_centre(geometry, "shank_r")
    assert thorax[1] > shank[1] + 0.4 * height  # scene y is up
    # The anterior markers sit on the north side of the segments: away from the viewer (−z).
    marker = geometry.marker_matrices[geometry.segment_names.index("thorax")][:3, 3]
    assert marker[2] < thorax[2]
    assert np.allclose(geometry.world_matrix[:3, :3], [[1, 0, 0], [0, 0, 1], [0, -1, 0]])


def test_body_mode_turns_the_figure_to_face_the_camera(npose):
    npose.set_display_mode("body")
    frame_id, geometry = npose.frame()
    assert frame_id[1] == "body"
    thorax = _segment_centre(geometry, "thorax")
    marker = geometry.marker_matrices[geometry.segment_names.index("thorax")][:3, 3]
    assert marker[2] > thorax[2]  # the chest faces the viewer
    assert _segment_centre(geometry, "upper_arm_r")[0] < -0.1  # its right arm is on screen left
    assert abs(geometry.root_scene_m[0]) < 1e-9 and abs(geometry.root_scene_m[2]) < 1e-9


def test_bad_display_mode_and_source_are_refused(npose):
    with pytest.raises(ValueError, match="display mode"):
        npose.set_display_mode("sideways")
    with pytest.raises(ValueError):
        open_live_session("carrier-pigeon:1")
    with pytest.raises(ValueError, match="skeleton model"):
        open_live_session("simulated:walk", model_name="octopus")


def test_the_skeleton_model_is_chosen_with_the_source():
    assert open_live_session("simulated:walk").model.name == "ten_segment"
    fifteen = open_live_session("simulated:walk", model_name="fifteen_segment")
    assert fifteen.model.name == "fifteen_segment" and len(fifteen.sensor_ids) == 17
    assert open_live_session("simulated:walk", n_sensors=17).model.name == "fifteen_segment"
    udp = open_live_session("udp:127.0.0.1:5599", model_name="fifteen_segment")
    assert udp.model.name == "fifteen_segment" and "head" in udp.builder.segment_names
    assert open_live_session("udp:127.0.0.1:5599").model.name == "ten_segment"


def test_frames_advance_with_the_wall_clock():
    now = [100.0]
    session = _session("walk", now)
    session.start()
    assert session.frame() is None
    now[0] += 0.05
    session.step()
    first_id, first = session.frame()
    now[0] += 0.2
    assert session.step() == 10 * 20  # ten sensors at 100 Hz
    second_id, second = session.frame()
    assert second_id != first_id
    assert session.time_s == pytest.approx(0.25, abs=0.011)
    assert not np.allclose(first.segment_matrices, second.segment_matrices)


def test_camera_presets_frame_the_figure():
    root = np.array([0.3, 0.9, -0.2])
    front = camera_preset("front", root, 1.75)
    assert front.position[2] > front.focal_point[2] + 3.0  # in front of the figure, looking towards −z (north)
    side = camera_preset("side", root, 1.75)
    assert side.position[0] > side.focal_point[0] + 3.0
    top = camera_preset("top", root, 1.75)
    assert top.position[1] > top.focal_point[1] + 3.0 and np.allclose(top.view_up, (0, 0, -1))
    moved = camera_preset("front", root + [1.0, 0, 0], 1.75)
    assert moved.focal_point[0] == pytest.approx(1.3)
    with pytest.raises(ValueError, match="camera preset"):
        camera_preset("fisheye", root, 1.75)
    # Following moves along the floor only: a bobbing root does not shake the view.
    np.testing.assert_allclose(follow_shift(root, root + [0.5, 0.04, -0.2]), [0.5, 0.0, -0.2])
