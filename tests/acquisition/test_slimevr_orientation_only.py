"""Orientation-only sensors (on-board fusion, no raw channels: SlimeVR trackers) through the
product: the live session takes their quaternions, the body calibration works from them, the
magnetometer wizard says they calibrate themselves, the sensor panel shows battery and signal.

The sensors are the simulated suit's with on-board orientation, stripped of acc, gyr and mag
as a SlimeVR tracker sends them; the body calibration is checked against the simulator's true
mounting rotations (an independent reference)."""

from __future__ import annotations

import dataclasses
from dataclasses import replace

import numpy as np
import pytest
from PyQt5 import QtCore

from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.sensor_errors import error_model
from mimucap.gui.sensor_panel import SensorPanel
from mimucap.gui.wizards import BodyCalibrationWizard, MagnetometerWizard
from mimucap.io.calibration_store import CalibrationStore
from mimucap.session.sources.feeds import SimulatorFeed
from mimucap.session.live.live_session import LiveSession
from tests.gui.body_wizard_runs import FakeClock, mounting_errors_deg, run_on_live

pytestmark = pytest.mark.gui
ONBOARD = replace(error_model("default"), onboard_orientation=True, onboard_error_deg=0.3)


class OrientationOnlyFeed(SimulatorFeed):
    """The simulated suit as SlimeVR trackers would deliver it: orientation, battery, signal."""

    def poll(self):
        return [dataclasses.replace(block, acc=None, gyr=None, mag_uT=None,
                                    battery_pct=np.full(len(block), 64.0))
                for block in super().poll()]

    def signal_dbm(self) -> dict[str, float]:
        return {sid: -55.0 for sid in self.sensor_ids}


def _live(scenario: str) -> tuple[LiveSession, FakeClock]:
    clock = FakeClock()
    config = SimulationConfig(scenario=scenario, n_sensors=10, seed=8, errors=ONBOARD)
    live = LiveSession(OrientationOnlyFeed(config, clock=clock), clock=clock)
    live.start()
    return live, clock


def test_the_panel_shows_battery_and_signal_and_the_magnetometer_wizard_asks_nothing(qtbot, tmp_path):
    live, clock = _live("npose")
    for _ in range(20):
        clock.now += 0.1
        live.step()
    assert sorted(live.orientation_only_sensors()) == sorted(live.sensor_ids)
    assert set(live.latest_orientations()) == set(live.sensor_ids)   # the device's quaternions
    panel = SensorPanel()
    qtbot.addWidget(panel)
    panel.show_rows(live.sensor_rows())
    assert panel.cell_text("S01", "Battery (%)") == "64"
    assert panel.cell_text("S01", "Radio (dBm)") == "-55"
    assert panel.cell_text("S01", "Magnetometer") == "on-board"
    assert panel.cell_text("S01", "State") == "ok"

    wizard = MagnetometerWizard(None, live, store=CalibrationStore(tmp_path))
    qtbot.addWidget(wizard)
    wizard.show()
    note = wizard.self_calibrating_note
    assert note.isVisible() and "calibrate themselves" in note.text() and "S01" in note.text()
    assert wizard.sensor_list.count() == 0 and not wizard.start_button.isEnabled()
    wizard.close()


def test_the_body_calibration_works_from_their_quaternions(qtbot):
    live, clock = _live("npose")
    wizard = BodyCalibrationWizard(None, live)
    qtbot.addWidget(wizard)
    wizard.show()
    run_on_live(qtbot, wizard, live, clock)
    assert wizard.page_name == "result", wizard.refusal_label.text()
    calibration = wizard.procedure.calibration
    simulator = live.simulator
    errors = mounting_errors_deg(calibration, simulator)
    assert len(errors) == 10 and max(errors) < 1.0
    qtbot.mouseClick(wizard.accept_button, QtCore.Qt.LeftButton)
    assert live.body_calibration is calibration
    for _ in range(10):          # the skeleton follows the sensors through the calibration
        clock.now += 0.1
        live.step()
    assert live.pose_source == "body calibration"
    q_segments = live.q_world_from_segment
    assert q_segments is not None and set(q_segments) >= set(calibration.sensors)


def test_the_source_dialog_offers_slimevr_trackers(qtbot):
    from mimucap.gui.source_dialog import SourceDialog

    dialog = SourceDialog(None, spec="slimevr:127.0.0.1:7000")
    qtbot.addWidget(dialog)
    assert dialog.current_kind() == "slimevr" and dialog.current_spec() == "slimevr:127.0.0.1:7000"
    dialog.slimevr_port.setValue(6969)
    dialog.slimevr_address.setText("0.0.0.0")
    dialog.accept()
    assert dialog.spec == "slimevr:0.0.0.0:6969"


def test_trackers_that_appear_later_are_worn_where_they_were_last_time(qtbot):
    """A worker source's sensors appear with their first samples, after the window opened the
    source: the remembered assignment reaches them then, and they drive the figure."""
    import socket
    import struct

    from mimucap.acquisition import slimevr_protocol as proto
    from mimucap.gui.assignment_dialog import remember_assignment
    from mimucap.core.device_identity import mac_device_id
    from mimucap.gui.main_window import MainWindow
    from mimucap.io.pairing_store import PairingStore
    from mimucap.session.live.processing import POSE_SENSOR_AXES

    mac = bytes([0x02, 0x4D, 0x43, 0, 0, 9])
    remember_assignment({"024D43000009-0": "pelvis", "024D43000009-1": "thorax"})
    PairingStore().pair([(mac_device_id(mac, 0), "024D43000009-0"), (mac_device_id(mac, 1), "024D43000009-1")])
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    win = MainWindow(f"slimevr:127.0.0.1:{port}")
    qtbot.addWidget(win)
    win.show()
    win.start()
    tracker = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    tracker.bind(("127.0.0.1", 0))
    tracker.setblocking(False)
    number = [0]
    connected = [False]
    handshake = struct.pack(">7i", 5, 4, 2, 0, 0, 0, 13) + bytes([5]) + b"0.4.1" + mac

    def send(packet_type: int, payload: bytes) -> None:
        tracker.sendto(proto.encode_tracker_packet(packet_type, number[0], payload), ("127.0.0.1", port))
        number[0] += 1

    def tick() -> None:      # a tracker: looks for its server until answered, then sends rotations
        try:
            while True:
                answer = tracker.recv(2048)
                connected[0] = connected[0] or answer[:1] == b"\x03"
        except BlockingIOError:
            pass
        if not connected[0]:
            tracker.sendto(proto.encode_tracker_packet(proto.PACKET_HANDSHAKE, 0, handshake), ("127.0.0.1", port))
            return
        for sensor in (0, 1):
            send(proto.PACKET_ROTATION_DATA, struct.pack(">BB4fB", sensor, 1, 0.0, 0.0, 0.0, 1.0, 0))

    timer = QtCore.QTimer()
    timer.timeout.connect(tick)
    try:
        timer.start(20)
        qtbot.waitUntil(lambda: win.live.sensor_segments.get("024D43000009-1") == "thorax", timeout=20000)
        assert win.live.sensor_segments.get("024D43000009-0") == "pelvis"
        qtbot.waitUntil(lambda: win.live.pose_source == POSE_SENSOR_AXES, timeout=5000)
    finally:
        timer.stop()
        tracker.close()
        win.close()
