"""A whole guided session run on a live session without a window (no Qt): magnetometer turns,
body calibration, then recording the subject's movement.

It drives the same procedures the wizards drive (:mod:`mimucap.session.procedures.magnetometer`,
:mod:`mimucap.session.procedures.body`) over the live session's own feed, stepping a clock it
owns, so that a whole session runs faster than real time. Its subject follows the procedures'
instructions like any other (the simulated suit's does them). Used by the end-to-end accuracy
benchmark and by tests; the desktop application drives the same procedures from its wizards.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mimucap.core.bodycal import BodyCalibration
from mimucap.io.calibration_store import CalibrationStore
from mimucap.session.procedures.body import BodycalProcedure
from mimucap.session.sources.calibration_feed import LiveSessionFeed, SteppedClock
from mimucap.session.procedures.instructions import RESUME
from mimucap.session.procedures.magnetometer import MagcalProcedure
from mimucap.session.live.recorder import RecordingResult


@dataclass
class GuidedOutcome:
    """What a guided session produced: the magnetometer calibration verdicts (sensor → verdict),
    the body calibration, the recording and the clock's time when it started (s)."""

    mag_verdicts: dict[str, str]
    body_calibration: BodyCalibration
    recording: RecordingResult
    recording_started_s: float


def run_guided_session(live, clock: SteppedClock, out_path: str | Path, record_s: float,
                       store: CalibrationStore, step_s: float = 0.02,
                       markers: tuple[tuple[float, str], ...] = (),
                       on_step: Callable[[], None] | None = None, settle_s: float = 1.0,
                       subject: dict | None = None) -> GuidedOutcome:
    """Calibrate every magnetometer (one bundle, one turn about each axis), calibrate the body
    (N-pose, T-pose; its N-pose page waits until no orientation is still settling on the newly
    calibrated field), let the subject carry on and, ``settle_s`` seconds later, record
    ``record_s`` seconds of it into ``out_path`` with ``markers`` (seconds after the start,
    label) and the ``subject`` form (id, height...). ``live`` must be started on ``clock``.
    ``ValueError`` when a calibration is refused."""

    def tick() -> None:
        clock.now += step_s
        live.step()
        if on_step is not None:
            on_step()

    feed = LiveSessionFeed(live)
    try:
        magcal = MagcalProcedure(feed, live.sensor_ids, store=store)
        magcal.start()
        while magcal.phase == "recording":
            tick()
            magcal.step()
        accepted = magcal.accept()
        for sensor_id in accepted:
            live.apply_mag_calibration(magcal.outcomes[sensor_id].result.calibration, save=False)
        verdicts = {sid: outcome.verdict for sid, outcome in magcal.outcomes.items()}
        mapping = {segment: sensor for sensor, segment in live.sensor_segments.items()}
        body = BodycalProcedure(feed, mapping, height_m=live.height_m)
        body.start()
        while body.phase in ("npose", "tpose"):
            tick()
            body.step()
        if body.calibration is None:
            raise ValueError(f"the body calibration was refused: {body.refusal}")
        live.apply_body_calibration(body.calibration)
    finally:
        feed.instruct(RESUME)
        feed.close()
    for _ in range(int(round(settle_s / step_s))):
        tick()
    live.start_recording(out_path, subject)
    start = clock.now
    pending = sorted(markers)
    while clock.now - start < record_s:
        tick()
        while pending and clock.now - start >= pending[0][0]:
            live.add_marker(pending.pop(0)[1])
    return GuidedOutcome(verdicts, body.calibration, live.stop_recording(), start)
