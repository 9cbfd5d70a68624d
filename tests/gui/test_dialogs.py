"""Source dialog, assignment dialog and sensor panel behave as a user expects."""

from __future__ import annotations

import math

from mimucap.gui.assignment_dialog import AssignmentDialog, remembered_assignment
from mimucap.gui.sensor_panel import SensorPanel
from mimucap.gui.source_dialog import SourceDialog, last_skeleton_model, last_source_spec, remember_source
from mimucap.session.live.sensor_rows import SensorRow


def test_source_dialog_builds_checks_and_starts_from_the_remembered_spec(qtbot):
    assert last_source_spec() == "simulated:demo"  # first start: the simulated suit
    dialog = SourceDialog(None)
    qtbot.addWidget(dialog)
    assert dialog.current_kind() == "simulated"
    dialog.kind_buttons["udp"].setChecked(True)
    dialog.udp_address.setText("0.0.0.0")
    dialog.udp_port.setValue(6001)
    assert dialog.current_spec() == "udp:0.0.0.0:6001"
    dialog.kind_buttons["serial"].setChecked(True)
    dialog.serial_baud.setCurrentText("fast")
    dialog.accept()
    assert "baud" in dialog.error_label.text() and dialog.result() == 0  # refused, stays open
    dialog.serial_baud.setCurrentText("230400")
    dialog.serial_device.setText("/dev/serial/by-id/usb-node")
    dialog.accept()
    assert dialog.spec == "serial:/dev/serial/by-id/usb-node@230400"
    assert last_source_spec() == "simulated:demo"  # remembered by the window once the source opened
    remember_source(dialog.spec, dialog.model_name)
    assert last_source_spec() == dialog.spec
    again = SourceDialog(None)
    qtbot.addWidget(again)
    assert again.current_kind() == "serial" and again.serial_baud.currentText() == "230400"
    again.set_spec("replay:/data/s.h5@2")
    assert again.current_spec() == "replay:/data/s.h5@2"


def test_source_dialog_asks_for_the_skeleton_and_starts_from_the_remembered_one(qtbot):
    assert last_skeleton_model() == "ten_segment"
    dialog = SourceDialog(None)
    qtbot.addWidget(dialog)
    assert dialog.model_combo.currentData() == "ten_segment"
    dialog.model_combo.setCurrentIndex(dialog.model_combo.findData("fifteen_segment"))
    dialog.accept()
    assert dialog.model_name == "fifteen_segment" and last_skeleton_model() == "ten_segment"
    remember_source(dialog.spec, dialog.model_name)
    assert last_skeleton_model() == "fifteen_segment"
    again = SourceDialog(None)
    qtbot.addWidget(again)
    assert again.model_combo.currentData() == "fifteen_segment"


def test_assignment_dialog_refuses_two_sensors_on_one_segment(qtbot):
    dialog = AssignmentDialog(None, ["1", "2", "3"], ["pelvis", "thorax"], {"1": "pelvis"})
    qtbot.addWidget(dialog)
    assert dialog.assignment() == {"1": "pelvis"}
    dialog.set_segment("2", "pelvis")
    dialog.accept()
    assert "Pelvis is given to both 1 and 2" in dialog.error_label.text() and remembered_assignment() == {}
    assert dialog.combos["1"].currentText() == "Pelvis"  # shown clinically, kept as "pelvis"
    dialog.set_segment("2", "thorax")
    dialog.accept()
    assert remembered_assignment() == {"1": "pelvis", "2": "thorax"}


def _row(sensor_id, stale=False, state="ok"):
    return SensorRow(sensor_id, "pelvis", 99.5, 3, 4.25, math.nan, "calibrated", 7200.0, ("rest",), stale, state)


def test_sensor_panel_shows_rows_and_flags_stale_ones(qtbot):
    panel = SensorPanel()
    qtbot.addWidget(panel)
    panel.show_rows([_row("S01"), _row("S02", stale=True, state="stale")])
    assert panel.cell_text("S01", "Rate (Hz)") == "99.5"
    assert panel.cell_text("S01", "Delay (ms)") == "4.2" or panel.cell_text("S01", "Delay (ms)") == "4.3"
    assert panel.cell_text("S01", "Battery (%)") == "–"
    assert panel.cell_text("S01", "Magnetometer") == "calibrated (2 hours ago)"
    assert panel.cell_text("S01", "Filter notes") == "rest"
    # headings in words a clinician reads; the technical detail on hover
    headings = [panel.horizontalHeaderItem(c).text() for c in range(panel.columnCount())]
    assert not {"Latency p95 (ms)", "Fusion flags", "Mag. calibration", "Drops"} & set(headings)
    tooltips = {h: panel.horizontalHeaderItem(c).toolTip() for c, h in enumerate(headings)}
    assert all(tooltips.values()) and "95th percentile" in tooltips["Delay (ms)"]
    assert "orientation filter" in tooltips["Filter notes"] and "RSSI" in tooltips["Radio (dBm)"]
    assert panel.cell_text("S02", "State") == "STALE: no data"
    stale_colour = panel.item(panel.row_of("S02"), 0).background().color()
    assert stale_colour.red() > 200 and stale_colour.green() < 220
    assert panel.cell_text("S01", "Segment") == "Pelvis"
    panel.show_rows([_row("S01")])
    assert panel.rowCount() == 1


def test_sensor_panel_counts_refused_packets_with_the_reason_on_hover(qtbot):
    """A sensor that is STALE while its packets keep arriving (refused as stale sequence
    numbers after a restart, say) says so: the Refused column counts them, the tooltip says why."""
    from dataclasses import replace

    from mimucap.acquisition.rejections import Rejection
    from mimucap.gui.sensor_panel import REJECTION_TEXT

    assert set(REJECTION_TEXT) == set(Rejection)  # every reason has words
    panel = SensorPanel()
    qtbot.addWidget(panel)
    refused = replace(_row("S02", stale=True, state="stale"), rejections={"stale_sequence": 120, "out_of_range": 3})
    panel.show_rows([_row("S01"), refused])
    assert panel.cell_text("S01", "Refused") == "0"
    assert panel.cell_text("S02", "Refused") == "123"
    assert panel.cell_text("S02", "State").startswith("STALE: packets arrive but are refused")
    tooltip = panel.item(panel.row_of("S02"), 4).toolTip()
    lines = tooltip.splitlines()
    assert lines[1].startswith("120 × stale") and lines[2].startswith("3 × a value outside")
    panel.show_rows([_row("S01"), replace(refused, rejections={"stale_sequence": 121})])
    assert panel.cell_text("S02", "Refused") == "121"
    assert "out of range" not in panel.item(panel.row_of("S02"), 4).toolTip()


def test_paths_in_view_write_the_home_folder_as_a_tilde(monkeypatch, tmp_path):
    from mimucap.gui.session_panel import display_path

    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert display_path(tmp_path / "home" / "sessions" / "P001.h5") == "~/sessions/P001.h5"
    assert display_path(tmp_path / "homework" / "P001.h5") == str(tmp_path / "homework" / "P001.h5")
    assert display_path("/data/P001.h5") == "/data/P001.h5"
