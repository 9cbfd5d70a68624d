"""The 3D view's pictures come from a render process holding a mirror of the scene: the same
pictures as drawn in the GUI process, a fallback to drawing in the GUI process when that
process dies, and nothing left behind on close."""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest
from PyQt5 import QtCore

from mimucap.core import skeleton
from mimucap.gui.scene.environment import Stage, scene_renderer
from mimucap.gui.scene.scene_state import FigureLayout, apply_scene, capture_scene
from mimucap.gui.scene.skeleton_actor import SkeletonActor
from mimucap.gui.scene.view import SceneView
from mimucap.session.figure import FigureBuilder
from vtkmodules.vtkRenderingCore import vtkRenderWindow


def _figure(seed: int = 5):
    model = skeleton.load_model("fifteen_segment")
    builder = FigureBuilder(model, 1.75)
    rng = np.random.default_rng(seed)
    q = {name: (lambda v: v / np.linalg.norm(v))(rng.normal(size=4)) for name in model.segment_names}
    return builder, builder.build(skeleton.forward_kinematics(model, q, 1.75), mode="world")


def _scene(layout=None):
    window = vtkRenderWindow()
    window.OffScreenRenderingOn()
    renderer = scene_renderer()
    window.AddRenderer(renderer)
    stage = Stage(renderer)
    figure = SkeletonActor(renderer, layout) if layout is not None else None
    return window, renderer, stage, figure


def _rgb(image):
    image = image.convertToFormat(image.Format_RGB888)
    bits = image.constBits()
    bits.setsize(image.sizeInBytes())
    rows = np.frombuffer(bits, np.uint8).reshape(image.height(), image.bytesPerLine())
    return rows[:, : 3 * image.width()].reshape(image.height(), image.width(), 3).copy()


def test_a_mirror_applies_the_captured_scene_exactly():
    builder, geometry = _figure()
    window, renderer, stage, figure = _scene(builder)
    window.SetSize(321, 203)
    figure.update(geometry)
    figure.set_tints({"thigh_l": "stale", "upper_arm_r": "mag_uncalibrated"})
    figure.shade((0.2, -1.0, 0.4))
    stage.set_world_matrix(geometry.world_matrix, geometry.root_world_m)
    stage.set_visible(floor=False, axes=True)
    camera = renderer.GetActiveCamera()
    camera.SetPosition(1.0, -4.0, 2.0)
    camera.SetFocalPoint(0.1, 0.2, 0.9)
    camera.SetViewUp(0.0, 0.1, 1.0)
    camera.SetViewAngle(27.0)
    camera.SetClippingRange(0.2, 40.0)
    state = capture_scene(renderer, stage, figure)

    _, mirror_renderer, mirror_stage, mirror_figure = _scene(FigureLayout.of(builder))
    assert not mirror_figure.visible
    apply_scene(state, mirror_renderer, mirror_stage, mirror_figure)
    again = capture_scene(mirror_renderer, mirror_stage, mirror_figure)

    assert again.size_px == (321, 203)
    np.testing.assert_allclose(again.camera, state.camera, atol=1e-9)
    np.testing.assert_array_equal(again.floor_matrix, state.floor_matrix)
    np.testing.assert_array_equal(again.axes_matrix, state.axes_matrix)
    assert (again.floor_visible, again.axes_visible, again.figure_visible) == (False, True, True)
    for name, values in state.figure.items():
        np.testing.assert_array_equal(again.figure[name], values, err_msg=name)
    np.testing.assert_array_equal(mirror_figure.vertices_of_segment("shank_r"), figure.vertices_of_segment("shank_r"))


def test_a_state_with_a_figure_does_not_fit_a_scene_without_one_nor_another_layout():
    builder, geometry = _figure()
    _, renderer, stage, figure = _scene(builder)
    figure.update(geometry)
    state = capture_scene(renderer, stage, figure)
    _, bare_renderer, bare_stage, _ = _scene()
    with pytest.raises(ValueError, match="whether a figure is shown"):
        apply_scene(state, bare_renderer, bare_stage, None)
    small_builder = FigureBuilder(skeleton.load_model("ten_segment"), 1.75)
    _, other_renderer, other_stage, other_figure = _scene(FigureLayout.of(small_builder))
    with pytest.raises(ValueError, match="figure array points has shape"):
        apply_scene(state, other_renderer, other_stage, other_figure)


def _view(qtbot, render_process: bool) -> SceneView:
    builder, geometry = _figure()
    view = SceneView(render_process=render_process)
    qtbot.addWidget(view)
    view.resize(360, 300)
    view.show()
    qtbot.waitExposed(view)
    view.set_figure(builder)
    view.set_camera_preset("side")
    view.set_frame_provider(lambda: ("pose", geometry))
    view.start()
    qtbot.waitUntil(lambda: view.frames_rendered >= 1 and view.shown_frame_id == "pose", timeout=30000)
    return view


def test_the_render_process_draws_the_picture_the_gui_process_would(qtbot):
    remote = _view(qtbot, render_process=True)
    local = _view(qtbot, render_process=False)
    assert remote.render_client is not None and remote.render_failure is None
    assert local.render_client is None
    remote_pixels, local_pixels = _rgb(remote.grab_image()), _rgb(local.grab_image())
    assert remote_pixels.shape == local_pixels.shape == (300, 360, 3)
    assert len(np.unique(remote_pixels.reshape(-1, 3), axis=0)) > 50  # a shaded figure, not a blank picture
    np.testing.assert_array_equal(remote_pixels, local_pixels)
    assert remote.vtk_widget.labels == local.vtk_widget.labels
    assert {label.text for label in remote.vtk_widget.labels} == {"E", "N", "Up"}
    # the GUI process never drew: its render window was never rendered
    assert remote.render_window.GetNeverRendered()


def test_turning_the_camera_with_the_mouse_brings_a_new_picture_from_the_render_process(qtbot, left_drag):
    view = _view(qtbot, render_process=True)
    before = _rgb(view.grab_image())
    shown = view.frames_rendered
    camera = view.renderer.GetActiveCamera()
    position = camera.GetPosition()
    widget = view.vtk_widget
    centre = widget.rect().center()
    left_drag(widget, centre, QtCore.QPoint(12, 0))
    assert not np.allclose(camera.GetPosition(), position)
    qtbot.waitUntil(lambda: view.frames_rendered > shown, timeout=10000)
    assert not np.array_equal(_rgb(view.grab_image()), before)
    assert view.render_window.GetNeverRendered()


def test_a_new_figure_while_frames_are_under_way_keeps_the_render_process(qtbot):
    view = _view(qtbot, render_process=True)
    view.render()
    view.render()  # one frame in flight, the newest state waiting (taken with the old figure)
    model = skeleton.load_model("ten_segment")
    small = FigureBuilder(model, 1.75)
    q = {name: np.array([1.0, 0.0, 0.0, 0.0]) for name in model.segment_names}
    geometry = small.build(skeleton.forward_kinematics(model, q, 1.75), mode="world")
    view.set_figure(small)
    view.set_frame_provider(lambda: ("ten segments", geometry))
    qtbot.waitUntil(lambda: view.shown_frame_id == "ten segments", timeout=10000)
    assert view.render_failure is None and view.render_client is not None


def test_when_the_render_process_dies_the_view_draws_itself_and_goes_on(qtbot):
    view = _view(qtbot, render_process=True)
    os.kill(view.render_client.pid, signal.SIGKILL)
    qtbot.waitUntil(lambda: view.render_failure is not None, timeout=10000)
    assert "render process" in view.render_failure
    assert view.render_client is None and view.vtk_widget.remote is None
    builder, geometry = _figure(seed=9)
    view.set_frame_provider(lambda: ("next pose", geometry))
    qtbot.waitUntil(lambda: view.shown_frame_id == "next pose", timeout=5000)
    assert len(np.unique(_rgb(view.grab_image()).reshape(-1, 3), axis=0)) > 50


def test_closing_the_view_stops_the_render_process_and_removes_its_frame_files(qtbot):
    view = _view(qtbot, render_process=True)
    client = view.render_client
    pid, paths = client.pid, client.frame_paths
    assert len(paths) == 2 and all(os.path.exists(path) for path in paths)
    view.close()
    assert client.closed and view.render_client is None
    assert not any(os.path.exists(path) for path in paths)
    assert not os.path.exists(f"/proc/{pid}")  # ended and reaped
    view.render()  # nothing renders after close


def test_the_main_window_says_when_its_3d_view_is_drawn_by_the_window_itself(qtbot, window):
    view = window.scene_view
    qtbot.waitUntil(lambda: view.frames_rendered >= 2, timeout=30000)
    assert view.render_client is not None
    os.kill(view.render_client.pid, signal.SIGKILL)
    qtbot.waitUntil(lambda: "render process stopped" in window.statusBar().currentMessage(), timeout=10000)
    shown = view.frames_rendered
    qtbot.waitUntil(lambda: view.frames_rendered > shown + 5, timeout=5000)  # live, drawn here now
