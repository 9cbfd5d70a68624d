"""The whole flow driven as a user would, under Xvfb, on the simulated suit with its default
sensor errors (noise, gyro bias, hard and soft iron).

Start the app, calibrate the magnetometers and the body with the wizards (the simulated subject
does what they ask and walks on when they close), record twenty seconds of walking with two
markers, export, and check the exported joint angles against the simulator's truth: an
independent reference, since the export is computed from the sensors only (a copy of the
session without its truth exports the same numbers). The review's *as seen live* angles equal
what the live plots showed. Simulated time runs faster than the wall clock (every part of the
pipeline reads the same clock).
"""

from __future__ import annotations

import threading

import numpy as np
import pytest
from PyQt5 import QtCore, QtWidgets

from mimucap.core.pipeline.settings import RESULT_LIVE
from mimucap.io.angles_export import read_angles_csv, read_angles_mot
from mimucap.io.session import read_session, write_session
from mimucap.session.angle_accuracy import angle_errors
from mimucap.session.recorded.export import ExportRequest, recording_start_s, run_export
from mimucap.session.live.recording import RecordingToSave
from mimucap.session.recorded.review import load_review
from tests.gui.live_window import calibrate, closed, live_window

RECORD_S = 20.0
FLEXION = ("knee_l_flexion_deg", "knee_r_flexion_deg", "hip_l_flexion_deg", "hip_r_flexion_deg",
           "elbow_l_flexion_deg", "elbow_r_flexion_deg")


@pytest.fixture
def app_window(qtbot):
    window = live_window(qtbot, "simulated:demo")
    yield window
    closed(window)


@pytest.fixture
def walking_window(qtbot):
    window = live_window(qtbot, "simulated:walk")
    yield window
    closed(window)


def test_calibrated_walk_recorded_and_exported_from_the_sensors(walking_window, qtbot, tmp_path, monkeypatch):
    window = walking_window
    live = window.live
    calibrate(window, qtbot)

    window.session_panel.subject_id.setText("P042")
    monkeypatch.setattr(window, "recording_folder", lambda: tmp_path)
    qtbot.mouseClick(window.mode_bar.record_button, QtCore.Qt.LeftButton)
    assert live.recording
    start = window.clock()
    qtbot.waitUntil(lambda: window.clock() - start > 5.0, timeout=20000)
    qtbot.keyClicks(window.session_panel.marker_label, "straight")
    qtbot.mouseClick(window.mode_bar.marker_button, QtCore.Qt.LeftButton)
    qtbot.waitUntil(lambda: window.clock() - start > 15.0, timeout=20000)
    window.add_marker("end of straight")
    qtbot.waitUntil(lambda: live.recording_info().elapsed_s >= RECORD_S, timeout=20000)
    # What the live plots show now (session seconds), before the recording stops.
    offset = live.recording_started_s
    shown = {joint: live.joint_series(joint, 30.0) for joint in ("knee_r", "hip_l", "elbow_r")}
    with qtbot.waitSignal(window.recording_saved, timeout=30000):
        qtbot.mouseClick(window.mode_bar.record_button, QtCore.Qt.LeftButton)
    result = live.last_recording
    assert result.complete

    session = read_session(result.session_path)
    assert [m.label for m in session.markers] == ["straight", "end of straight"]
    assert set(session.calibrations["magnetometer"]) == set(session.sensors)
    assert session.calibrations["body"]["format"] == "mimucap-body-calibration"

    # Export through the window's export dialog (reprocessed, the default).
    window.action_export.trigger()
    review = window.review.view
    assert window.workspace == "review" and review.path == result.session_path
    qtbot.waitUntil(lambda: review.export_dialog is not None, timeout=30000)
    dialog = review.export_dialog
    dialog.base_path.setText(str(tmp_path / "walk"))
    qtbot.mouseClick(dialog.export_button, QtCore.Qt.LeftButton)
    qtbot.waitUntil(lambda: dialog.result is not None, timeout=30000)
    table = read_angles_csv(tmp_path / "walk_joint_angles.csv")
    # the range starts at the recording's start, never at a negative time (it read "-0.14 s": the
    # poses of the poll that was running when Record was pressed)
    assert "-" not in dialog.range_all.text() and dialog.t_from.minimum() >= 0.0 and table.t_s[0] >= 0.0
    header = (tmp_path / "walk_joint_angles.csv").read_text().split("\n", 20)
    assert any("Result: reprocessed" in line for line in header)
    mot = read_angles_mot(tmp_path / "walk_joint_angles.mot")
    assert np.allclose(mot.angles_deg["knee_r_flexion_deg"], table.angles_deg["knee_r_flexion_deg"], atol=1e-5)
    summary = (tmp_path / "walk_joint_angle_summary.csv").read_text().splitlines()
    assert "column,label,min_deg,max_deg,rom_deg,doubtful_pct" in summary
    assert "knee_r_flexion_deg,Right knee flexion (°)," in "\n".join(summary)
    # the recording's markers are in both angle files' headers
    for written in (table, mot):
        assert [m.label for m in written.markers] == ["straight", "end of straight"]
    dialog.accept()
    review.close()

    # Accuracy against the simulator's truth (independent: the export never reads it).
    truth = session.truth
    errors = angle_errors(table.t_s, table.angles_deg, truth.t_s, truth.joint_angles_deg, span_s=(1.0, RECORD_S))
    print("RMS error per joint angle (deg):", {c: round(e.rms_deg, 2) for c, e in errors.items()})
    for column in FLEXION:
        assert errors[column].rms_deg < 2.0, (column, errors[column])
    for column, error in errors.items():
        assert error.rms_deg < 4.0, (column, error)
    assert np.ptp(table.angles_deg["knee_r_flexion_deg"]) > 30.0  # walking bends the knee
    # calibrated in the window, walking in a clean field: the joint angles are trusted
    for joint in ("hip_l", "hip_r", "knee_l", "knee_r"):
        assert np.mean(table.ok[joint]) > 0.95, (joint, np.mean(table.ok[joint]))

    # The same export from a copy without the truth is identical: it comes from the sensors.
    session.truth = None
    blind = tmp_path / "without_truth.h5"
    write_session(blind, session)
    blind_data = load_review(blind)
    run_export(blind_data, ExportRequest(tmp_path / "blind", recording_start_s(blind_data), blind_data.end_s,
                                         angles_mot=False, summary_csv=False))
    blind_table = read_angles_csv(tmp_path / "blind_joint_angles.csv")
    assert blind_table.angles_deg.keys() == table.angles_deg.keys()
    for column, values in table.angles_deg.items():
        assert np.array_equal(blind_table.angles_deg[column], values), column

    # The review's "as seen live" result is what the live plots showed.
    as_live = load_review(result.session_path, result=RESULT_LIVE)
    compared = 0
    for joint, (t_live, angles_live) in shown.items():
        columns = [f"{joint}_{axis}_deg" for axis in ("flexion", "adduction", "rotation")]
        t_rec = t_live - offset
        inside = (t_rec >= as_live.t_s[0]) & (t_rec <= as_live.t_s[-1])
        index = np.searchsorted(as_live.t_s, t_rec[inside] - 1e-6)
        assert np.allclose(as_live.t_s[index], t_rec[inside], atol=1e-6)
        for k, column in enumerate(columns):
            diff = np.abs(as_live.angles_deg[column][index] - angles_live[inside, k])
            assert np.max(diff) < 0.1, (column, np.max(diff))
        compared += int(np.count_nonzero(inside))
    assert compared > 100

    # Reopen the session from the File menu (its camera as the main window's), scrub to the
    # second marker and play.
    t_first, t_second = (m.t_s for m in session.markers)
    # 5. Reopen the session from the File menu (its camera as the main window's) and scrub to
    #    the second marker.
    window.camera_actions["side"].trigger()
    monkeypatch.setattr(QtWidgets.QFileDialog, "getOpenFileName", lambda *a, **k: (str(result.session_path), ""))
    window.action_open.trigger()
    assert window.review.view is not review  # the recording shown before is let go
    review = window.review.view
    assert review.scene_view.camera_preset == "side" and window.camera_actions["side"].isChecked()
    qtbot.waitUntil(lambda: review.player is not None, timeout=20000)
    assert review.markers_list.count() == 2
    window.camera_actions["top"].trigger()  # View → Camera moves the 3D view of the workspace shown
    assert review.scene_view.camera_preset == "top"
    assert review.pose_status.text().startswith("Pose: body calibration; reprocessed")
    qtbot.waitUntil(lambda: review.scene_view.frames_rendered > 0, timeout=10000)
    item = review.markers_list.item(1)
    rect = review.markers_list.visualItemRect(item)
    qtbot.mouseClick(review.markers_list.viewport(), QtCore.Qt.LeftButton, pos=rect.center())
    assert review.player.cursor_s == pytest.approx(t_second)
    assert review.slider.value() == round(t_second * 100)
    assert f"{t_second:7.2f}" in review.time_label.text()
    qtbot.waitUntil(lambda: review.scene_view.last_geometry is not None
                    and review.scene_view._last_frame_id[0] == review.player.index(), timeout=5000)
    x, _y = review.plots.curve_data("angles", 0)
    assert len(x) and x[-1] <= t_second + 1e-9
    # Play at 2x moves the play head forward.
    review.speed_combo.setCurrentIndex(review.speed_combo.findData(2.0))
    review.seek_marker(0)
    qtbot.mouseClick(review.play_button, QtCore.Qt.LeftButton)
    qtbot.waitUntil(lambda: review.player.cursor_s > t_first + 0.5, timeout=5000)
    qtbot.mouseClick(review.play_button, QtCore.Qt.LeftButton)
    assert not review.player.playing


def test_the_session_file_is_written_off_the_gui_thread(app_window, qtbot, tmp_path, monkeypatch):
    window = app_window
    monkeypatch.setattr(window, "recording_folder", lambda: tmp_path)
    qtbot.waitUntil(lambda: window.live.samples_received > 0, timeout=10000)
    release = threading.Event()
    real_save = RecordingToSave.save
    save_threads = []

    def slow_save(pending, progress=None):
        save_threads.append(threading.current_thread())
        assert release.wait(20)
        return real_save(pending, progress)

    monkeypatch.setattr(RecordingToSave, "save", slow_save)
    window.action_record.trigger()
    qtbot.waitUntil(lambda: bool(window.live.recording_info().samples), timeout=10000)
    window.action_record.trigger()
    # Stopped at once; the window keeps running (frames keep coming) while the file is written.
    assert not window.live.recording and window.saving
    assert "Saving the session" in window.session_panel.record_status.text()
    frames = window.scene_view.frames_rendered
    qtbot.waitUntil(lambda: window.scene_view.frames_rendered > frames + 5, timeout=5000)
    assert window.saving and save_threads and save_threads[0] is not threading.main_thread()
    with qtbot.waitSignal(window.recording_saved, timeout=30000) as saved:
        release.set()
    assert saved.args[0].complete and saved.args[0].session_path.exists()
    assert "Saved" in window.session_panel.record_status.text() and not window.saving
    assert window.action_export.isEnabled()
    # Review (the mode bar, Ctrl+2) shows the recording just saved; a recording started and
    # stopped from there with the mode bar's button is shown when Review is chosen again.
    assert "Review (Ctrl+2) shows it" in window.statusBar().currentMessage()
    window.workspace_actions["review"].trigger()
    assert window.workspace == "review" and window.review.view.path == saved.args[0].session_path
    monkeypatch.setattr(RecordingToSave, "save", real_save)
    qtbot.mouseClick(window.mode_bar.record_button, QtCore.Qt.LeftButton)
    assert window.live.recording
    qtbot.waitUntil(window.mode_bar.recording_badge.isVisible, timeout=2000)  # the bar lays itself out
    assert window.workspace == "review" and window.windowTitle().startswith("● Recording")
    qtbot.waitUntil(lambda: bool(window.live.recording_info().samples), timeout=10000)
    with qtbot.waitSignal(window.recording_saved, timeout=30000) as second:
        qtbot.mouseClick(window.mode_bar.record_button, QtCore.Qt.LeftButton)
    assert window.mode_bar.record_button.text() == "● Record"
    qtbot.waitUntil(lambda: not window.mode_bar.recording_badge.isVisible(), timeout=2000)
    assert "Review (Ctrl+2) shows it" in window.review.statusBar().currentMessage()
    window.workspace_actions["capture"].trigger()
    window.workspace_actions["review"].trigger()
    assert window.review.view.path == second.args[0].session_path


def test_closing_while_recording_asks_first(app_window, qtbot, tmp_path, monkeypatch):
    window = app_window
    monkeypatch.setattr(window, "recording_folder", lambda: tmp_path)
    qtbot.waitUntil(lambda: window.live.samples_received > 0, timeout=10000)
    window.action_record.trigger()
    assert window.live.recording
    answers = iter([QtWidgets.QMessageBox.No, QtWidgets.QMessageBox.Yes])
    monkeypatch.setattr(QtWidgets.QMessageBox, "question", lambda *a, **k: next(answers))
    window.close()
    assert window.isVisible() and window.live.recording  # "No": nothing happens
    live = window.live
    window.close()
    # the file is written while the window keeps running, a progress dialog showing; it closes then
    qtbot.waitUntil(lambda: not window.isVisible(), timeout=30000)
    assert live.last_recording is not None and live.last_recording.session_path.exists()
    assert not live.last_recording.journal_path.exists()
