"""What a user can get wrong in the main window does not cost a recording, a setting or a
silent failure: a refused source change, Space after clicking Record, marker times, unwritable
folders, reviews that failed, were closed or replaced, a source switch under an open wizard."""

from __future__ import annotations

import pytest
from PyQt5 import QtCore, QtWidgets, sip

from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import simulate_session
from mimucap.gui.main_window import MainWindow
from mimucap.gui.source_dialog import SourceDialog, last_skeleton_model, last_source_spec
from mimucap.io.session import session_from_simulation, write_session


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):
    win = MainWindow("simulated:demo")  # closed below, after any recording is stopped
    win.confirm_recording = lambda items: True  # recording without calibrations, knowingly
    win.show()
    win.start()
    qtbot.waitExposed(win)
    monkeypatch.setattr(win, "recording_folder", lambda: tmp_path)
    qtbot.waitUntil(lambda: win.live.samples_received > 0, timeout=15000)
    yield win
    if win.live is not None and win.live.recording:
        win.toggle_recording()
        win.wait_for_saving()
    win.close()
    win.deleteLater()


def test_no_source_change_while_recording_and_a_failed_one_is_not_remembered(window, qtbot, monkeypatch,
                                                                              accept_modal):
    warnings = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "warning", lambda *a, **k: warnings.append(a[2]))
    window.action_record.trigger()
    assert window.live.recording and not window.action_source.isEnabled()
    window.choose_source()  # e.g. from a script: refused before any dialog
    assert warnings == ["Stop the recording before changing the source."]
    window.action_record.trigger()
    window.wait_for_saving()
    assert window.action_source.isEnabled()

    # A source that fails to open: neither it nor its skeleton is used or remembered.
    def failing(spec):
        raise OSError("no such device")
    monkeypatch.setattr(window, "session_factory", failing)

    def choose(dialog: SourceDialog):
        dialog.kind_buttons["serial"].setChecked(True)
        dialog.serial_device.setText("/dev/ttyGone")
        dialog.model_combo.setCurrentIndex(dialog.model_combo.findData("fifteen_segment"))
        dialog.accept()
    accept_modal(choose)
    window.action_source.trigger()
    assert "no such device" in warnings[-1]
    assert window.model_name == "ten_segment" and window.live.label == "simulated:demo"
    assert last_source_spec() == "simulated:demo" and last_skeleton_model() == "ten_segment"


def test_a_click_on_record_leaves_space_to_the_plots(window, qtbot):
    bar = window.mode_bar
    for button in (bar.record_button, bar.marker_button):
        assert button.focusPolicy() == QtCore.Qt.NoFocus  # a click does not take the keyboard
    qtbot.mouseClick(bar.record_button, QtCore.Qt.LeftButton)
    assert window.live.recording
    assert QtWidgets.QApplication.focusWidget() is not bar.record_button
    assert window.action_pause_plots.text().endswith("\tSpace")


def test_markers_are_listed_at_their_time_in_the_recording(window, qtbot):
    window.add_marker("before")
    listed = window.session_panel.markers_list
    assert listed.item(listed.count() - 1).text().strip() == "–    before (not recorded)"
    qtbot.wait(1500)  # the live session has been running: session time is well past 1.5 s
    window.action_record.trigger()
    qtbot.wait(500)
    window.add_marker("heel strike")
    line = window.session_panel.markers_list.item(window.session_panel.markers_list.count() - 1).text()
    seconds = float(line.split(" s ")[0])
    info = window.live.recording_info()
    assert 0.3 < seconds <= info.elapsed_s + 0.01  # time since the recording started, as review shows it
    assert "heel strike" in line


def test_a_source_switch_clears_the_old_sources_markers_plots_and_messages(window, qtbot):
    window.add_marker("old")
    window.statusBar().showMessage("Cannot open source x: y")
    qtbot.waitUntil(lambda: len(window.plots.curve_data("acc", 0)[0]) > 0, timeout=5000)
    assert window.open_source("simulated:walk", interactive=False)
    assert window.session_panel.markers_list.count() == 0 or \
        all("old" not in window.session_panel.markers_list.item(i).text()
            for i in range(window.session_panel.markers_list.count()))
    assert window.statusBar().currentMessage() == ""
    assert len(window.plots.curve_data("acc", 0)[0]) == 0 or window.plots.source is window.live


def test_a_source_switch_closes_an_open_calibration_wizard(window, qtbot):
    window.open_wizard("body")
    wizard = window._wizard
    assert wizard.isVisible()
    assert window.open_source("simulated:walk", interactive=False)
    assert not wizard.isVisible() and "wizard was closed" in window.statusBar().currentMessage()


def test_unwritable_folders_are_said_not_swallowed(window, qtbot, tmp_path, monkeypatch):
    warnings = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "warning", lambda *a, **k: warnings.append(a[2]))
    blocked = tmp_path / "a_file"
    blocked.write_text("x")
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName",
                        lambda *a, **k: (str(blocked / "shot.png"), "PNG images (*.png)"))
    window.action_save_screenshot.trigger()
    assert warnings and "shot.png" in warnings[-1]
    # A recording folder out of reach: the file dialogs still open (in the home folder).
    monkeypatch.setattr(window, "recording_folder", lambda: (_ for _ in ()).throw(OSError("drive gone")))
    asked = []
    monkeypatch.setattr(QtWidgets.QFileDialog, "getOpenFileName", lambda *a, **k: (asked.append(a[2]) or "", ""))
    window.action_open.trigger()
    assert asked and "drive gone" in window.statusBar().currentMessage()


def _let_go(widget) -> bool:
    """Run Qt's deferred deletions; True once ``widget`` is deleted."""
    QtCore.QCoreApplication.sendPostedEvents(None, QtCore.QEvent.DeferredDelete)
    return sip.isdeleted(widget)


def _session_file(tmp_path):
    sim = simulate_session(SimulationConfig(scenario="walk", duration_s=3.0))
    path = tmp_path / "walk.h5"
    write_session(path, session_from_simulation(sim))
    return path


def test_reviews_are_let_go_when_closed_or_replaced_and_a_failed_one_is_said(window, qtbot, tmp_path, monkeypatch):
    warnings = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "warning", lambda *a, **k: warnings.append(a[2]))
    bad = tmp_path / "notes.h5"
    bad.write_text("not a session")
    review = window.open_review(bad)
    qtbot.waitUntil(lambda: window.review.view is None, timeout=10000)
    assert len(warnings) == 1  # said once, in a dialog, and on the Review workspace's page
    assert window.review.currentWidget() is window.review.empty and "notes.h5" in window.review.statusBar().currentMessage()
    qtbot.waitUntil(lambda: _let_go(review), timeout=5000)  # let go

    path = _session_file(tmp_path)
    good = window.open_review(path)
    with qtbot.waitSignal(good.loaded, timeout=20000):
        pass
    assert window.review.view is good
    again = window.open_review(path)  # one recording at a time: the one shown before is let go
    assert window.review.view is again and not good._timer.isActive()
    qtbot.waitUntil(lambda: _let_go(good), timeout=5000)
    with qtbot.waitSignal(again.loaded, timeout=20000):
        pass
    window.action_close_recording.trigger()
    assert window.review.view is None and not again._timer.isActive()
    qtbot.waitUntil(lambda: _let_go(again), timeout=5000)


def test_a_click_on_the_review_slider_moves_the_play_head_there(window, qtbot, tmp_path):
    review = window.open_review(_session_file(tmp_path))
    with qtbot.waitSignal(review.loaded, timeout=20000):
        pass
    slider = review.slider
    qtbot.mouseClick(slider, QtCore.Qt.LeftButton, pos=QtCore.QPoint(int(slider.width() * 0.75), slider.height() // 2))
    fraction = (slider.value() - slider.minimum()) / (slider.maximum() - slider.minimum())
    assert fraction == pytest.approx(0.75, abs=0.05)
    assert review.player.cursor_s == pytest.approx(slider.value() / 100, abs=0.011)
    before = slider.value()
    qtbot.keyClick(slider, QtCore.Qt.Key_PageDown)
    assert abs(slider.value() - before) == 100  # one second


def test_export_dialog_follows_the_users_edits_and_says_what_failed(qtbot, tmp_path, calibrated_walk):
    from mimucap.gui.export_dialog import ExportDialog
    from mimucap.session.recorded.review import load_review

    data = load_review(calibrated_walk)  # joint angles are offered with a body calibration only
    dialog = ExportDialog(None, data)
    qtbot.addWidget(dialog)
    assert dialog.range_all.isChecked() and dialog.export_button.isEnabled()
    dialog.t_from.setValue(1.0)  # editing the times chooses that range
    assert dialog.range_time.isChecked() and dialog.time_range() == (1.0, pytest.approx(dialog.t_to.value()))
    dialog.t_to.setValue(0.5)  # reversed: nothing can be exported or saved, and it says why
    assert "before it starts" in dialog.message.text()
    assert not dialog.export_button.isEnabled() and not dialog.summary_csv_button.isEnabled()
    dialog.t_to.setValue(2.0)
    for box in (dialog.want_csv, dialog.want_mot, dialog.want_summary, dialog.want_sensors):
        box.setChecked(False)
    assert not dialog.export_button.isEnabled()  # no file ticked
    dialog.want_csv.setChecked(True)
    assert dialog.export_button.isEnabled()
    folder = tmp_path / "out"
    folder.mkdir()
    dialog.base_path.setText(str(folder) + "/")  # a folder: the files go inside it
    assert dialog.export_base_path() == folder / "walk"
    dialog.base_path.setText("  ")
    with pytest.raises(ValueError, match="Save as"):
        dialog.export_base_path()
    blocked = tmp_path / "a_file"
    blocked.write_text("x")
    dialog._save_or_say(dialog.save_summary_csv, str(blocked / "summary.csv"))
    assert dialog.message.text().startswith("Summary not saved:")
    texts = [dialog.summary.item(r, c).text() for r in range(dialog.summary.rowCount()) for c in (1, 2, 3)]
    assert texts and "-0.0" not in texts
