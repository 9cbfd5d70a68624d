"""In the window, a stored magnetometer calibration of the suit's own devices whose local field no
longer fits (made in a field of 60 µT; the window's simulated suit is in 49.3 µT) is named with
its figures by the Sensors table, the checklist and the "Not everything is ready" prompt, and the
recording made anyway stores it as not good."""

from __future__ import annotations

import re

import pytest
from PyQt5 import QtWidgets

from mimucap.cli import main
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.magnetic_field import EarthField
from mimucap.core.simulate.suit import simulate_session
from mimucap.io.session import read_session, session_from_simulation, write_session

FIGURES = r"local field (\d+) µT, (\d+) µT when calibrated"


@pytest.fixture
def stale_store(tmp_path):
    """``magcal fit --save`` of the window's own suit (seed 0, default errors), made in a field of
    60 µT: the user's store (``MIMUCAP_DATA_DIR``) holds it."""
    config = SimulationConfig(scenario="demo", duration_s=27.0, magcal_turns=True, earth_field=EarthField(60.0))
    path = tmp_path / "elsewhere.h5"
    write_session(path, session_from_simulation(simulate_session(config)))
    assert main(["magcal", "fit", str(path), "--save"]) == 0
    return path


def test_a_calibration_that_no_longer_fits_is_named_by_the_table_the_checklist_and_the_prompt(
        stale_store, qtbot, tmp_path, monkeypatch, accept_modal):
    from mimucap.gui.main_window import MainWindow

    window = MainWindow("simulated:demo")
    window.show()
    window.start()
    qtbot.waitExposed(window)
    monkeypatch.setattr(window, "recording_folder", lambda: tmp_path)
    try:
        assert len(window.live.mag_calibrations) == 10          # its own devices': applied
        qtbot.waitUntil(lambda: window.live.samples_received > 2500, timeout=20000)
        window.live.publish_status()
        state = window.sensor_panel.cell_text("S01", "State")
        local, when = map(int, re.fullmatch(FIGURES + ": calibrate again here", state).groups())
        s01 = window.sensor_panel.item(window.sensor_panel.row_of("S01"), 0).toolTip()
        assert s01.startswith("Device: simulated unit S01 of suit ")
        assert abs(when - 60) <= 4 and abs(local - 49.3 * when / 60.0) <= 2   # through the calibration
        label = window.session_panel.checklist_labels["magnetometers"]
        qtbot.waitUntil(lambda: "the local field no longer fits" in label.text(), timeout=3000)
        assert not label.property("ok") and "Pelvis sensor (S01) local field" in label.text()

        shown = []
        window.confirm_recording = window._ask_to_record_anyway

        def record_anyway(box: QtWidgets.QMessageBox) -> None:
            shown.append(box.informativeText())
            next(b for b in box.buttons() if b.text() == "Record Anyway").click()

        accept_modal(record_anyway)
        window.action_record.trigger()
        assert window.live.recording
        prompt = shown[0]
        assert "• Magnetometer calibration: the local field no longer fits: Pelvis sensor (S01) local field" in prompt
        assert re.search(FIGURES, prompt)
        qtbot.wait(300)
        window.action_record.trigger()
        window.wait_for_saving()
        recorded = read_session(window.live.last_recording.session_path)
        readiness = recorded.metadata["magnetometer_readiness"]["S01"]
        assert readiness["level"] == "not good" and re.fullmatch(FIGURES, readiness["problems"][0])
    finally:
        if window.live is not None and window.live.recording:
            window.toggle_recording()
        window.wait_for_saving()
        window.close()
        window.deleteLater()
