"""The processing path over a whole recording: the batch form (no I/O, no Qt).

:func:`process_recording` runs every sensor's samples through its chain (:mod:`.chain`), forms
every sensor at the reference sensor's sample instants (:mod:`.instants`), turns them into
segment orientations (:mod:`.segments`) and those into the joint angles of the measured joints
with the reasons each may be wrong (:mod:`.joint_angles`). :class:`~mimucap.core.pipeline.live.LivePipeline`
is the same path fed block by block; from the same filter states the two give the same numbers.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from mimucap.core import bodycal, skeleton
from mimucap.core.heading_modes import MODE_COUPLED
from mimucap.core.fusion.state import FusionState
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.pipeline.chain import SensorChain
from mimucap.core.pipeline.instants import SensorTrack, reference_sensor, sensors_at_instants
from mimucap.core.pipeline.joint_angles import joint_reasons, measured_joint_angles, off_body, singular_reasons
from mimucap.core.pipeline.segments import JointCoupling, SegmentStage
from mimucap.core.pipeline.settings import (
    DEFAULT_PIPELINE_SETTINGS, RESULT_REPROCESSED, PipelineSettings, check_result,
)
from mimucap.core.sensor_samples import SensorSamples

POSE_BODY_CALIBRATION = "body calibration"
POSE_SENSOR_AXES = "sensor axes (no body calibration)"


@dataclass
class PipelineOutput:
    """What the processing path gives for a recording.

    ``t_s`` (T,) pose instants (the reference sensor's sample times, s); ``q_world_from_segment``
    segment → (T, 4); ``angles_deg`` column → (T,) degrees (:func:`skeleton.joint_angle_columns`);
    ``q_world_from_sensor`` sensor → (N, 4) on that sensor's own ``t_s``; ``flags`` sensor →
    (N,) filter flags; ``result`` one of :data:`~mimucap.core.pipeline.settings.RESULTS`;
    ``pose_source`` :data:`POSE_BODY_CALIBRATION` or :data:`POSE_SENSOR_AXES`;
    ``reference_sensor`` the sensor whose instants are the poses'. ``doubt`` sensor → (N,) and
    ``joint_doubt`` joint → (T,) (the joints of ``angles_deg``): the reasons each may be wrong
    (:mod:`~mimucap.core.pipeline.doubt_reasons`, 0 where trustworthy). ``heading_source``
    sensor → (T,) where each sensor's heading came from at the pose instants, as the coupling
    chose it (:data:`~mimucap.core.heading_sources.SOURCE_NAMES`; empty without one), and
    ``heading_mode`` the settings' mode (:data:`~mimucap.core.heading_modes.MODES`).
    """

    result: str
    t_s: np.ndarray
    q_world_from_segment: dict[str, np.ndarray]
    angles_deg: dict[str, np.ndarray]
    q_world_from_sensor: dict[str, np.ndarray]
    flags: dict[str, np.ndarray]
    pose_source: str
    reference_sensor: str | None
    problems: list[str] = field(default_factory=list)
    doubt: dict[str, np.ndarray] = field(default_factory=dict)
    joint_doubt: dict[str, np.ndarray] = field(default_factory=dict)
    heading_source: dict[str, np.ndarray] = field(default_factory=dict)
    heading_mode: str = MODE_COUPLED


def process_recording(streams: Mapping[str, SensorSamples], model: skeleton.SkeletonModel, *,
                      result: str = RESULT_REPROCESSED,
                      mag_calibrations: Mapping[str, MagCalibration] | None = None,
                      body_calibration: bodycal.BodyCalibration | None = None,
                      sensor_segments: Mapping[str, str] | None = None,
                      settings: PipelineSettings = DEFAULT_PIPELINE_SETTINGS,
                      initial_states: Mapping[str, FusionState] | None = None,
                      time_offset_s: float = 0.0,
                      shoulder_sequence: str = "zxy",
                      off_body_s: Sequence[tuple[float, float]] = (),
                      coupling: JointCoupling | None = None) -> PipelineOutput:
    """Run a whole recording through the processing path (see the module docstring).

    ``streams``: sensor id → its samples (``t_s`` (N,) s; ``acc``, ``gyr``, ``mag_uT`` raw µT,
    ``q_world_from_sensor`` the device's own orientation, arrays or None; the other fields are
    not used). ``sensor_segments``: sensor → segment, used without a body calibration.
    ``result``: :data:`~mimucap.core.pipeline.settings.RESULT_LIVE` or
    :data:`~mimucap.core.pipeline.settings.RESULT_REPROCESSED`. ``initial_states`` (the live
    filter's state at the start) and ``time_offset_s`` continue the live filter: it runs on
    ``t_s + time_offset_s``, the clock the live view ran it on (both results start from that
    prior). A sensor that can give no orientation is left out and named in ``problems``.
    ``off_body_s``: time windows (s) in which the sensors are not on the body (the magnetometer
    turns): every joint angle there is doubtful, and so until each sensor first rests after a
    window (strapped back on). ``coupling``: the joint coupling of the segment stage
    (:class:`~mimucap.core.pipeline.segments.JointCoupling`), or None.
    """
    check_result(result)
    mag_calibrations = dict(mag_calibrations or {})
    initial_states = dict(initial_states or {})
    q_sensor: dict[str, np.ndarray] = {}
    flags: dict[str, np.ndarray] = {}
    reasons: dict[str, np.ndarray] = {}
    tracks: dict[str, SensorTrack] = {}
    problems: list[str] = []
    for sensor_id, stream in streams.items():
        t = np.asarray(stream.t_s, dtype=np.float64)
        if len(t) == 0:
            continue
        try:
            chain = SensorChain(sensor_id, mag_calibrations.get(sensor_id), settings,
                                state=initial_states.get(sensor_id))
            out = chain.process(stream.with_times(t + time_offset_s), result)
        except ValueError as error:
            problems.append(str(error))
            continue
        q_sensor[sensor_id], flags[sensor_id], reasons[sensor_id] = out.q_world_from_sensor, out.flags, out.doubt
        tracks[sensor_id] = SensorTrack.finite(stream.t_s, out.q_world_from_sensor, out.flags, out.heading_std_rad,
                                               out.q_world_from_sensor_no_mag,
                                               out.mag_uT if chain.mag_calibration is not None else None)
    stage = SegmentStage(model, body_calibration, sensor_segments or {}, coupling)
    segments = stage.segment_of_sensor
    tracks = {sid: track for sid, track in tracks.items() if sid in segments and len(track.t_s)}
    source = POSE_BODY_CALIBRATION if body_calibration is not None else POSE_SENSOR_AXES
    reference = reference_sensor(model, segments, list(tracks))
    if reference is None:
        return PipelineOutput(result, np.zeros(0), {}, {}, q_sensor, flags, source, None, problems, reasons,
                              heading_mode=settings.heading)
    t_pose = tracks[reference].t_s
    instants, q_segments = stage.coupled_segments(sensors_at_instants(t_pose, tracks))
    q_segments = q_segments or {}
    angles = skeleton.joint_angles_deg(model, q_segments, shoulder_sequence) if len(t_pose) else {}
    angles = measured_joint_angles(model, angles, {segments[sid] for sid in tracks})
    if off_body_s:
        fusion = settings.fusion
        for sid, stream in streams.items():
            if sid in reasons:
                reasons[sid] = reasons[sid] | off_body(stream.t_s, off_body_s, stream.gyr, fusion.rest_max_rate_rad_s,
                                                       fusion.rest_time_s)
    joint_doubt = joint_reasons(model, t_pose, segments, {sid: (np.asarray(streams[sid].t_s), reasons[sid])
                                                         for sid in tracks},
                                body_calibration, settings.fusion.max_gap_s, instants.heading_source)
    joint_doubt = {joint: value | singular_reasons(model, joint, angles, shoulder_sequence)
                   for joint, value in joint_doubt.items() if any(c.startswith(joint + "_") for c in angles)}
    return PipelineOutput(result, t_pose, q_segments, angles, q_sensor, flags, source, reference, problems,
                          reasons, joint_doubt, dict(instants.heading_source), settings.heading)
