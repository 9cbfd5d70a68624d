"""The body calibration a simulated suit's true mounting gives: for tests that need a calibrated
pose from the live session without running the N-pose/T-pose procedure (its own tests do)."""

from __future__ import annotations

import numpy as np

from mimucap.core import skeleton
from mimucap.core.bodycal import BodyCalibration, CalibrationQuality


def known_mounting_calibration(session) -> BodyCalibration:
    """A body calibration of ``session``'s simulated suit from its true mounting (heading north),
    for the segments of the session's skeleton model, one sensor each."""
    mounting = {}  # segment → (sensor, its mounting): the first sensor on each segment of the model
    for sensor, mount in session.feed.simulator.mounting.items():
        if mount.segment in session.model.segment_names:
            mounting.setdefault(mount.segment, (sensor, mount))
    return BodyCalibration(
        q_world_from_body=skeleton.q_world_from_body_facing(0.0), up_world=np.array([0.0, 0.0, 1.0]),
        sensors={segment: sensor for segment, (sensor, _m) in mounting.items()},
        q_segment_from_sensor={segment: m.q_segment_from_sensor for segment, (_s, m) in mounting.items()},
        quality=CalibrationQuality("known mounting", ()))
