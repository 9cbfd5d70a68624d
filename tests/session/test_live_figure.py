"""The live pipeline's figure follows the conventions: east to the right, north away, y up; before
a body calibration it is the neutral outline with each sensor on its segment, turning as the
sensor turns."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core import rotation, skeleton
from mimucap.core.simulate.config import SimulationConfig
from mimucap.session.views.camera import camera_preset, follow_shift
from mimucap.session.views.skeleton_figure import R_SCENE_FROM_WORLD
from tests.known_mounting import known_mounting_calibration
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


def _skeleton_of(session, mode: str):
    """The skeleton figure of the session's newest pose (the sensors' axes, which with ideal
    sensors mounted along their segments are the segments'), without a reference heading."""
    q = np.array([session.q_world_from_segment[name] for name in session.model.segment_names])
    proximal, distal = skeleton.forward_kinematics_stacked(session.model, q, session.height_m)
    return session.builder.build_arrays(proximal, distal, q, mode=mode)


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
    geometry = _skeleton_of(npose, "world")
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
    geometry = _skeleton_of(npose, "body")
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
    # before a body calibration the outline stands still and its sensors turn
    np.testing.assert_array_equal(first.segment_matrices, second.segment_matrices)
    assert not np.allclose(first.sensor_glyphs.matrices, second.sensor_glyphs.matrices)


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


def _glyph(geometry, sensor_id):
    glyphs = geometry.sensor_glyphs
    return glyphs.segments[glyphs.sensor_ids.index(sensor_id)], glyphs.matrices[glyphs.sensor_ids.index(sensor_id)]


def test_before_a_body_calibration_the_figure_is_the_outline_with_each_sensor_on_its_segment(npose):
    """The figure does not follow the sensors' axes (a tangle): it is the standing outline, the
    same for any pose, facing the viewer, with one glyph per assigned sensor halfway along the
    front of the segment it is worn on; no joint angles are kept and no truth is compared."""
    _, geometry = npose.frame()
    assert geometry.outline and npose.pose_source == "sensor axes (no body calibration)"
    outline = npose.builder.build_arrays(*npose.builder.outline_pose())
    np.testing.assert_array_equal(geometry.segment_matrices, outline.segment_matrices)
    assert _segment_centre(geometry, "upper_arm_r")[0] < -0.1  # facing the viewer: its right on screen left
    worn = {sensor: segment for sensor, segment in npose.sensor_segments.items() if segment is not None}
    assert dict(zip(geometry.sensor_glyphs.sensor_ids, geometry.sensor_glyphs.segments)) == worn
    for sensor, segment in worn.items():
        _, matrix = _glyph(geometry, sensor)
        centre = _segment_centre(geometry, segment)
        along = geometry.segment_matrices[geometry.segment_names.index(segment)][:3, 1]
        offset = matrix[:3, 3] - centre
        assert abs(offset @ along) < 1e-9 * np.linalg.norm(along) + 1e-9  # halfway along
        assert 0 < offset[2] < 0.2  # on its front, towards the viewer
    assert npose.joint_series("knee_r", 5.0)[0].size == 0
    assert npose.truth_errors() == {} and npose.truth_frame() is None


def test_a_sensor_glyph_turns_with_its_sensors_measured_orientation():
    """The glyph of a sensor shows the filter's ``q_world_from_sensor`` in the scene: when the
    subject walks, each glyph's axes are its sensor's orientation (heading included) mapped by
    R_scene_from_world, and they change as the sensor turns while the outline stays."""
    now = [10.0]
    session = _session("walk", now)
    session.start()
    mounting = session.feed.simulator.mounting
    seen = []
    for _ in range(3):
        now[0] += 0.4
        session.step()
        _, geometry = session.frame()
        truth = session.feed.last_truth
        for sensor in ("S08", "S10"):
            segment, matrix = _glyph(geometry, sensor)
            side = np.linalg.norm(matrix[:3, 0])
            # the pose's orientation of that segment is its sensor's, as the filter gave it
            np.testing.assert_allclose(matrix[:3, :3] / side, R_SCENE_FROM_WORLD @ rotation.to_matrix(
                session.q_world_from_segment[segment]), atol=1e-9)
            # and it is the sensor's true orientation within the filter's error (evaluation)
            q_true = rotation.multiply(truth.q_world_from_segment[segment][-1], mounting[sensor].q_segment_from_sensor)
            shown = rotation.from_matrix(R_SCENE_FROM_WORLD.T @ matrix[:3, :3] / side)
            assert np.degrees(rotation.angle_between(shown, q_true)) < 10.0, sensor
        seen.append(_glyph(geometry, "S10")[1][:3, :3].copy())
    assert not np.allclose(seen[0], seen[1]) and not np.allclose(seen[1], seen[2])


def test_once_a_body_calibration_is_applied_the_skeleton_is_drawn():
    now = [10.0]
    session = _session("walk", now)
    session.start()
    now[0] += 0.3
    session.step()
    assert session.frame()[1].outline
    session.apply_body_calibration(known_mounting_calibration(session))
    for _ in range(10):
        now[0] += 0.1
        session.step()
    _, geometry = session.frame()
    assert not geometry.outline and geometry.sensor_glyphs is None
    assert session.joint_series("knee_r", 5.0)[0].size > 0
    assert session.truth_frame() is not None
