"""What the screenshot scripts share (``make_screenshots.py`` and its helpers, which import this
from their own folder): waiting for the window under a display, and a simulated session's body
calibration."""

from __future__ import annotations

import time

from PyQt5 import QtCore, QtWidgets


def wait(app: QtWidgets.QApplication, condition, timeout_s: float, what: str) -> None:
    """Process events until ``condition()`` holds; RuntimeError naming ``what`` after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise RuntimeError(f"timed out waiting for {what}")
        app.processEvents(QtCore.QEventLoop.AllEvents, 20)


def known_mounting_calibration(result) -> dict:
    """The body calibration of a simulation ``result`` whose error-free sensors are worn along
    their segments: that mounting (as the N-pose/T-pose procedure would find it), as stored in a
    session's calibrations."""
    import numpy as np

    from mimucap.core import skeleton
    from mimucap.core.bodycal import BodyCalibration, CalibrationQuality

    return BodyCalibration(
        q_world_from_body=skeleton.q_world_from_body_facing(0.0), up_world=np.array([0.0, 0.0, 1.0]),
        sensors={m.segment: sid for sid, m in result.mounting.items()},
        q_segment_from_sensor={m.segment: m.q_segment_from_sensor for m in result.mounting.values()},
        quality=CalibrationQuality("known mounting", ())).to_dict()
