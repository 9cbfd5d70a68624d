"""A recording run through the processing path again (no Qt).

:func:`process_session` gives either result (*as seen live* or *reprocessed*) of a session,
from what it stores of its live processing (:mod:`mimucap.session.recorded.stored_processing`),
with the calibrations :func:`mimucap.session.recorded.calibration_choice.applied_calibrations`
chooses. Review, export, the analysis and the command line all go through :func:`process_session`.
"""

from __future__ import annotations

from dataclasses import replace

from mimucap.core import phase_markers, skeleton
from mimucap.core.heading_sources import heading_coupling
from mimucap.core.pipeline.recording import PipelineOutput, process_recording
from mimucap.core.pipeline.settings import RESULT_REPROCESSED, check_result
from mimucap.io.session import Session
from mimucap.session.recorded.calibration_choice import AppliedCalibrations, applied_calibrations
from mimucap.session.recorded.stored_processing import (
    RecordedProcessing, check_body_calibration_fits, recorded_processing, session_model,
)


def process_session(session: Session, *, result: str = RESULT_REPROCESSED,
                    calibrations: AppliedCalibrations | None = None,
                    recorded: RecordedProcessing | None = None,
                    model: skeleton.SkeletonModel | None = None,
                    shoulder_sequence: str = "zxy", heading: str | None = None) -> PipelineOutput:
    """Either result of ``session`` through the processing path, with ``calibrations``
    (:func:`mimucap.session.recorded.calibration_choice.applied_calibrations` of the session when None: the
    one choice of body and magnetometer calibrations every consumer makes). The simulator's
    truth, when the session holds it, is never read. The phases its markers name as
    magnetometer calibration (:func:`off_body_windows`) make every joint angle there doubtful.
    ``heading`` (:data:`~mimucap.core.heading_modes.MODES`) replaces the recorded settings'
    heading mode when given."""
    check_result(result)
    recorded = recorded if recorded is not None else recorded_processing(session)
    if calibrations is None:
        calibrations = applied_calibrations(session)
    body = calibrations.body
    if model is None:
        model = session_model(session)[0]
    if body is not None:
        check_body_calibration_fits(body, model)
    settings = recorded.settings if heading is None else replace(recorded.settings, heading=heading)
    # as seen live, the coupling continues from where the live one stood (in the mode it ran in)
    live_state = recorded.coupling_state if settings.heading == recorded.settings.heading else None
    return process_recording(
        session.sensors, model, result=result, mag_calibrations=calibrations.magnetometer, body_calibration=body,
        sensor_segments=recorded.sensor_segments, settings=settings,
        initial_states=recorded.initial_states, time_offset_s=recorded.time_offset_s,
        shoulder_sequence=shoulder_sequence, off_body_s=off_body_windows(session),
        coupling=heading_coupling(settings, result, live_state))


def off_body_windows(session: Session) -> list[tuple[float, float]]:
    """The time windows (s) its markers name as a magnetometer calibration phase
    (:func:`mimucap.core.phase_markers.off_body_windows`)."""
    end = max((float(s.t_s[-1]) for s in session.sensors.values() if len(s.t_s)), default=0.0)
    return phase_markers.off_body_windows(session.markers, end + 1.0)
