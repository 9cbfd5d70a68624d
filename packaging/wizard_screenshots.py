"""Screenshots of every calibration-wizard page, driven on the simulated suit.

``write_wizard_screenshots(out_dir) -> list[Path]`` writes PNGs named ``wizard-*.png``
(full pages: the Qt widgets with the VTK views painted in) and returns their paths. Needs a
display (``xvfb-run -a -s "-screen 0 1366x768x24"``). Run directly:

    xvfb-run -a -s "-screen 0 1366x768x24" .venv/bin/python packaging/wizard_screenshots.py docs/screenshots

The simulated subject performs what each page asks, faster than real time (the wizards are
stepped directly, not by their clocks).
"""

from __future__ import annotations

import datetime as dt
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
from PyQt5 import QtWidgets

from mimucap.core.magcal.model import MagCalibration
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import SuitSimulator
from mimucap.gui.capture import grab_window
from mimucap.gui.wizards.body import BodyCalibrationWizard
from mimucap.gui.wizards.magnetometer import MagnetometerWizard
from mimucap.io.calibration_store import CalibrationStore
from mimucap.session.procedures.body import BodycalProcedureSettings

NOW = dt.datetime(2026, 11, 21, 9, 0, tzinfo=dt.timezone.utc)


def _app() -> QtWidgets.QApplication:
    return QtWidgets.QApplication.instance() or QtWidgets.QApplication(sys.argv[:1])


def _until(app: QtWidgets.QApplication, wizard, done: Callable[[], bool], steps: int = 5000) -> None:
    for _ in range(steps):
        if done():
            return
        wizard.feed.advance()  # the simulated suit moves on: its samples reach the wizard
        app.processEvents()
    raise RuntimeError("the simulated wizard did not reach the expected page")


def _save(app, wizard, out_dir: Path, name: str, written: list[Path]) -> None:
    app.processEvents()
    path = out_dir / f"wizard-{name}.png"
    grab_window(wizard).save(str(path), "PNG")
    written.append(path)


def write_wizard_screenshots(out_dir: str | Path) -> list[Path]:
    """Drive both wizards through every page on a simulated suit and save a PNG of each."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    app = _app()
    written: list[Path] = []
    store = CalibrationStore(Path(tempfile.mkdtemp(prefix="mimucap-shots-")))
    simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=3))
    # A previous calibration of S02's device, 12 days old, for the comparison column.
    old = simulator.parameters["S02"]
    store.save(MagCalibration("S02", old.mag_b_uT + 1.5, [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]], 48.0,
                              created_utc="2026-11-09T08:30:00Z", protocol="single_axis",
                              quality={"verdict": "good"}, device_id=simulator.config.device_ids()["S02"]))

    mag = MagnetometerWizard.for_simulator(simulator, store=store, now=lambda: NOW, view_interval_ms=0)
    mag.set_selected_sensors(["S01", "S02", "S03", "S04", "S05"])
    mag.show()
    _save(app, mag, out_dir, "magnetometer-1-setup", written)
    mag.start()
    procedure = mag.procedure
    _until(app, mag, lambda: procedure.status().axis_to_turn == "y" and procedure.status().axis_progress["y"] > 0.5)
    mag._refresh_views(force=True)
    _save(app, mag, out_dir, "magnetometer-2-turn-about-y", written)
    _until(app, mag, lambda: procedure.phase == "result")
    _save(app, mag, out_dir, "magnetometer-3-result", written)
    mag.result_table.selectRow(1)
    _save(app, mag, out_dir, "magnetometer-4-result-with-previous", written)
    # A bad capture: one axis only, then "Compute now".
    mag.redo()
    mag.set_selected_sensors(["S06", "S07"])
    mag.start()
    _until(app, mag, lambda: mag.procedure.status().axis_progress["x"] >= 1.0)
    mag.feed.simulator.set_activity("npose")
    for _ in range(10):
        mag.feed.advance()
    mag.finish_now()
    _save(app, mag, out_dir, "magnetometer-5-one-axis-refused", written)
    mag.redo()
    mag.set_protocol("figure8")
    mag.start()
    _until(app, mag, lambda: mag.procedure.elapsed_s > 6.0)
    mag._refresh_views(force=True)
    _save(app, mag, out_dir, "magnetometer-6-figure8", written)
    mag.close()

    # Body calibration on the same suit, fused with the new magnetometer calibrations.
    simulator_body = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=4))
    body = BodyCalibrationWizard.for_simulator(simulator_body, settings=BodycalProcedureSettings(pose_timeout_s=8.0))
    for sensor_id, parameters in simulator_body.parameters.items():
        body.feed.set_magnetometer_calibration(
            MagCalibration(sensor_id, parameters.mag_b_uT, np.linalg.inv(parameters.mag_A), 50.0))
    # The orientation filters settle on the new magnetometer calibrations while the sensors are
    # strapped on and the setup page is shown (half a minute in a clinic; 20 s here).
    for _ in range(int(20.0 / body.feed.step_s)):
        body.feed.read()
    body.show()
    _save(app, body, out_dir, "body-1-setup", written)
    body.start()
    bodyproc = body.procedure
    _until(app, body, lambda: bodyproc.status().capturing and bodyproc.status().countdown_s < 1.2)
    _save(app, body, out_dir, "body-2-npose-countdown", written)
    _until(app, body, lambda: bodyproc.phase == "tpose" and not bodyproc.status().still)
    _save(app, body, out_dir, "body-3-tpose-raising", written)
    _until(app, body, lambda: bodyproc.phase == "tpose" and bodyproc.status().capturing)
    _save(app, body, out_dir, "body-4-tpose-countdown", written)
    _until(app, body, lambda: bodyproc.phase == "result")
    _save(app, body, out_dir, "body-5-result", written)
    # Movement during the N-pose: restart message, then refusal.
    body.redo()
    _until(app, body, lambda: bodyproc.status().capturing)
    body.feed.simulator.set_activity("arm_raise")
    _until(app, body, lambda: bodyproc.status().message.startswith("Movement"))
    _save(app, body, out_dir, "body-6-npose-movement", written)
    _until(app, body, lambda: bodyproc.phase == "refused")
    _save(app, body, out_dir, "body-7-refused", written)
    body.close()
    return written


if __name__ == "__main__":
    target = sys.argv[1] if len(sys.argv) > 1 else "docs/screenshots"
    for path in write_wizard_screenshots(target):
        print(path)
