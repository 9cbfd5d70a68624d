"""Small session files for the library tests (tests/io, tests/cli, tests/gui)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mimucap.core.sensor_samples import SensorSamples
from mimucap.io.library import library_fields
from mimucap.io.session import Marker, Session, make_subject, write_session


def make_session(path: Path, subject_id: str, duration_s: float = 2.0, started_utc: str = "2026-03-01T09:00:00+00:00",
                 condition: str = "", tags=(), trial: str = "", height_m: float = 1.70, body_verdict: str | None = None,
                 ) -> Path:
    """A small session file: two sensors at 50 Hz over ``duration_s``, a marker, a subject."""
    t = np.arange(0.0, duration_s + 1e-9, 0.02)
    sensors = {sid: SensorSamples(sid, t + 0.001 * k, np.arange(len(t)), acc=np.tile([0.0, 0.0, 9.81], (len(t), 1)),
                                 gyr=np.zeros((len(t), 3)), segment=segment)
               for k, (sid, segment) in enumerate((("S01", "pelvis"), ("S02", "thigh_r")))}
    metadata = {"subject": make_subject(subject_id, height_m, "left", f"notes of {subject_id}"),
                "recording": {"started_utc": started_utc},
                "library": library_fields(condition, tags, trial)}
    if body_verdict is not None:
        metadata["body_calibration"] = {"verdict": body_verdict}
    write_session(path, Session(metadata=metadata, sensors=sensors, markers=[Marker(0.5, "start walking")]))
    return path
