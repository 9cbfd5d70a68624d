"""Helpers for tests running the body-calibration wizard: a settable clock, a run on a live
session stepped as the main window's timer steps it, and the result's error against the
simulated suit's true mountings (the truth read only here, to grade the estimate)."""

from __future__ import annotations

import numpy as np
from PyQt5 import QtCore

from mimucap.core import rotation as rot


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def run_on_live(qtbot, wizard, live, clock: FakeClock) -> None:
    """Start ``wizard`` and step ``live`` (0.1 s a tick) until the wizard shows its result or refusal."""
    stepper = QtCore.QTimer()

    def step() -> None:
        clock.now += 0.1
        live.step()

    stepper.timeout.connect(step)
    stepper.start(1)
    qtbot.mouseClick(wizard.start_button, QtCore.Qt.LeftButton)
    qtbot.waitUntil(lambda: wizard.page_name in ("result", "refused"), timeout=30000)
    stepper.stop()


def mounting_errors_deg(calibration, simulator) -> list[float]:
    """Per calibrated segment: the angle (degrees) between the estimated and the true mounting."""
    return [float(np.degrees(rot.angle_between(calibration.q_segment_from_sensor[seg],
                                               simulator.mounting[sid].q_segment_from_sensor)))
            for seg, sid in calibration.sensors.items()]
