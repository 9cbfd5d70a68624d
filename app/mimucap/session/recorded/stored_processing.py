"""What a recording stores of its processing, and how it is read back (no Qt).

A recording stores everything :func:`mimucap.core.pipeline.recording.process_recording` needs to
recompute it: the raw samples (the session file's sensor streams), the magnetometer
calibrations applied (``calibrations["magnetometer"]``, sensor id → the calibration's JSON),
the body calibration (``calibrations["body"]``), the filter settings, the live filter's state
at the start of the recording and the clock offset the live view ran it on
(``metadata["pipeline"]``), the skeleton model, the subject's height and the software version.
:func:`recording_record` builds those entries for the recorder; :func:`recorded_processing`
reads them back (and says what an older recording lacks). Running a recording through the
processing path again is :mod:`mimucap.session.recorded.reprocessing`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from mimucap import __version__
from mimucap.core import bodycal, skeleton
from mimucap.core.fusion import FusionState
from mimucap.core.heading_sources import coupling_state_from_dict
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.pipeline.settings import PipelineSettings, state_from_dict
from mimucap.io.calibration_store import body_calibration_of, magnetometer_calibrations_of, session_calibrations
from mimucap.io.session import Session

PIPELINE_KEY = "pipeline"
#: The live heading coupling's state at the recording's start, in ``metadata["pipeline"]``.
COUPLING_STATE_KEY = "live_heading_coupling"


def recording_record(*, mag_calibrations: Mapping[str, MagCalibration],
                     body_calibration: bodycal.BodyCalibration | None, settings: PipelineSettings,
                     filter_states: Mapping[str, Any], time_offset_s: float,
                     coupling_state: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The metadata entries a recording carries so that it can be recomputed (see the module
    docstring): ``{"calibrations": {...}, "pipeline": {...}, "mimucap_version": ...}``;
    ``coupling_state`` where the live heading coupling's averages stood
    (:meth:`~mimucap.core.heading_sources.HeadingCoupling.state_to_dict`, on the recording's clock)."""
    pipeline = {"settings": settings.to_dict(), "live_filter_states": dict(filter_states),
                "live_time_offset_s": float(time_offset_s)}
    if coupling_state is not None:
        pipeline[COUPLING_STATE_KEY] = dict(coupling_state)
    return {
        "calibrations": session_calibrations(mag_calibrations, body_calibration),
        PIPELINE_KEY: pipeline,
        "mimucap_version": __version__,
    }


@dataclass
class RecordedProcessing:
    """What a session says about how it was processed live.

    ``mag_calibrations`` sensor → calibration; ``body_calibration`` or None; ``settings`` the
    filter settings; ``initial_states`` sensor → the live filter's state at the recording's
    start; ``coupling_state`` the live heading coupling's there (None: none stored);
    ``time_offset_s`` (s) the live clock minus the recording's; ``sensor_segments``
    sensor → segment; ``missing`` what an older recording does not store (one sentence each).
    """

    mag_calibrations: dict[str, MagCalibration] = field(default_factory=dict)
    body_calibration: bodycal.BodyCalibration | None = None
    settings: PipelineSettings = PipelineSettings()
    initial_states: dict[str, FusionState] = field(default_factory=dict)
    coupling_state: dict[str, Any] | None = None
    time_offset_s: float = 0.0
    sensor_segments: dict[str, str] = field(default_factory=dict)
    missing: list[str] = field(default_factory=list)


def recorded_processing(session: Session, origin: str = "the session") -> RecordedProcessing:
    """Read the processing a session stores (``ValueError`` naming ``origin`` when an entry is
    malformed); an older recording without some entries still opens, and ``missing`` says
    what it lacks."""
    meta = session.metadata
    found = RecordedProcessing(sensor_segments={sid: s.segment for sid, s in session.sensors.items() if s.segment})
    found.mag_calibrations = magnetometer_calibrations_of(session.calibrations, origin)
    names_only = meta.get("mag_calibrated_sensors") or []
    lost = [sid for sid in names_only if sid not in found.mag_calibrations]
    if lost:
        found.missing.append(f"the magnetometer calibrations applied live ({', '.join(lost)}) are not stored "
                             "(an older recording): their raw magnetometer samples are used")
    found.body_calibration = body_calibration_of(session.calibrations, meta, origin)
    pipeline = meta.get(PIPELINE_KEY)
    if isinstance(pipeline, Mapping):
        found.settings = PipelineSettings.from_dict(pipeline.get("settings"), f"{origin}: pipeline settings")
        for sensor_id, state in (pipeline.get("live_filter_states") or {}).items():
            found.initial_states[sensor_id] = state_from_dict(state, f"{origin}: live filter state of {sensor_id}")
        found.time_offset_s = float(pipeline.get("live_time_offset_s") or 0.0)
        found.coupling_state = coupling_state_from_dict(pipeline.get(COUPLING_STATE_KEY),
                                                        f"{origin}: live heading coupling state")
    elif session.sensors:
        found.missing.append("the filter settings and the live filter's state are not stored (an older "
                             "recording): 'as seen live' restarts the filter at the recording's start")
    return found


def session_model(session: Session) -> tuple[skeleton.SkeletonModel, float]:
    """The session's skeleton model and subject height (m)."""
    meta = session.metadata
    subject = meta.get("subject") or {}
    model = skeleton.load_model(str(meta.get("skeleton_model") or "ten_segment"))
    height = float(meta.get("height_m") or subject.get("height_m") or 1.75)
    return model, height


def check_body_calibration_fits(calibration: bodycal.BodyCalibration, model: skeleton.SkeletonModel) -> None:
    """``ValueError`` naming the segments of ``calibration`` that ``model`` lacks (the live
    session and the reprocessing refuse such a calibration alike)."""
    unknown = [s for s in calibration.segments if s not in model.segment_names]
    if unknown:
        raise ValueError(f"the body calibration has segments the {model.name} model lacks: {', '.join(unknown)}")
