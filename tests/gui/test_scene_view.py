"""The skeleton's 3D view: the camera keeps a walking subject framed in every preset, a T pose
fits the view of the main window at its default size, the axis names and the hint are drawn in
the picture; it draws what its model's events bring (coalesced to the screen's rate), nothing
without them, lets its model go, and renders nothing after close."""

from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np
import pytest
from PyQt5 import QtCore, QtGui

from mimucap.core import skeleton
from mimucap.gui.scene.view import FRAME_INTERVAL_SLACK, SceneView
from mimucap.session.views.camera import CAMERA_PRESETS
from mimucap.session.events import EmitterGroup
from mimucap.session.views.skeleton_figure import FigureBuilder

from tests.gui.scene_projection import axis_label_positions, world_to_display

HEIGHT_M = 1.75


def _matrix_to_q(matrix: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternion of a rotation matrix (columns: the segment's axes in the world)."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(matrix).as_quat()
    return np.array([w, x, y, z])


def standing_pose(model, arms_out: bool) -> dict[str, np.ndarray]:
    """``q_world_from_segment`` of a subject standing upright facing north (segment x anterior
    = N, y up = Up, z right = E; world ENU), with the arms hanging or, with ``arms_out``,
    straight out to the sides (a T pose: an arm's y axis, towards its proximal end, points
    to the body's midline)."""
    upright = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # columns x=N, y=Up, z=E
    right_arm = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # x=N, y=W, z=Up
    left_arm = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # x=N, y=E, z=Down
    pose = {}
    for name in model.segment_names:
        matrix = upright
        if arms_out and name.endswith("_r") and name.split("_")[0] in ("upper", "forearm", "hand"):
            matrix = right_arm
        elif arms_out and name.endswith("_l") and name.split("_")[0] in ("upper", "forearm", "hand"):
            matrix = left_arm
        pose[name] = _matrix_to_q(matrix)
    return pose


def _figure(arms_out: bool = False):
    model = skeleton.load_model("fifteen_segment")
    builder = FigureBuilder(model, HEIGHT_M)
    return model, builder


def _walked(model, builder, pose, east_m: float, north_m: float):
    """The figure's geometry with the root moved ``east_m``, ``north_m`` over the floor (world
    mode: the scene shows the world, the camera has to follow)."""
    root = np.array([east_m, north_m, model.root_height_ratio * HEIGHT_M])
    return builder.build(skeleton.forward_kinematics(model, pose, HEIGHT_M, root), mode="world")


def _show(qtbot, width: int, height: int) -> SceneView:
    view = SceneView()
    qtbot.addWidget(view)
    view.resize(width, height)
    view.show()
    qtbot.waitExposed(view)
    qtbot.waitUntil(lambda: tuple(view.render_window.GetSize()) == (width, height), timeout=2000)
    return view


def _in_picture(view: SceneView, points: np.ndarray, margin_px: float = 0.0) -> np.ndarray:
    """Which of ``points`` (scene, m) the camera shows at least ``margin_px`` inside the picture."""
    width, height = view.render_window.GetSize()
    display = world_to_display(view.renderer, points)
    return ((display[:, 0] >= margin_px) & (display[:, 0] <= width - margin_px)
            & (display[:, 1] >= margin_px) & (display[:, 1] <= height - margin_px)
            & (display[:, 2] > 0.0) & (display[:, 2] < 1.0))


def _figure_points(view: SceneView) -> np.ndarray:
    """Every point of the figure as shown: capsule vertices and the extreme points of the spheres."""
    centres, radii = view.skeleton.spheres()
    rims = np.concatenate([centres + radius * axis for axis in np.eye(3) for radius in (radii[:, None], -radii[:, None])])
    capsules = np.concatenate([view.skeleton.vertices_of_segment(name) for name in view.skeleton.segment_names])
    return np.concatenate([capsules, rims])


@pytest.mark.parametrize("preset", CAMERA_PRESETS)
def test_the_camera_follows_a_subject_that_walks_10_m(qtbot, preset):
    model, builder = _figure()
    pose = standing_pose(model, arms_out=False)
    view = _show(qtbot, 480, 520)
    view.set_figure(builder)
    view.set_camera_preset(preset)
    view.start()
    view.show_frame(0, _walked(model, builder, pose, 0.0, 0.0))
    view.render_pending()
    width, height = view.render_window.GetSize()
    centre = np.array([width / 2.0, height / 2.0])
    frames = view.frames_rendered
    for index in range(1, 41):  # 10 m north-east, away from the front camera, 0.25 m a frame
        east_m, north_m = 0.25 * index * np.array([0.6, 0.8])
        view.show_frame(index, _walked(model, builder, pose, east_m, north_m))
        view.render_pending()
        pelvis = world_to_display(view.renderer, view.last_geometry.root_scene_m[None, :])[0]
        # The pelvis stays near the middle of the picture, and the whole figure in it.
        assert np.all(np.abs(pelvis[:2] - centre) < 0.25 * np.array([width, height])), (index, pelvis)
        assert _in_picture(view, _figure_points(view)).all(), index
    assert view.frames_rendered == frames + 40  # one render per new frame
    assert np.linalg.norm(view.last_geometry.root_world_m[:2]) == pytest.approx(10.0, abs=0.01)


def test_the_camera_keeps_the_users_turn_and_zoom_while_following(qtbot):
    model, builder = _figure()
    pose = standing_pose(model, arms_out=False)
    view = _show(qtbot, 480, 520)
    view.set_figure(builder)
    view.start()
    view.show_frame(0.0, _walked(model, builder, pose, 0.0, 0.0))
    view.render_pending()
    camera = view.renderer.GetActiveCamera()
    camera.Azimuth(40.0)  # as a mouse drag would
    camera.Zoom(1.3)
    offset = np.array(camera.GetPosition()) - camera.GetFocalPoint()
    view.show_frame(3.0, _walked(model, builder, pose, 3.0, 0.0))
    view.render_pending()
    np.testing.assert_allclose(np.array(camera.GetPosition()) - camera.GetFocalPoint(), offset, atol=1e-9)
    np.testing.assert_allclose(camera.GetFocalPoint()[0] - view.last_geometry.root_scene_m[0], 0.0, atol=1e-9)


def test_a_t_pose_fits_the_3d_view_of_the_main_window_at_its_default_size(qtbot):
    from mimucap.gui.main_window import MainWindow

    window = MainWindow("simulated:demo")  # not started: only its layout matters here
    qtbot.addWidget(window)
    window.show()
    qtbot.waitExposed(window)
    width, height = window.scene_view.width(), window.scene_view.height()
    window.close()
    model, builder = _figure()
    t_pose = standing_pose(model, arms_out=True)
    view = _show(qtbot, width, height)
    view.set_figure(builder)
    geometry = _walked(model, builder, t_pose, 0.0, 0.0)
    centres = geometry.joint_matrices[:, :3, 3]
    assert np.ptp(centres[:, 0]) > 0.8 * HEIGHT_M  # arms out: about as wide as tall
    view.show_frame("t", geometry)
    view.start()
    for preset in CAMERA_PRESETS:
        view.set_camera_preset(preset)
        view.render_pending()
        assert _in_picture(view, _figure_points(view), margin_px=5.0).all(), preset


def _rgb(image: QtGui.QImage) -> np.ndarray:
    image = image.convertToFormat(QtGui.QImage.Format_RGB888)
    ptr = image.constBits()
    ptr.setsize(image.sizeInBytes())
    rows = np.frombuffer(ptr, np.uint8).reshape(image.height(), image.bytesPerLine())
    return rows[:, : 3 * image.width()].reshape(image.height(), image.width(), 3).copy()


def _near_white(pixels: np.ndarray) -> np.ndarray:
    return (pixels > 230).all(axis=2)


def test_axis_names_are_drawn_at_their_anchors_and_hide_with_the_axes(qtbot):
    model, builder = _figure()
    view = _show(qtbot, 400, 400)
    view.set_figure(builder)
    view.set_stage_visible(floor=False, axes=True)
    view.start()
    view.render()
    labels = axis_label_positions(view)
    assert set(labels) == {"E", "N", "Up"}
    assert labels["Up"][1] < labels["E"][1] and labels["E"][0] > labels["Up"][0]  # Up above, E right
    pixels = _rgb(view.grab_image())
    for name, (x, y) in labels.items():
        box = pixels[int(y) - 8:int(y) + 9, int(x) - 12:int(x) + 13]
        assert _near_white(box).sum() > 8, name  # the white letters, at their anchor
    view.set_stage_visible(floor=False, axes=False)
    assert axis_label_positions(view) == {}
    pixels = _rgb(view.grab_image())
    assert not _near_white(pixels).any()  # no figure yet, no floor, no axes: nothing white


def test_the_hint_is_boxed_in_the_middle_of_the_picture_until_cleared(qtbot):
    view = _show(qtbot, 400, 300)
    view.set_stage_visible(floor=False, axes=False)
    view.start()
    view.render()
    plain = _rgb(view.grab_image())
    frames = view.frames_rendered
    view.set_hint("Waiting for data from the source: nothing has arrived for a while, so no figure is shown.")
    # drawn by itself once the event loop runs: nothing else may come to ask for a picture
    qtbot.waitUntil(lambda: view.frames_rendered == frames + 1, timeout=1000)
    pixels = _rgb(view.grab_image())
    rows, columns = np.nonzero(np.any(pixels != plain, axis=2))
    assert len(rows) > 500
    assert abs(rows.mean() - 150.0) < 15.0 and abs(columns.mean() - 200.0) < 15.0
    assert columns.min() > 5 and columns.max() < 395  # wrapped into the picture
    assert _near_white(pixels).sum() > 50  # the text
    view.set_hint("")
    np.testing.assert_array_equal(_rgb(view.grab_image()), plain)


class FakeModel:
    """A model as the view sees one: ``frame``, ``truth_frame`` and ``status`` events, and the
    newest frame on request (``None`` until one is emitted)."""

    def __init__(self) -> None:
        self.events = EmitterGroup("frame", "truth_frame", "status")
        self.newest = None
        self.frames_asked = 0

    def frame(self):
        self.frames_asked += 1
        return self.newest

    def truth_frame(self):
        return None

    def emit(self, frame_id, geometry) -> None:
        self.newest = (frame_id, geometry)
        self.events.frame.emit(frame_id, geometry)


def _followed_model(qtbot, size=(300, 300)):
    model, builder = _figure()
    geometry = _walked(model, builder, standing_pose(model, arms_out=False), 0.0, 0.0)
    view = _show(qtbot, *size)
    view.set_figure(builder)
    fake = FakeModel()
    view.set_model(fake)
    view.start()
    qtbot.waitUntil(lambda: view.frames_rendered >= 1, timeout=2000)  # the floor, before any frame
    return view, fake, geometry


def test_the_view_draws_the_frames_its_model_emits_and_nothing_without_them(qtbot):
    view, fake, geometry = _followed_model(qtbot)
    # A long frame interval, so that the burst below falls inside one interval however busy
    # the machine is (software rendering of the first frame can take longer than 1/60 s).
    view.target_fps = 4.0
    assert fake.frames_asked == 1  # read once on subscribing, never again
    frames = view.frames_rendered
    qtbot.wait(150)
    assert view.frames_rendered == frames  # no event, no picture
    fake.emit(0, geometry)  # drawn at once: a frame is the last event of a change
    assert view.frames_rendered == frames + 1 and view.shown_frame_id == 0
    for frame_id in range(1, 5):  # within the frame interval: one picture, of the newest frame
        fake.emit(frame_id, geometry)
    assert view.frames_rendered == frames + 1
    qtbot.waitUntil(lambda: view.shown_frame_id == 4, timeout=2000)
    assert view.frames_rendered == frames + 2
    fake.events.status.emit([SimpleNamespace(segment="pelvis", state="stale")])
    qtbot.waitUntil(lambda: view.frames_rendered == frames + 3, timeout=1000)  # the tint changed
    assert fake.frames_asked == 1


def test_frames_faster_than_the_screen_are_coalesced(qtbot):
    view, fake, geometry = _followed_model(qtbot)
    view.target_fps = 60.0
    frames = view.frames_rendered
    start = time.perf_counter()
    frame_id = 0
    while time.perf_counter() - start < 0.5:  # a frame every 2 ms: 250 in half a second
        frame_id += 1
        fake.emit(frame_id, geometry)
        qtbot.wait(2)
    qtbot.waitUntil(lambda: view.shown_frame_id == frame_id, timeout=1000)
    elapsed = time.perf_counter() - start
    drawn = view.frames_rendered - frames
    assert 5 <= drawn <= elapsed * 60.0 / (1.0 - FRAME_INTERVAL_SLACK) + 2, (drawn, frame_id)


def test_the_view_lets_its_model_go_when_given_another_or_closed(qtbot):
    view, fake, geometry = _followed_model(qtbot)
    view.set_ghost_visible(True)
    assert fake.events.truth_frame.callbacks
    other = FakeModel()
    view.set_model(other)
    assert not any(getattr(fake.events, name).callbacks for name in fake.events.names)
    assert other.events.frame.callbacks and other.events.truth_frame.callbacks  # the ghost follows
    frames = view.frames_rendered
    fake.emit(99, geometry)  # the old model's frames are not drawn
    qtbot.wait(100)
    assert view.frames_rendered == frames and view.shown_frame_id != 99
    view.close()
    assert not any(getattr(other.events, name).callbacks for name in other.events.names)


def test_after_close_nothing_renders(qtbot):
    view, fake, geometry = _followed_model(qtbot)
    for frame_id in range(3):
        fake.emit(frame_id, geometry)
    qtbot.waitUntil(lambda: view.shown_frame_id == 2, timeout=2000)
    drawn = []
    view.vtk_widget.rendered.connect(lambda: drawn.append(1))
    view.close()
    assert not view.alive and view.vtk_widget.finalized
    frames = view.frames_rendered
    view.start()
    view.show_frame(7, geometry)
    view.render_pending()
    view.render()
    view.set_hint("closed")
    view.vtk_widget.repaint()
    QtCore.QCoreApplication.processEvents()
    assert not view.running and not view._render_timer.isActive()  # nothing left to render it
    assert view.frames_rendered == frames and not drawn
    with pytest.raises(RuntimeError, match="closed"):
        view.grab_image()
