"""Guard rails of the main window: the checklist before recording and its confirmation, the
recording indicator, marker labels used once, refused packets in the sensor panel, closing while
the file is written, and the body wizard's sensor mapping kept or discarded."""

from __future__ import annotations

import threading

import pytest
from PyQt5 import QtCore, QtWidgets

from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import SuitSimulator
from mimucap.gui.assignment_dialog import remembered_assignment
from mimucap.gui.wizards import BodyCalibrationWizard
from mimucap.session.sources.calibration_feed import SimulatedSuitFeed
from mimucap.session.live.recording import RecordingToSave


@pytest.fixture
def live_window(qtbot, tmp_path, monkeypatch):
    """The main window on the simulated suit; not given to qtbot, which would close it before
    this fixture stops a recording (closing asks first)."""
    from mimucap.gui.main_window import MainWindow

    window = MainWindow("simulated:demo")
    window.confirm_recording = lambda items: True
    window.show()
    window.start()
    qtbot.waitExposed(window)
    monkeypatch.setattr(window, "recording_folder", lambda: tmp_path)
    qtbot.waitUntil(lambda: window.live.samples_received > 100, timeout=15000)
    window.live.publish_status()
    yield window
    if window.live is not None and window.live.recording:
        window.toggle_recording()
    window.wait_for_saving()
    window.close()
    window.deleteLater()


def test_the_checklist_is_shown_and_recording_without_it_needs_a_confirmation(live_window, qtbot):
    window = live_window
    labels = window.session_panel.checklist_labels
    assert set(labels) == {"streaming", "drops", "magnetometers", "body"}
    assert window.session_panel.checklist_box.isVisible()
    # the simulated suit streams every sensor (the list is refreshed once a second); nothing is calibrated yet
    qtbot.waitUntil(lambda: labels["streaming"].property("ok"), timeout=3000)
    assert "all 10 assigned sensors send data" in labels["streaming"].text()
    assert not labels["body"].property("ok") and "not done" in labels["body"].text()
    assert not labels["magnetometers"].property("ok") and "not calibrated" in labels["magnetometers"].text()

    asked = []
    window.confirm_recording = lambda items: asked.append([i.key for i in items]) or False
    qtbot.mouseClick(window.mode_bar.record_button, QtCore.Qt.LeftButton)
    assert asked == [["magnetometers", "body"]]
    assert not window.live.recording and window.mode_bar.record_button.text() == "● Record"
    assert not window.live_status.recording_indicator.isVisible()

    window.confirm_recording = lambda items: asked.append([i.key for i in items]) or True
    window.action_record.trigger()
    assert window.live.recording and len(asked) == 2
    # the red indicator with the elapsed time, in the status bar; the checklist steps aside
    indicator = window.live_status.recording_indicator
    assert indicator.isVisible() and indicator.text() == "● REC 00:00"
    assert "#d62728" in indicator.styleSheet() and window.windowTitle().startswith("● Recording")
    assert not window.session_panel.checklist_box.isVisible()
    qtbot.waitUntil(lambda: indicator.text() == "● REC 00:01", timeout=5000)
    assert indicator.visibleRegion().boundingRect().width() == indicator.width()  # not covered
    # the file being written beside it, whole (it was "Recording to ~/sessions/P001_2026-1" under the badge)
    target = window.live_status.recording_target
    assert target.isVisible() and target.text() == f"→ {window.live.recording_info().path.name}"
    assert target.width() >= target.sizeHint().width() and target.visibleRegion().boundingRect().width() == target.width()
    assert "Recording to" not in window.statusBar().currentMessage()
    window.action_record.trigger()
    assert not indicator.isVisible() and not target.isVisible() and window.windowTitle() == "MimuCap"
    assert window.session_panel.checklist_box.isVisible()


def test_a_ready_session_records_without_asking(live_window, qtbot, monkeypatch):
    from mimucap.session.live import checklist as checklist

    window = live_window
    ready = [checklist.CheckItem(key, key, True, "ok") for key in ("streaming", "drops", "magnetometers", "body")]
    monkeypatch.setattr("mimucap.gui.main_window.recording_checklist", lambda live: ready)
    window.confirm_recording = lambda items: pytest.fail(f"asked although everything is ready: {items}")
    window.action_record.trigger()
    assert window.live.recording


def test_a_marker_takes_the_typed_label_once(live_window, qtbot):
    window = live_window
    panel = window.session_panel
    window.action_record.trigger()
    qtbot.keyClicks(panel.marker_label, "heel strike")
    qtbot.mouseClick(window.mode_bar.marker_button, QtCore.Qt.LeftButton)
    assert panel.marker_label.text() == ""
    qtbot.mouseClick(window.mode_bar.marker_button, QtCore.Qt.LeftButton)
    qtbot.keyClicks(panel.marker_label, "turn")
    window.action_marker.trigger()  # the menu item (M) reads and clears the field too
    assert panel.marker_label.text() == ""
    lines = [panel.markers_list.item(i).text().split(" s  ", 1)[1] for i in range(panel.markers_list.count())]
    assert lines == ["heel strike", "marker", "turn"]
    assert window.live.recording_info().markers == 3


def test_refused_packets_reach_the_sensor_panel(live_window, monkeypatch):
    window = live_window
    feed = window.live.feed
    real_stats = feed.stats

    def stats():
        found = real_stats()
        first = next(iter(found))
        found[first] = type(found[first])(**{**found[first].__dict__, "rejections": {"stale_sequence": 7}})
        return found
    monkeypatch.setattr(feed, "stats", stats)
    window.live.publish_status()
    first = window.live.sensor_ids[0]
    panel = window.sensor_panel
    assert panel.cell_text(first, "Refused") == "7"
    assert "7 × stale" in panel.item(panel.row_of(first), 4).toolTip()
    assert panel.cell_text(window.live.sensor_ids[1], "Refused") == "0"


def test_closing_while_the_file_is_written_shows_progress_and_keeps_the_window_alive(live_window, qtbot,
                                                                                       monkeypatch):
    window = live_window
    release = threading.Event()
    real_save = RecordingToSave.save
    fractions = []

    def save(pending, progress=None):
        release.wait(20)
        return real_save(pending, lambda fraction: (fractions.append(fraction), progress(fraction)))

    monkeypatch.setattr(RecordingToSave, "save", save)
    monkeypatch.setattr(QtWidgets.QMessageBox, "question", lambda *a, **k: QtWidgets.QMessageBox.Yes)
    window.action_record.trigger()
    qtbot.waitUntil(lambda: bool(window.live.recording_info().samples), timeout=10000)
    live = window.live
    window.close()
    assert window.isVisible() and not live.recording and window.saving
    progress = window.findChild(QtWidgets.QProgressDialog, "closingProgress")
    assert progress is not None and progress.isVisible() and progress.maximum() == 100  # one file: a percentage
    assert window.session_panel.saving_bar.isVisible()
    frames = window.scene_view.frames_rendered
    qtbot.waitUntil(lambda: window.scene_view.frames_rendered > frames + 5, timeout=5000)  # still responding
    release.set()
    qtbot.waitUntil(lambda: not window.isVisible(), timeout=30000)
    assert live.last_recording is not None and live.last_recording.session_path.exists()
    assert fractions and fractions[-1] == 1.0


class _Live:
    """The part of the live session the body wizard uses for the sensor assignment."""

    def __init__(self, segments: dict[str, str]) -> None:
        self.sensor_segments = dict(segments)

    def assign_sensor(self, sensor_id: str, segment: str | None) -> None:
        for other, seg in list(self.sensor_segments.items()):
            if seg == segment:
                del self.sensor_segments[other]
        if segment is None:
            self.sensor_segments.pop(sensor_id, None)
        else:
            self.sensor_segments[sensor_id] = segment


@pytest.mark.parametrize("answer", ["keep", "discard", "cancel"])
def test_the_body_wizards_mapping_is_kept_or_discarded_never_dropped_silently(qtbot, answer):
    simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=1))
    worn = {sid: m.segment for sid, m in simulator.mounting.items()}
    live = _Live(worn)
    wizard = BodyCalibrationWizard(None, live, feed=SimulatedSuitFeed(simulator, step_s=0.1), model=simulator.model)
    qtbot.addWidget(wizard)
    wizard.show()
    # swap the two shanks' sensors on the setup page
    left, right = wizard.mapping()["shank_l"], wizard.mapping()["shank_r"]
    wizard.mapping_combos["shank_l"].setCurrentText(right)
    wizard.mapping_combos["shank_r"].setCurrentText(left)
    asked = []
    wizard.ask_about_assignment = lambda: asked.append(1) or answer
    # the refused page can be closed like the others
    wizard.pages.setCurrentWidget(wizard.refused_page)
    close = next(b for b in wizard.refused_page.findChildren(QtWidgets.QPushButton) if b.text() == "Close")
    qtbot.mouseClick(close, QtCore.Qt.LeftButton)
    assert asked == [1]
    if answer == "cancel":
        assert wizard.isVisible() and live.sensor_segments == worn
        wizard.ask_about_assignment = lambda: "discard"
        wizard.close()
        assert not wizard.isVisible()
        return
    assert not wizard.isVisible()
    swapped = dict(worn, **{left: "shank_r", right: "shank_l"})
    if answer == "keep":
        assert live.sensor_segments == swapped and remembered_assignment() == swapped
    else:
        assert live.sensor_segments == worn and remembered_assignment() == {}


def test_packets_of_no_known_sensor_are_counted_in_the_status_bar(live_window, monkeypatch):
    window = live_window
    assert not window.live_status.refused_status.isVisible()
    monkeypatch.setattr(window.live.feed, "refused_without_sensor",
                        lambda: ({"unknown_address": 340}, {"address 10.0.0.9": 340}), raising=False)
    window.live.publish_status()
    label = window.live_status.refused_status
    assert label.isVisible() and label.text() == "340 packets refused from no known sensor"
    assert "340 × a sender this source does not accept" in label.toolTip()
    assert "address 10.0.0.9 (340)" in label.toolTip()


def test_the_body_wizard_says_setup_problems_in_clinical_words(qtbot):
    simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=1))
    wizard = BodyCalibrationWizard.for_simulator(simulator)
    qtbot.addWidget(wizard)
    wizard.set_arms("right")
    for segment in ("upper_arm_r", "forearm_r"):  # no sensor on the right arm
        wizard.mapping_combos[segment].setCurrentIndex(0)
    wizard.start()
    assert wizard.page_name == "setup"
    assert "right upper arm" in wizard.setup_error.text() and "upper_arm_r" not in wizard.setup_error.text()
