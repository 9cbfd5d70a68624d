"""Issue 6, done when: the whole flow driven as a user would, under Xvfb.

Start the app, choose the simulated suit, assign sensors, record ten seconds with two markers,
stop, export CSV and .mot, reopen the session, scrub to a marker. Simulated time runs five
times faster than the wall clock (every part of the pipeline reads the same clock).
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from PyQt5 import QtCore, QtWidgets

from mimucap.gui.assignment_dialog import AssignmentDialog, remembered_assignment
from mimucap.gui.main_window import MainWindow
from mimucap.gui.source_dialog import SourceDialog, last_source_spec
from mimucap.io.angles_export import read_angles_csv, read_angles_mot
from mimucap.io.session import read_session
from mimucap.session.live import RecordingToSave, open_live_session

SPEED_UP = 5.0
RECORD_S = 10.0


def _fast_clock():
    start = time.monotonic()
    return lambda: start + SPEED_UP * (time.monotonic() - start)


@pytest.fixture
def app_window(qtbot):
    clock = _fast_clock()
    window = MainWindow("simulated:demo", session_factory=lambda spec: open_live_session(spec, clock=clock))
    window.clock = clock
    window.confirm_recording = lambda items: True  # recording without calibrations, knowingly
    window.show()
    window.start()
    qtbot.waitExposed(window)
    yield window
    for review in window.review_windows:
        review.close()
    if window.live is not None and window.live.recording:
        window.live.stop_recording()
    window.close()


def test_record_export_review(app_window, qtbot, tmp_path, monkeypatch, accept_modal):
    window = app_window
    # 1. Choose the simulated suit (walking) in the source dialog.
    def choose(dialog: SourceDialog):
        dialog.kind_buttons["simulated"].setChecked(True)
        dialog.scenario.setCurrentText("walk")
        dialog.accept()
    accept_modal(choose)
    window.action_source.trigger()
    assert window.live.label == "simulated:walk"
    assert last_source_spec() == "simulated:walk"  # remembered for next time
    qtbot.waitUntil(lambda: window.live.samples_received > 100, timeout=10000)

    # 2. Assign the sensors: swap the two shanks' sensors on purpose, then put them right.
    suit = dict(window.live.feed.sensor_segments())
    wanted = dict(suit)
    def assign(dialog: AssignmentDialog):
        for sensor_id, segment in wanted.items():
            dialog.set_segment(sensor_id, segment)
        dialog.accept()
    accept_modal(assign)
    window.action_assign.trigger()
    assert window.live.sensor_segments == wanted
    assert remembered_assignment() == wanted
    window.refresh_panels()
    assert window.sensor_panel.cell_text("S01", "Segment") == "Pelvis"

    # 3. Subject, then record ten (simulated) seconds with two markers.
    window.session_panel.subject_id.setText("P042")
    window.session_panel.height.setValue(1.75)
    monkeypatch.setattr(window, "recording_folder", lambda: tmp_path)
    qtbot.mouseClick(window.session_panel.record_button, QtCore.Qt.LeftButton)
    assert window.live.recording
    assert "P042_" in window.session_panel.record_status.text()
    start = window.clock()
    qtbot.waitUntil(lambda: window.clock() - start > 3.0, timeout=10000)
    qtbot.keyClicks(window.session_panel.marker_label, "first step")
    qtbot.mouseClick(window.session_panel.marker_button, QtCore.Qt.LeftButton)
    qtbot.waitUntil(lambda: window.clock() - start > 7.0, timeout=10000)
    window.session_panel.marker_label.clear()
    QtWidgets.QApplication.setActiveWindow(window)
    window.session_panel.record_button.setFocus()
    qtbot.keyClick(window.session_panel.record_button, QtCore.Qt.Key_M)  # the hotkey
    assert window.live.recording_info().markers == 2
    qtbot.waitUntil(lambda: window.live.recording_info().elapsed_s >= RECORD_S, timeout=10000)
    info = window.live.recording_info()
    assert info.size_bytes > 0 and info.markers == 2
    with qtbot.waitSignal(window.recording_saved, timeout=30000):
        qtbot.mouseClick(window.session_panel.record_button, QtCore.Qt.LeftButton)
        assert not window.live.recording
    result = window.live.last_recording
    assert result.complete and result.session_path.parent == tmp_path
    assert "Saved" in window.session_panel.record_status.text()

    session = read_session(result.session_path)
    assert set(session.sensors) == set(suit)
    assert {sid: s.segment for sid, s in session.sensors.items()} == wanted
    assert session.metadata["subject"]["id"] == "P042"
    labels = [m.label for m in session.markers]
    assert labels == ["first step", "marker"]
    t_first, t_second = (m.t_s for m in session.markers)
    assert 2.5 < t_first < 4.5 and 6.5 < t_second < 8.5
    for stream in session.sensors.values():
        assert RECORD_S - 0.2 < stream.t_s[-1] - stream.t_s[0] < RECORD_S + 1.0
        rate = (len(stream.t_s) - 1) / (stream.t_s[-1] - stream.t_s[0])
        assert rate == pytest.approx(100.0, rel=0.05)  # the suit's rate, in session seconds
        assert np.all(np.isfinite(stream.gyr))

    # 4. Export joint angles between the two markers as CSV and .mot.
    window.action_export.trigger()
    review = window.review_windows[-1]
    qtbot.waitUntil(lambda: review.export_dialog is not None, timeout=20000)
    dialog = review.export_dialog
    dialog.range_markers.setChecked(True)
    dialog.marker_a.setCurrentIndex(0)
    dialog.marker_b.setCurrentIndex(1)
    dialog.base_path.setText(str(tmp_path / "walk_angles"))
    assert dialog.summary.rowCount() == len(review.player.data.angles_deg)
    qtbot.mouseClick(dialog.export_button, QtCore.Qt.LeftButton)
    qtbot.waitUntil(lambda: dialog.result is not None, timeout=20000)
    assert dialog.progress.value() == 100
    table = read_angles_csv(tmp_path / "walk_angles.csv")
    mot = read_angles_mot(tmp_path / "walk_angles.mot")
    assert table.t_s[0] >= t_first - 1e-6 and table.t_s[-1] <= t_second + 1e-6
    assert len(table.t_s) == pytest.approx(100 * (t_second - t_first), abs=3)
    assert np.allclose(mot.t_s, table.t_s, atol=1e-6)
    knee = table.angles_deg["knee_r_flexion_deg"]
    # Independent reference: the simulator's own joint angles, stored as truth in the session.
    truth = session.truth
    reference = np.interp(table.t_s, truth.t_s, truth.joint_angles_deg["knee_r_flexion_deg"])
    assert np.max(np.abs(knee - reference)) < 0.5
    assert np.ptp(knee) > 30.0  # walking bends the knee
    assert np.allclose(mot.angles_deg["knee_r_flexion_deg"], knee, atol=1e-5)
    summary = (tmp_path / "walk_angles_summary.csv").read_text().splitlines()
    assert "column,label,min_deg,max_deg,rom_deg" in summary
    assert "knee_r_flexion_deg,Right knee flexion (°)," in "\n".join(summary)
    # the two markers bounding the range are in both angle files' headers
    for written in (table, mot):
        assert [m.label for m in written.markers] == [m.label for m in review.player.data.markers[:2]]
    png = dialog.save_summary_png(tmp_path / "summary.png")
    assert png.stat().st_size > 5000
    dialog.accept()
    review.close()

    # 5. Reopen the session from the File menu (its camera as the main window's) and scrub to
    #    the second marker.
    window.camera_actions["side"].trigger()
    monkeypatch.setattr(QtWidgets.QFileDialog, "getOpenFileName", lambda *a, **k: (str(result.session_path), ""))
    window.action_open.trigger()
    review = window.review_windows[-1]
    assert review.scene_view.camera_preset == "side" and review.camera_actions["side"].isChecked()
    qtbot.waitUntil(lambda: review.player is not None, timeout=20000)
    assert review.markers_list.count() == 2
    review.camera_actions["follow"].trigger()
    assert review.scene_view.camera_preset == "follow"
    assert review.pose_status.text() == "Pose: simulator truth"
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

    def slow_save(pending):
        save_threads.append(threading.current_thread())
        assert release.wait(20)
        return real_save(pending)

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
