"""The main window starts, renders the live skeleton, and every menu item does something."""

from __future__ import annotations

import numpy as np
import pytest
from PyQt5 import QtGui, QtWidgets

from mimucap.core.pipeline.recording import POSE_SENSOR_AXES
from mimucap.gui.live_status_bar import VIEW_HINTS
from mimucap.gui.main_window import MainWindow

from tests.gui.scene_projection import axis_label_positions
from tests.known_mounting import known_mounting_calibration


def _menu_actions(win):
    actions = []
    for menu_action in win.menuBar().actions():
        stack = [menu_action.menu()]
        while stack:
            menu = stack.pop()
            for action in menu.actions():
                if action.menu() is not None:
                    stack.append(action.menu())
                elif not action.isSeparator():
                    actions.append(action)
    return actions


def test_window_starts_and_renders_the_skeleton(window, qtbot):
    assert window.windowTitle() == "MimuCap"
    assert [a.text() for a in window.menuBar().actions()][:3] == ["&File", "&Session", "&View"]
    assert window.menuBar().actions()[-1].text() == "&Help"
    qtbot.waitUntil(lambda: window.scene_view.frames_rendered >= 3, timeout=15000)
    geometry = window.scene_view.last_geometry
    assert geometry is not None
    assert window.scene_view.skeleton.visible
    # The status bar follows at the panels' pace (4 Hz), after the first frames.
    # Like any source, the simulated suit shows what its sensors give until it is calibrated,
    # and the view says so.
    qtbot.waitUntil(lambda: "sensor axes" in window.live_status.pose_status.text(), timeout=2000)
    # No accuracy figure against the truth before a calibration to judge (it said "vs. truth:
    # flexion RMS 109.9°"): the on-screen check appears with the body calibration.
    qtbot.wait(1500)
    assert "vs. truth" not in window.live_status.pose_status.text()
    assert "simulated:demo" in window.live_status.source_status.text()
    assert window.scene_view.hint == VIEW_HINTS[POSE_SENSOR_AXES]
    # Every segment of the ten-sensor suit has a sensor: tinted "magnetometer not calibrated"
    # once each has sent data (until its first sample a sensor is "stale").
    qtbot.waitUntil(lambda: {window.scene_view.skeleton.tint_of(s) for s in geometry.segment_names}
                    == {"mag_uncalibrated"}, timeout=5000)
    # That tangle of sensor axes is not drawn: the calm grey outline, with each sensor's glyph
    # (tinted by its state) on its segment, and no joint angles plotted yet.
    view = window.scene_view
    assert view.last_geometry.outline and view.skeleton.outline
    assert view.sensor_glyphs.visible and set(view.sensor_glyphs.segments) == set(geometry.segment_names)
    qtbot.waitUntil(lambda: view.sensor_glyphs.tint_of("S08") == "mag_uncalibrated", timeout=5000)
    assert window.plots.joint_angles_refused and not window.plots.selected_joints


def test_menu_lists_only_working_items(window):
    texts = {a.text() for a in _menu_actions(window)}
    # Each of these is exercised by a test of tests/gui.
    expected = {
        "Choose &Source…", "&Open Recording…", "&Close Recording", "&Export Recording…", "Library &Folder…",
        "S&tream to Lab Streaming Layer…", "Save Screens&hot…", "&Quit", "&Assign Sensors…", "Start &Recording", "Add &Marker",
        "&Pair Devices…",
        "Front", "Side", "Top", "World Mode", "Body Mode", "&Toggle Body/World", "Show &Floor",
        "Show World &Axes", "Show Simulator &Truth", "&Pause Plots\tSpace", "Play/Pause &Review", "&User Guide",
        "&About MimuCap", "Capture", "Review", "Analysis", "Library",
    }
    assert expected <= texts
    assert texts - expected <= {"&Magnetometers…", "&Body…", "&Range of Motion…", "&Clinical Test…"}  # the wizards


def test_screenshot_and_quit_from_the_file_menu(window, qtbot, tmp_path, monkeypatch):
    qtbot.waitUntil(lambda: window.scene_view.frames_rendered >= 2, timeout=15000)
    target = tmp_path / "menu.png"
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName", lambda *a, **k: (str(target), "PNG images (*.png)"))
    window.action_save_screenshot.trigger()
    assert target.stat().st_size > 10_000
    window.action_quit.trigger()
    assert not window.isVisible()
    assert not window.scene_view.alive


def test_camera_and_display_actions_change_the_view(window, qtbot):
    qtbot.waitUntil(lambda: window.scene_view.last_geometry is not None, timeout=15000)
    window.live.apply_body_calibration(known_mounting_calibration(window.live))  # body mode turns a skeleton
    window.camera_actions["top"].trigger()
    assert window.scene_view.camera_preset == "top"
    qtbot.waitUntil(lambda: np.allclose(window.scene_view.renderer.GetActiveCamera().GetViewUp(), (0, 0, -1), atol=1e-6))
    window.display_actions["body"].trigger()
    assert window.live.display_mode == "body"
    qtbot.waitUntil(lambda: window.scene_view.last_geometry is not None and
                    window.scene_view.last_geometry.heading_alpha_rad != 0.0, timeout=5000)
    window.action_toggle_display.trigger()
    assert window.live.display_mode == "world" and window.display_actions["world"].isChecked()
    window.action_floor.setChecked(False)
    assert not window.scene_view.stage.grid.GetVisibility()
    window.action_axes.setChecked(False)
    assert not window.scene_view.stage.axes.GetVisibility()


def test_about_box_names_the_application(window, qtbot, monkeypatch):
    shown = {}
    monkeypatch.setattr(QtWidgets.QMessageBox, "about", lambda parent, title, text: shown.update(title=title, text=text))
    window.action_about.trigger()
    assert shown["title"] == "About MimuCap" and "MimuCap" in shown["text"]


def test_save_screenshot_paints_the_3d_view(window, qtbot, tmp_path):
    qtbot.waitUntil(lambda: window.scene_view.frames_rendered >= 2, timeout=15000)
    path = window.save_screenshot(tmp_path / "shot.png")
    image = QtGui.QImage(str(path))
    assert image.width() == window.width() and image.height() == window.height()


def test_the_camera_moves_with_the_subject_and_keeps_the_users_turn(qtbot):
    win = MainWindow("simulated:walk")
    qtbot.addWidget(win)
    win.show()
    win.start()
    try:
        view = win.scene_view
        qtbot.waitUntil(lambda: view.last_geometry is not None, timeout=15000)
        win.live.apply_body_calibration(known_mounting_calibration(win.live))  # the outline stands still
        qtbot.waitUntil(lambda: not view.last_geometry.outline, timeout=15000)
        win.set_camera_preset("side")
        qtbot.waitUntil(lambda: not view._camera_pending, timeout=5000)
        camera = view.renderer.GetActiveCamera()
        camera.Azimuth(40.0)  # as a mouse drag would
        camera.Zoom(1.3)
        start_root = view.last_geometry.root_scene_m.copy()
        start_offset = np.array(camera.GetFocalPoint()) - start_root
        direction = np.array(camera.GetPosition()) - np.array(camera.GetFocalPoint())
        qtbot.waitUntil(lambda: np.hypot(*(view.last_geometry.root_scene_m - start_root)[[0, 2]]) > 0.25,
                        timeout=15000)
        root = view.last_geometry.root_scene_m
        offset = np.array(camera.GetFocalPoint()) - root
        np.testing.assert_allclose(offset[[0, 2]], start_offset[[0, 2]], atol=1e-9)  # followed along the floor
        np.testing.assert_allclose(np.array(camera.GetPosition()) - np.array(camera.GetFocalPoint()), direction,
                                   atol=1e-9)  # the user's turn and zoom are kept
    finally:
        win.close()


def test_the_fusion_kernels_are_prepared_off_the_gui_thread_before_the_first_start(qtbot, monkeypatch):
    import threading

    from mimucap.gui import main_window as module

    threads = []
    release = threading.Event()

    def slow_compile():
        threads.append(threading.current_thread())
        assert release.wait(20)

    class SlowPreparation:
        def run(self):
            slow_compile()

        def cancel(self):
            release.set()

    monkeypatch.setattr(module, "_kernels_ready", False)
    monkeypatch.setattr(module, "KernelPreparation", SlowPreparation)
    win = MainWindow("simulated:demo")
    qtbot.addWidget(win)
    win.show()
    win.start()
    try:
        qtbot.waitUntil(lambda: bool(threads), timeout=5000)
        assert threads[0] is not threading.main_thread()
        assert win.starting and not win.live.started and "Preparing the orientation filters" in \
            win.statusBar().currentMessage()
        qtbot.wait(200)  # the window stays responsive and nothing runs the pipeline meanwhile
        assert win.live.samples_received == 0
        # Meanwhile the 3D view shows the floor from the front, where the subject will stand.
        camera = win.scene_view.renderer.GetActiveCamera()
        np.testing.assert_allclose(camera.GetViewUp(), (0.0, 1.0, 0.0), atol=1e-9)
        assert camera.GetPosition()[2] > camera.GetFocalPoint()[2] + 3.0
        floor = win.scene_view.stage.floor_matrix
        assert [floor.GetElement(1, 2), floor.GetElement(2, 1)] == [1.0, -1.0]  # world up = scene y
        release.set()
        qtbot.waitUntil(lambda: win.live.started and win.live.samples_received > 0, timeout=10000)
        assert not win.starting
    finally:
        release.set()
        win.close()


def test_closing_while_the_kernels_are_prepared_stops_the_preparation_and_waits_for_it(qtbot, monkeypatch):
    import threading

    from PyQt5 import QtCore

    from mimucap.gui import main_window as module

    cancelled = threading.Event()
    finished = []

    class Preparation:  # as KernelPreparation: run() blocks until the child ends or cancel()
        def run(self):
            cancelled.wait(20)
            finished.append(True)

        def cancel(self):
            cancelled.set()

    monkeypatch.setattr(module, "_kernels_ready", False)
    monkeypatch.setattr(module, "KernelPreparation", Preparation)
    win = MainWindow("simulated:demo")
    qtbot.addWidget(win)
    win.show()
    win.start()
    qtbot.waitUntil(lambda: win._warm_up is not None and win._warm_up.isRunning(), timeout=5000)
    win.close()  # cancels, and returns once the thread has finished: none destroyed while running
    assert cancelled.is_set() and finished == [True]
    assert not win._warm_up.isRunning() and not win.isVisible()
    assert not win.live or not win.live.started
    QtCore.QCoreApplication.processEvents()


def test_world_axes_are_named_at_their_tips_and_the_names_hide_with_them(window, qtbot):
    view = window.scene_view
    window.camera_actions["front"].trigger()
    qtbot.waitUntil(lambda: set(axis_label_positions(view)) == {"E", "N", "Up"}, timeout=5000)
    labels = axis_label_positions(view)
    assert labels["Up"][1] < labels["E"][1]  # Up above E on the screen
    assert labels["E"][0] > labels["Up"][0]  # E (east) to the right in the front view
    assert all(label.GetVisibility() for label in view.stage.axis_labels)
    window.action_axes.setChecked(False)
    qtbot.waitUntil(lambda: axis_label_positions(view) == {}, timeout=5000)
    assert not any(label.GetVisibility() for label in view.stage.axis_labels)


@pytest.mark.data("opensense")
def test_before_any_sensor_is_assigned_the_view_says_so_and_the_plots_scroll(qtbot, shared_data):
    """Xsens exports replayed (accelerations and on-board orientations, no segment known): the
    3D view explains that no sensor is assigned yet, the accelerometer plot shows the newest
    samples, and the gyroscope plot (not in the files) says it has no data."""
    from mimucap.gui.live_status_bar import VIEW_HINTS
    from mimucap.session.live.processing import POSE_UNASSIGNED

    folder = shared_data / "body" / "opensense_example" / "IMUData"
    win = MainWindow(f"replay:{folder}")
    qtbot.addWidget(win)
    win.show()
    win.start()
    try:
        qtbot.waitUntil(lambda: win.live is not None and win.live.samples_received > 1200, timeout=30000)
        qtbot.waitUntil(lambda: win.scene_view.hint == VIEW_HINTS[POSE_UNASSIGNED], timeout=2000)
        assert win.live.pose_source == POSE_UNASSIGNED
        win.plots.refresh()
        x, y = win.plots.curve_data("acc", 2)
        newest = win.live.series(win.plots.sensor_id, 1.0)[0][-1]
        assert len(x) > 100 and x[-1] == pytest.approx(newest) and np.all(np.isfinite(y))
        assert "no data" in win.plots.title_text("gyr")
    finally:
        win.close()


def test_the_simulators_truth_is_a_ghost_beside_the_estimate(window, qtbot):
    """On the simulated suit, View → Show Simulator Truth draws the true pose as a pale
    translucent second figure and the true angles as dashed curves (an accuracy check); the
    estimate stays the figure. Unticked, both are gone."""
    view = window.scene_view
    qtbot.waitUntil(window.action_truth.isEnabled, timeout=15000)  # the panels' pace
    assert not window.action_truth.isChecked() and not (view.ghost is not None and view.ghost.visible)
    window.action_truth.setChecked(True)
    # before a body calibration there is no estimated pose to compare: no ghost beside the outline
    qtbot.wait(500)
    assert view.last_geometry.outline and not view.ghost.visible
    window.live.apply_body_calibration(known_mounting_calibration(window.live))
    qtbot.waitUntil(lambda: view.ghost is not None and view.ghost.visible, timeout=15000)
    assert view.ghost.actor.GetProperty().GetOpacity() < 0.5
    estimate = view.skeleton.vertices_of_segment("thigh_r")
    ghost = view.ghost.vertices_of_segment("thigh_r")
    assert not np.allclose(estimate, ghost)  # two figures: the estimate is not the truth
    # The plotted joint's true angles are dashed curves beside the estimate.
    plots = window.plots
    key = plots._joint_key(plots.selected_joints[0])
    def drawn() -> int:
        x, _y = plots.truth_curves[key][0].getData()
        return 0 if x is None else len(x)

    qtbot.waitUntil(lambda: drawn() > 10, timeout=5000)
    window.action_truth.setChecked(False)
    assert not view.ghost.visible
    qtbot.waitUntil(lambda: drawn() == 0, timeout=5000)
