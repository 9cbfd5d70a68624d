"""One processing path per sensor, from raw samples to joint angles (no I/O, no Qt).

Every consumer (the live view, both calibration wizards, the recorder's review, export and the
commands ``fuse``, ``bodycal``, ``angles``) runs its data through these functions:

1. **Magnetometer calibration** (Choe, Zhao, Qiu, So, "Study of calibration method of low-cost
   MEMS magnetometer"): ``mag_cal_uT = A⁻¹ · (mag_raw_uT − b)`` per sensor
   (:class:`~mimucap.core.magcal.MagCalibration`).
2. **Orientation filter** (the error-state Kalman filter of Zhang, Gao, Zhou, "Head attitude
   sensing algorithm based on IMU in VR device", :mod:`mimucap.core.fusion`) giving
   ``q_world_from_sensor`` (world ENU, scalar first) for every sample; a device that fuses on
   board sends it instead. Two results exist: :data:`RESULT_LIVE` is the forward filter, as the
   live view ran it (continuing from the filter state it had when a recording started);
   :data:`RESULT_REPROCESSED` adds the Rauch-Tung-Striebel smoother over the whole recording
   (past and future data; what Xsens calls HD reprocessing).
3. **Poses at one instant**: a pose is formed at a sample instant ``t`` of the *reference
   sensor* (the pelvis sensor when there is one) from every sensor's orientation at that same
   instant (exact at its own sample times, slerp between two of its samples, held after its
   last one, absent before its first: :func:`orientation_at`).
4. **Body calibration** (Podoprosvetov, Aliseychik, Orlov, Rebrik, "Calibration algorithm for
   MIMU sensors group"): ``q_world_from_segment = q_world_from_sensor ⊗ q_sensor_from_segment``;
   without one, each assigned sensor's axes stand for its segment's. Segments without a sensor
   follow their parents; a root without a sensor faces north.
5. **Joint angles** (ISB, :func:`mimucap.core.skeleton.joint_angles_deg`).

Beside each orientation the path keeps why it may be wrong (:mod:`mimucap.core.doubt`: reason
bits per sensor and sample, from the filter's covariance and flags, the field against the
magnetometer calibration, lost samples, an on-board calibration status), and every joint angle
inherits the reasons of the sensors of its two segments.

:class:`LivePipeline` is the online form (block by block, as samples arrive);
:func:`process_recording` the batch form. Fed the same samples from the same filter state they
give the same numbers, which is how a recording's *as seen live* result reproduces the screen.

Times ``t_s`` are float64 seconds on one clock per call; units are SI with the magnetic field
in µT.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from mimucap.core import (
    bodycal,
    doubt,
    heading_modes,
    heading_sources,
    rotation,
    skeleton,
)
from mimucap.core.fusion import (
    DEFAULT_FUSION_PARAMS,
    FusionParams,
    FusionState,
    OrientationEKF,
    update_together,
)
from mimucap.core.magcal import MagCalibration
from mimucap.core.samples import SensorSamples

RESULT_LIVE = "live"
RESULT_REPROCESSED = "reprocessed"
#: How screens and file headers name each result.
RESULT_LABELS = {RESULT_LIVE: "as seen live (forward filter)",
                 RESULT_REPROCESSED: "reprocessed (filter smoothed with past and future data)"}
RESULTS = (RESULT_LIVE, RESULT_REPROCESSED)

POSE_BODY_CALIBRATION = "body calibration"
POSE_SENSOR_AXES = "sensor axes (no body calibration)"

#: A sensor silent for longer than this (s) no longer holds back a live pose (it is held).
HOLD_BACK_LIMIT_S = 1.0


@dataclass(frozen=True)
class PipelineSettings:
    """Settings of the processing path that a recording stores so that it can be recomputed.

    ``fusion``: the orientation filter's parameters (units in their names); ``heading``: where
    the sensors' headings come from (:data:`~mimucap.core.heading_modes.MODES`).
    """

    fusion: FusionParams = DEFAULT_FUSION_PARAMS
    heading: str = heading_modes.MODE_COUPLED

    def __post_init__(self) -> None:
        heading_modes.check_mode(self.heading)

    @property
    def uses_magnetometers(self) -> bool:
        return self.heading != heading_modes.MODE_NO_MAGNETOMETER

    def to_dict(self) -> dict[str, Any]:
        return {"fusion": asdict(self.fusion), "heading": self.heading}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any] | None, origin: str = "pipeline settings") -> PipelineSettings:
        """Inverse of :meth:`to_dict`; an unknown filter parameter name raises ``ValueError``."""
        if not data:
            return cls()
        try:
            fusion = FusionParams(**dict(data.get("fusion") or {}))
            return cls(fusion=fusion, heading=str(data.get("heading", heading_modes.MODE_COUPLED)))
        except (TypeError, ValueError) as error:
            raise ValueError(f"{origin}: {error}") from None


DEFAULT_PIPELINE_SETTINGS = PipelineSettings()


def check_result(result: str) -> str:
    if result not in RESULTS:
        raise ValueError(f"unknown result {result!r}; use one of {', '.join(RESULTS)}")
    return result


# --------------------------------------------------------------------------------------------
# Filter states that a recording carries (the live filter at its start)
# --------------------------------------------------------------------------------------------

def state_to_dict(state: FusionState) -> dict[str, list]:
    """A one-sensor :class:`FusionState` as JSON-ready lists."""
    return {"q_world_from_sensor": state.q_world_from_sensor[0].tolist(), "bias_rad_s": state.bias_rad_s[0].tolist(),
            "cov": state.cov[0].tolist(), "aux": state.aux[0].tolist()}


def state_from_dict(data: Mapping[str, Any], origin: str) -> FusionState:
    """Inverse of :func:`state_to_dict`; ``ValueError`` naming ``origin`` when malformed."""
    template = FusionState.new(1)
    try:
        arrays = [np.asarray(data[name], dtype=np.float64)[None]
                  for name in ("q_world_from_sensor", "bias_rad_s", "cov", "aux")]
    except (KeyError, TypeError, ValueError) as error:
        raise ValueError(f"{origin}: malformed filter state ({error!r})") from None
    for array, name, like in zip(arrays, ("q", "bias", "cov", "aux"),
                                 (template.q_world_from_sensor, template.bias_rad_s, template.cov, template.aux)):
        if array.shape != like.shape or not np.all(np.isfinite(array)):
            raise ValueError(f"{origin}: filter state {name} must be finite with shape {like.shape[1:]}")
    return FusionState(*arrays)


# --------------------------------------------------------------------------------------------
# Steps 1-2, online: one chain per sensor
# --------------------------------------------------------------------------------------------

class SensorChain:
    """Magnetometer calibration and orientation filter of one sensor, fed block by block.

    The filter is created on the first block with a gyroscope (using the magnetometer if that
    block has one). A new magnetometer calibration keeps the running filter's orientation and
    gyro bias but reopens their uncertainty, with the heading unknown
    (:meth:`~mimucap.core.fusion.OrientationEKF.magnetometer_changed`): the corrected field then
    sets the heading within a second, where a new filter, aligned on one accelerometer sample
    of a sensor that is being strapped back on and with its gyro bias forgotten, took tens of
    seconds to settle (and a body calibration made meanwhile kept its heading error).
    """

    def __init__(self, sensor_id: str, mag_calibration: MagCalibration | None = None,
                 settings: PipelineSettings = DEFAULT_PIPELINE_SETTINGS) -> None:
        self.sensor_id = sensor_id
        self.settings = settings
        self.mag_calibration = mag_calibration
        self.ekf: OrientationEKF | None = None
        self.onboard = False
        self._doubt: doubt.SensorDoubt | None = None

    def set_mag_calibration(self, calibration: MagCalibration | None) -> None:
        if calibration is not None and calibration.sensor_id != self.sensor_id:
            raise ValueError(f"the magnetometer calibration of sensor {calibration.sensor_id} cannot be "
                             f"used for sensor {self.sensor_id}")
        self.mag_calibration = calibration
        if self.ekf is not None and self.ekf.use_mag:
            self.ekf.magnetometer_changed()
        if self._doubt is not None:
            self._doubt.set_mag_calibration(calibration)

    def doubt(self) -> doubt.SensorDoubt:
        """What keeps this sensor's reasons for doubt (:mod:`mimucap.core.doubt`) across blocks."""
        if self._doubt is None or self._doubt.onboard != self.onboard:
            self._doubt = doubt.SensorDoubt(self.settings.fusion, self.mag_calibration, onboard=self.onboard)
        return self._doubt

    def doubt_terms(self, t_s: np.ndarray, seq: np.ndarray | None, gyr: np.ndarray | None,
                    mag_uT: np.ndarray | None, q_world_from_sensor: np.ndarray, flags: np.ndarray,
                    status: np.ndarray | None = None) -> doubt.DoubtTerms:
        """The error terms of a block this chain has just fused (or received fused on board:
        ``status`` its calibration status), with the filter's covariance after it."""
        cov = None if self.onboard or self.ekf is None else self.ekf.state.cov[0]
        return self.doubt().update(t_s, seq, gyr, mag_uT, q_world_from_sensor, flags, cov, status)

    def calibrated_mag(self, mag_raw_uT: np.ndarray | None) -> np.ndarray | None:
        """``mag_raw_uT`` (N, 3) corrected by this sensor's calibration (raw when it has none)."""
        if mag_raw_uT is None or self.mag_calibration is None:
            return mag_raw_uT
        return self.mag_calibration.apply(mag_raw_uT, self.sensor_id)

    def filter_for(self, has_mag: bool) -> OrientationEKF:
        if self.ekf is None:
            self.ekf = OrientationEKF(self.settings.fusion, use_mag=has_mag)
        return self.ekf

    def state_snapshot(self) -> dict[str, list] | None:
        """The filter state now (JSON-ready), ``None`` before the filter has started."""
        return None if self.ekf is None else state_to_dict(self.ekf.state)


@dataclass
class ChainInput:
    """One block of one sensor for :func:`run_chains`: ``t_s`` (N,), ``gyr`` (N, 3) rad/s,
    ``acc`` (N, 3) m/s² or None, ``mag_uT`` (N, 3) calibrated µT or None."""

    chain: SensorChain
    t_s: np.ndarray
    gyr: np.ndarray
    acc: np.ndarray | None
    mag_uT: np.ndarray | None


@dataclass
class ChainOutput:
    """Filter outputs of one :class:`ChainInput`: ``q_world_from_sensor`` (N, 4) (NaN rows before
    the filter has an orientation) and ``flags`` (N,) uint8 (:data:`~mimucap.core.fusion.FLAG_NAMES`)."""

    sensor_id: str
    t_s: np.ndarray
    q_world_from_sensor: np.ndarray
    flags: np.ndarray


def run_chains(inputs: Sequence[ChainInput]) -> list[ChainOutput]:
    """Run each input through its sensor's filter, in order (outputs in the inputs' order).

    Sensors whose blocks have the same length and channels and whose filters the same settings
    go through the filter in one call (:func:`~mimucap.core.fusion.update_together`): for a
    17-sensor suit one kernel call per poll instead of 17, with the same numbers. A sensor with
    more than one block has them fused one after the other."""
    for item in inputs:
        item.chain.filter_for(item.mag_uT is not None)
    blocks_of = Counter(id(item.chain) for item in inputs)
    groups: dict[object, list[int]] = {}
    for index, item in enumerate(inputs):
        shares = blocks_of[id(item.chain)] == 1  # a filter appears once in a call
        key = ((len(item.t_s), item.acc is None, item.mag_uT is None, item.chain.ekf.grouping_key)
               if shares else ("alone", index))
        groups.setdefault(key, []).append(index)
    outputs: list[ChainOutput | None] = [None] * len(inputs)
    for indices in sorted(groups.values()):
        group = [inputs[i] for i in indices]

        def stacked(name: str):
            first = getattr(group[0], name)
            return None if first is None else np.stack([getattr(item, name) for item in group])

        result = update_together([item.chain.ekf for item in group], stacked("t_s"), stacked("gyr"),
                                 stacked("acc"), stacked("mag_uT"))
        for row, index in enumerate(indices):
            item = inputs[index]
            outputs[index] = ChainOutput(item.chain.sensor_id, item.t_s, result.q_world_from_sensor[row],
                                         result.flags[row])
    return outputs  # type: ignore[return-value]


# --------------------------------------------------------------------------------------------
# Step 2, batch
# --------------------------------------------------------------------------------------------

#: Samples the filter is fed at a time when a recording is processed, so that its covariance is
#: read as often as the live view reads it between blocks (the numbers are those of one call).
FILTER_BLOCK_SAMPLES = 32


@dataclass
class SensorTrack:
    """One sensor's whole recording through steps 1-2: ``q_world_from_sensor`` (N, 4), the
    filter's ``flags`` (N,) (:data:`~mimucap.core.fusion.FLAG_NAMES`; zeros for an on-board
    orientation) and ``doubt`` (N,) the reasons it may be wrong (:mod:`mimucap.core.doubt`)."""

    q_world_from_sensor: np.ndarray
    flags: np.ndarray
    doubt: np.ndarray


def sensor_orientation(t_s: np.ndarray, gyr_rad_s: np.ndarray | None, acc_m_s2: np.ndarray | None,
                       mag_raw_uT: np.ndarray | None, q_onboard: np.ndarray | None, *, sensor_id: str,
                       result: str = RESULT_REPROCESSED, mag_calibration: MagCalibration | None = None,
                       settings: PipelineSettings = DEFAULT_PIPELINE_SETTINGS,
                       initial_state: FusionState | None = None, seq: np.ndarray | None = None,
                       status: np.ndarray | None = None) -> SensorTrack:
    """One sensor's whole recording through the magnetometer calibration and the filter.

    ``t_s`` (N,) s; ``gyr_rad_s``, ``acc_m_s2`` (N, 3) or None; ``mag_raw_uT`` (N, 3) raw µT
    (calibrated here with ``mag_calibration``) or None; ``q_onboard`` (N, 4) the device's own
    orientation, used as it is when given (``status`` (N, 4) its calibration status, or None);
    ``seq`` (N,) the sequence numbers (their gaps are lost samples). ``result``:
    :data:`RESULT_LIVE` runs the forward filter from ``initial_state`` (the live filter's state
    when the recording started; a fresh filter when None, as the live view starts one),
    :data:`RESULT_REPROCESSED` the forward filter plus smoother with the same prior (what the
    live filter had learnt before the recording: gyro bias, heading); the reasons for doubt of
    the reprocessed result also reach back from later samples (:meth:`~mimucap.core.doubt.
    DoubtTerms.smoothed`). ``ValueError`` naming the sensor when it has neither an orientation
    nor a gyroscope.
    """
    check_result(result)
    n = len(t_s)
    chain = SensorChain(sensor_id, mag_calibration, settings)
    if q_onboard is not None:
        chain.onboard = True
        q = np.asarray(q_onboard, dtype=np.float64)
        flags = np.zeros(n, dtype=np.uint8)
        terms = chain.doubt_terms(t_s, seq, gyr_rad_s, None, q, flags, status)
        return SensorTrack(q, flags, terms.reasons())
    if gyr_rad_s is None:
        raise ValueError(f"sensor {sensor_id}: neither an on-board orientation nor a gyroscope to fuse")
    mag = chain.calibrated_mag(mag_raw_uT) if settings.uses_magnetometers else None
    chain.ekf = OrientationEKF(settings.fusion, use_mag=mag is not None, state=initial_state)
    q_parts, flag_parts, term_parts = [], [], []
    for start in range(0, n, FILTER_BLOCK_SAMPLES):
        rows = slice(start, start + FILTER_BLOCK_SAMPLES)
        block = [None if channel is None else channel[rows] for channel in (t_s, gyr_rad_s, acc_m_s2, mag, seq)]
        out = chain.ekf.update_batch(*block[:4])
        q_parts.append(out.q_world_from_sensor)
        flag_parts.append(out.flags)
        term_parts.append(chain.doubt_terms(block[0], block[4], block[1], block[3], out.q_world_from_sensor,
                                            out.flags))
    terms = doubt.DoubtTerms.joined(term_parts)
    if result == RESULT_LIVE:
        if not n:
            return SensorTrack(np.zeros((0, 4)), np.zeros(0, dtype=np.uint8), np.zeros(0, dtype=doubt.DOUBT_DTYPE))
        return SensorTrack(np.concatenate(q_parts), np.concatenate(flag_parts), terms.reasons())
    from mimucap.core.fusion import fuse_offline

    out = fuse_offline(t_s, gyr_rad_s, acc_m_s2, mag, params=settings.fusion, use_mag=mag is not None,
                       state=initial_state)
    intervals = np.diff(np.asarray(t_s, dtype=np.float64))
    intervals = intervals[intervals > 0]
    step = float(np.median(intervals)) if len(intervals) else 0.01
    terms = terms.smoothed(doubt.smoother_memory_s(settings.fusion, step))
    return SensorTrack(np.asarray(out.q_world_from_sensor), np.asarray(out.flags), terms.reasons())


# --------------------------------------------------------------------------------------------
# Steps 3-5: poses at one instant, segments, joint angles
# --------------------------------------------------------------------------------------------

def orientation_at(t_query: np.ndarray, t_s: np.ndarray, q: np.ndarray) -> np.ndarray:
    """One sensor's orientation at the instants ``t_query`` (M,) from its samples ``(t_s (N,),
    q (N, 4))`` (finite rows, increasing times): the sample itself at a sample time, slerp
    between the two samples around ``t``, the last sample after the last time, NaN before the
    first. (M, 4)."""
    t_query = np.asarray(t_query, dtype=np.float64)
    out = np.full(t_query.shape + (4,), np.nan)
    if len(t_s) == 0:
        return out
    after = np.searchsorted(t_s, t_query, side="right")  # first sample later than t
    index = after - 1
    known = index >= 0
    exact_or_held = known & ((index == len(t_s) - 1) | (t_s[np.clip(index, 0, len(t_s) - 1)] == t_query))
    out[exact_or_held] = q[index[exact_or_held]]
    between = known & ~exact_or_held
    if np.any(between):
        i = index[between]
        fraction = (t_query[between] - t_s[i]) / (t_s[i + 1] - t_s[i])
        out[between] = rotation.slerp(q[i], q[i + 1], fraction)
    return out


def finite_track(t_s: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows of a sensor's orientation track that hold an orientation."""
    keep = np.isfinite(q).all(axis=1)
    return np.asarray(t_s)[keep], np.asarray(q)[keep]


def reference_sensor(model: skeleton.SkeletonModel, segment_of_sensor: Mapping[str, str],
                     available: Sequence[str]) -> str | None:
    """The sensor whose sample instants are the pose instants: the root segment's sensor, else
    the first segment's (model order) that has one among ``available``; ``None`` without any."""
    by_segment = {segment: sensor for sensor, segment in segment_of_sensor.items() if sensor in available}
    for name in model.segment_names:
        if name in by_segment:
            return by_segment[name]
    return None


def one_sensor_per_segment(sensor_segments: Mapping[str, str | None]) -> dict[str, str]:
    """``sensor_segments`` (sensor id → segment) with each segment carried by one sensor, the
    first in the mapping's order (a recording made when two sensors could share a segment, e.g.
    the simulated suit's second pelvis unit, keeps its first); unassigned sensors are left out."""
    kept: dict[str, str] = {}
    for sensor, segment in sensor_segments.items():
        if segment is not None and segment not in kept.values():
            kept[sensor] = segment
    return kept


def assignment_of(body_calibration: bodycal.BodyCalibration | None,
                  sensor_segments: Mapping[str, str]) -> dict[str, str]:
    """Sensor id → segment as the pose uses it: the body calibration's when there is one, else
    ``sensor_segments`` with one sensor per segment (:func:`one_sensor_per_segment`)."""
    if body_calibration is not None:
        return {sensor: segment for segment, sensor in body_calibration.sensors.items()}
    return one_sensor_per_segment(sensor_segments)


def segments_from_sensors(model: skeleton.SkeletonModel, q_world_from_sensor: Mapping[str, np.ndarray],
                          body_calibration: bodycal.BodyCalibration | None,
                          sensor_segments: Mapping[str, str]) -> dict[str, np.ndarray] | None:
    """Every segment's ``q_world_from_segment`` (..., 4) from its sensors' orientations at the
    same instants (step 4). Rows where a sensor has no orientation (NaN) leave its segment to
    follow its parent (a root without one faces north); ``None`` when no assigned sensor has
    any orientation."""
    if body_calibration is not None:
        found = bodycal.segment_orientations(body_calibration, q_world_from_sensor, require_all=False, allow_nan=True)
    else:
        found = {segment: np.asarray(q_world_from_sensor[sensor], dtype=np.float64)
                 for sensor, segment in one_sensor_per_segment(sensor_segments).items()
                 if sensor in q_world_from_sensor and segment in model.segment_names}
    if not found:
        return None
    north = np.broadcast_to(skeleton.q_world_from_body_facing(0.0), next(iter(found.values())).shape).copy()
    result: dict[str, np.ndarray] = {}
    for segment in model.segments:
        fallback = north if segment.parent is None else result[segment.parent]
        own = found.get(segment.name)
        if own is None:
            result[segment.name] = fallback
            continue
        missing = ~np.isfinite(own).all(axis=-1)
        if np.any(missing):
            own = own.copy()
            own[missing] = fallback[missing]
        result[segment.name] = own
    return result


@dataclass
class PipelineOutput:
    """What the processing path gives for a recording.

    ``t_s`` (T,) pose instants (the reference sensor's sample times, s); ``q_world_from_segment``
    segment → (T, 4); ``angles_deg`` column → (T,) degrees (:func:`skeleton.joint_angle_columns`);
    ``q_world_from_sensor`` sensor → (N, 4) on that sensor's own ``t_s``; ``flags`` sensor →
    (N,) filter flags; ``result`` one of :data:`RESULTS`; ``pose_source`` :data:`POSE_BODY_CALIBRATION`
    or :data:`POSE_SENSOR_AXES`; ``reference_sensor`` the sensor whose instants are the poses'.
    ``doubt`` sensor → (N,) and ``joint_doubt`` joint → (T,) (the joints of ``angles_deg``): the
    reasons each may be wrong (:mod:`mimucap.core.doubt`, 0 where trustworthy).
    ``heading_source`` sensor → (T,) where each sensor's heading came from at the pose instants
    (:data:`~mimucap.core.heading_sources.SOURCE_NAMES`), ``heading_mode`` the mode chosen.
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
    heading_mode: str = heading_modes.MODE_COUPLED


def process_recording(streams: Mapping[str, SensorSamples], model: skeleton.SkeletonModel, *,
                      result: str = RESULT_REPROCESSED,
                      mag_calibrations: Mapping[str, MagCalibration] | None = None,
                      body_calibration: bodycal.BodyCalibration | None = None,
                      sensor_segments: Mapping[str, str] | None = None,
                      settings: PipelineSettings = DEFAULT_PIPELINE_SETTINGS,
                      initial_states: Mapping[str, FusionState] | None = None,
                      time_offset_s: float = 0.0,
                      shoulder_sequence: str = "zxy",
                      off_body_s: Sequence[tuple[float, float]] = ()) -> PipelineOutput:
    """Run a whole recording through the processing path (see the module docstring).

    ``streams``: sensor id → its samples (``t_s`` (N,) s; ``acc``, ``gyr``, ``mag_uT`` raw µT,
    ``q_world_from_sensor`` the device's own orientation, arrays or None; the other fields are
    not used). ``sensor_segments``: sensor → segment, used
    without a body calibration. ``initial_states`` (the live filter's state at the start) and
    ``time_offset_s`` continue the live filter: it runs on ``t_s + time_offset_s``, the clock the
    live view ran it on (both results start from that prior). A sensor that can give no
    orientation is left out and named in ``problems``. ``off_body_s``: time windows (s) in
    which the sensors are not on the body (the magnetometer turns): every joint angle there is
    doubtful, and so until each sensor first rests after a window (strapped back on).
    """
    check_result(result)
    mag_calibrations = dict(mag_calibrations or {})
    initial_states = dict(initial_states or {})
    q_sensor: dict[str, np.ndarray] = {}
    flags: dict[str, np.ndarray] = {}
    reasons: dict[str, np.ndarray] = {}
    problems: list[str] = []
    for sensor_id, stream in streams.items():
        t = np.asarray(stream.t_s, dtype=np.float64)
        if len(t) == 0:
            continue
        try:
            track = sensor_orientation(t + time_offset_s, stream.gyr, stream.acc, stream.mag_uT,
                                       stream.q_world_from_sensor, sensor_id=sensor_id, result=result,
                                       mag_calibration=mag_calibrations.get(sensor_id), settings=settings,
                                       initial_state=initial_states.get(sensor_id), seq=stream.seq,
                                       status=stream.calibration)
        except ValueError as error:
            problems.append(str(error))
            continue
        q_sensor[sensor_id], flags[sensor_id], reasons[sensor_id] = track.q_world_from_sensor, track.flags, track.doubt
    segments = assignment_of(body_calibration, sensor_segments or {})
    tracks = {sid: finite_track(streams[sid].t_s, q) for sid, q in q_sensor.items() if sid in segments}
    tracks = {sid: track for sid, track in tracks.items() if len(track[0])}
    source = POSE_BODY_CALIBRATION if body_calibration is not None else POSE_SENSOR_AXES
    reference = reference_sensor(model, segments, list(tracks))
    if reference is None:
        return PipelineOutput(result, np.zeros(0), {}, {}, q_sensor, flags, source, None, problems, reasons)
    t_pose = tracks[reference][0]
    at = {sid: orientation_at(t_pose, t, q) for sid, (t, q) in tracks.items()}
    fields = {sid: field_at(t_pose, streams[sid].t_s, calibrated_field(streams[sid].mag_uT, mag_calibrations.get(sid), sid))
              for sid in tracks}
    at, heading_source = coupled_headings(model, t_pose, at, fields, body_calibration, settings,
                                          both_ways=result == RESULT_REPROCESSED)
    q_segments = segments_from_sensors(model, at, body_calibration, sensor_segments or {}) or {}
    angles = skeleton.joint_angles_deg(model, q_segments, shoulder_sequence) if len(t_pose) else {}
    measured = {segments[sid] for sid in tracks}
    angles = measured_joint_angles(model, angles, measured)
    if off_body_s:
        fusion = settings.fusion
        for sid, stream in streams.items():
            if sid in reasons:
                reasons[sid] = reasons[sid] | doubt.off_body(stream.t_s, off_body_s, stream.gyr,
                                                             fusion.rest_max_rate_rad_s, fusion.rest_time_s)
    joint_doubt = joint_reasons(model, t_pose, segments, {sid: (np.asarray(streams[sid].t_s), reasons[sid])
                                                         for sid in tracks},
                                body_calibration, settings.fusion.max_gap_s, heading_source)
    joint_doubt = {joint: value | singular_reasons(model, joint, angles, shoulder_sequence)
                   for joint, value in joint_doubt.items() if any(c.startswith(joint + "_") for c in angles)}
    return PipelineOutput(result, t_pose, q_segments, angles, q_sensor, flags, source, reference, problems,
                          reasons, joint_doubt, heading_source, settings.heading)


def calibrated_field(mag_raw_uT: np.ndarray | None, calibration: MagCalibration | None,
                     sensor_id: str) -> np.ndarray | None:
    """A sensor's field (N, 3) µT corrected by its calibration; None without a magnetometer or
    a calibration (a raw field's magnitude and dip say nothing the body could share)."""
    if mag_raw_uT is None or calibration is None:
        return None
    return calibration.apply(mag_raw_uT, sensor_id)


def field_at(t_query: np.ndarray, t_s: np.ndarray, mag_uT: np.ndarray | None) -> np.ndarray | None:
    """A sensor's field (M, 3) at the instants ``t_query`` (M,): its latest sample at or before
    each (NaN before its first); None without a field."""
    if mag_uT is None:
        return None
    index = np.searchsorted(np.asarray(t_s), t_query, side="right") - 1
    out = np.asarray(mag_uT, dtype=np.float64)[np.clip(index, 0, None)]
    out[index < 0] = np.nan
    return out


def coupled_headings(model: skeleton.SkeletonModel, t_pose: np.ndarray, q_world_from_sensor: Mapping[str, np.ndarray],
                     mag_uT: Mapping[str, np.ndarray | None], body_calibration: bodycal.BodyCalibration | None,
                     settings: PipelineSettings, both_ways: bool) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """The sensors' orientations at the pose instants ``t_pose`` (T,) with their headings
    chosen per sensor and instant (:mod:`mimucap.core.heading_sources`, mode
    ``settings.heading``): ``q_world_from_sensor`` sensor → (T, 4), ``mag_uT`` sensor → (T, 3)
    calibrated field or None; ``both_ways`` for the reprocessed result. Returns the corrected
    orientations and sensor → (T,) the source of each heading
    (:data:`~mimucap.core.heading_sources.SOURCE_NAMES`)."""
    sensors = list(q_world_from_sensor)
    coupling = heading_sources.coupling_for(model, body_calibration, sensors, settings.heading)
    if not coupling.active or not len(t_pose):
        return dict(q_world_from_sensor), {sid: np.zeros(len(t_pose), dtype=np.uint8) for sid in sensors}
    q = np.stack([q_world_from_sensor[sid] for sid in sensors], axis=1)
    nan_field = np.full((len(t_pose), 3), np.nan)
    fields = [mag_uT.get(sid) for sid in sensors]
    mag = None if all(f is None for f in fields) else np.stack([nan_field if f is None else f for f in fields], axis=1)
    corrected, sources = coupling.run(np.asarray(t_pose, dtype=np.float64), q, mag, both_ways)
    return ({sid: corrected[:, i] for i, sid in enumerate(sensors)},
            {sid: sources[:, i] for i, sid in enumerate(sensors)})


def singular_reasons(model: skeleton.SkeletonModel, joint: str, angles_deg: Mapping[str, np.ndarray],
                     shoulder_sequence: str) -> np.ndarray | int:
    """:data:`~mimucap.core.doubt.SINGULAR` (T,) where ``joint``'s angles (``angles_deg``, columns of
    :func:`~mimucap.core.skeleton.joint_angle_columns`) lie near their sequence's singularity
    (0 when the joint has no angles)."""
    column, proper = skeleton.middle_angle(model.joint(joint), shoulder_sequence)
    return doubt.singular(angles_deg[column], proper) if column in angles_deg else 0


def joint_reasons(model: skeleton.SkeletonModel, t_pose: np.ndarray, segment_of_sensor: Mapping[str, str],
                  sensor_reasons: Mapping[str, tuple[np.ndarray, np.ndarray]],
                  body_calibration: bodycal.BodyCalibration | None,
                  hold_s: float = HOLD_BACK_LIMIT_S,
                  heading_source: Mapping[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """Joint → the reasons (T,) its angles at the pose instants ``t_pose`` may be wrong: its two
    sensors' (``sensor_reasons`` sensor → ``(t_s (N,), reasons (N,))``, at the instants by
    :func:`~mimucap.core.doubt.at_instants`, ``hold_s`` the longest a held orientation counts
    as measured), and no body calibration or a poor one. A sensor whose heading at an instant
    came from the field the body shares or from its joint (``heading_source`` sensor → (T,))
    is not doubtful there for its own magnetometer's reasons
    (:data:`~mimucap.core.heading_sources.RELIEVED_REASONS`)."""
    shared = np.zeros(len(t_pose), dtype=doubt.DOUBT_DTYPE)
    if body_calibration is None:
        shared |= doubt.NO_BODY_CALIBRATION
    else:
        if body_calibration.quality.verdict == "poor":
            shared |= doubt.BODY_CALIBRATION_POOR
        if body_calibration.quality.doubtful_sensors:
            shared |= doubt.BODY_CALIBRATION_DOUBTFUL
    at = {sid: doubt.at_instants(t_pose, t, values, hold_s) for sid, (t, values) in sensor_reasons.items()}
    for sid, sources in (heading_source or {}).items():
        if sid in at:
            at[sid] = heading_sources.relieved(at[sid], sources)
    sensor_of_segment = {segment: sid for sid, segment in segment_of_sensor.items() if sid in at}
    return doubt.joint_reasons(model.joints, sensor_of_segment, at, shared)


def measured_joint_angles(model: skeleton.SkeletonModel, angles_deg: Mapping[str, np.ndarray],
                          measured_segments) -> dict[str, np.ndarray]:
    """The joint-angle columns of the joints whose two segments carry a sensor: a segment
    without one only follows its parent, and its joint's angle would be a constant zero."""
    measured = set(measured_segments)
    keep = {joint.name for joint in model.joints if joint.proximal in measured and joint.distal in measured}
    return {column: values for column, values in angles_deg.items()
            if any(column.startswith(joint + "_") for joint in keep)}


# --------------------------------------------------------------------------------------------
# The online form
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class SensorOrientations:
    """What the pipeline made of one sensor's :class:`~mimucap.core.samples.SensorSamples`:
    ``t_s`` (N,), ``q_world_from_sensor``
    (N, 4) (NaN rows before the filter has an orientation), ``mag_uT`` (N, 3) the calibrated
    field or None, ``flags`` (N,) filter flags (zeros for an on-board orientation), ``doubt``
    (N,) the reasons the orientation may be wrong (:mod:`mimucap.core.doubt`)."""

    sensor_id: str
    t_s: np.ndarray
    q_world_from_sensor: np.ndarray
    mag_uT: np.ndarray | None
    flags: np.ndarray
    onboard: bool
    doubt: np.ndarray


#: Orientations a live sensor track keeps: a pose needs its sensors' last second or so
#: (:data:`HOLD_BACK_LIMIT_S`), and each new block copies the track.
TRACK_CAPACITY = 256


class _Track:
    """Recent finite orientations of one sensor (bounded)."""

    def __init__(self, capacity: int = TRACK_CAPACITY) -> None:
        self.t = np.empty(0)
        self.q = np.empty((0, 4))
        self.mag_uT = np.empty((0, 3))
        self.capacity = capacity

    def add(self, t: np.ndarray, q: np.ndarray, mag_uT: np.ndarray | None = None) -> None:
        keep = np.isfinite(q).all(axis=1)
        t, q = np.asarray(t)[keep], np.asarray(q)[keep]
        mag = np.full((len(t), 3), np.nan) if mag_uT is None else np.asarray(mag_uT, dtype=np.float64)[keep]
        if not len(t):
            return
        if len(self.t) and t[0] <= self.t[-1]:
            keep = t > self.t[-1]
            t, q, mag = t[keep], q[keep], mag[keep]
        self.t = np.concatenate([self.t, t])[-self.capacity:]
        self.q = np.concatenate([self.q, q])[-self.capacity:]
        self.mag_uT = np.concatenate([self.mag_uT, mag])[-self.capacity:]

    def field_at(self, t_s: float) -> np.ndarray:
        """The calibrated field (3,) of the latest sample at or before ``t_s`` (NaN when none)."""
        index = int(np.searchsorted(self.t, t_s, side="right")) - 1
        return self.mag_uT[index] if index >= 0 else np.full(3, np.nan)

    @property
    def newest_t(self) -> float:
        return float(self.t[-1]) if len(self.t) else float("nan")

    def at(self, t_s: float) -> np.ndarray:
        """The orientation (4,) at instant ``t_s``, as :func:`orientation_at` gives it; a pose
        at this sensor's newest sample (every sensor of a synchronous suit) is read directly."""
        if len(self.t) and self.t[-1] <= t_s:
            return self.q[-1]
        index = int(np.searchsorted(self.t, t_s, side="right")) - 1
        if index < 0:
            return np.full(4, np.nan)
        if self.t[index] == t_s:
            return self.q[index]
        fraction = (t_s - self.t[index]) / (self.t[index + 1] - self.t[index])
        return _slerp_one(self.q[index], self.q[index + 1], float(fraction))


def _slerp_one(q0: np.ndarray, q1: np.ndarray, fraction: float) -> np.ndarray:
    """Slerp of two unit quaternions (4,) in plain floats: the rotation of
    :func:`mimucap.core.rotation.slerp` (to rounding) at a fraction of its cost, for the live
    poses of sensors sampled at other instants than the reference sensor."""
    a = [float(v) for v in q0]
    b = [float(v) for v in q1]
    dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
    if dot < 0.0:  # the shorter way round
        b = [-v for v in b]
        dot = -dot
    if dot > 0.9999995:
        w0, w1 = 1.0 - fraction, fraction
    else:
        theta = math.acos(min(dot, 1.0))
        sin_theta = math.sin(theta)
        w0 = math.sin((1.0 - fraction) * theta) / sin_theta
        w1 = math.sin(fraction * theta) / sin_theta
    out = [w0 * x + w1 * y for x, y in zip(a, b)]
    norm = math.sqrt(sum(v * v for v in out))
    return np.array([v / norm for v in out])


class LivePipeline:
    """The processing path fed block by block (see the module docstring).

    Args:
        model: the skeleton model the poses are for.
        settings: the filter settings.
    """

    def __init__(self, model: skeleton.SkeletonModel, settings: PipelineSettings = DEFAULT_PIPELINE_SETTINGS) -> None:
        self.model = model
        self.settings = settings
        self.chains: dict[str, SensorChain] = {}
        self.mag_calibrations: dict[str, MagCalibration] = {}
        self.flags: dict[str, int] = {}
        #: sensor → the reasons its newest orientation may be wrong (:mod:`mimucap.core.doubt`)
        self.doubts: dict[str, int] = {}
        self._tracks: dict[str, _Track] = {}
        self._last_pose_t = -np.inf
        self._coupling: heading_sources.HeadingCoupling | None = None
        self._coupling_key: tuple | None = None
        #: sensor → where the newest pose's heading of that sensor came from
        #: (:data:`~mimucap.core.heading_sources.SOURCE_NAMES`)
        self.heading_sources: dict[str, int] = {}

    def chain(self, sensor_id: str) -> SensorChain:
        chain = self.chains.get(sensor_id)
        if chain is None:
            chain = self.chains[sensor_id] = SensorChain(sensor_id, self.mag_calibrations.get(sensor_id), self.settings)
        return chain

    def set_mag_calibration(self, calibration: MagCalibration) -> None:
        """Use ``calibration`` for its sensor from now on (its filter learns the heading anew:
        :meth:`SensorChain.set_mag_calibration`)."""
        self.mag_calibrations[calibration.sensor_id] = calibration
        self.chain(calibration.sensor_id).set_mag_calibration(calibration)

    def clear_mag_calibration(self, sensor_id: str) -> None:
        """Use ``sensor_id``'s raw magnetometer from now on (its calibration was for another
        device); its filter learns the heading anew."""
        self.mag_calibrations.pop(sensor_id, None)
        if sensor_id in self.chains:
            self.chains[sensor_id].set_mag_calibration(None)

    def filter_states(self) -> dict[str, dict[str, list]]:
        """Sensor → its filter state now (JSON-ready), for the sensors whose filter runs."""
        return {sid: snap for sid, chain in self.chains.items() if (snap := chain.state_snapshot()) is not None}

    def feed(self, blocks: Sequence[SensorSamples]) -> list[SensorOrientations]:
        """Calibrate and fuse new samples (``t_s`` on the pipeline's clock, raw ``mag_uT``; a
        ``q_world_from_sensor`` is the device's own orientation and is taken as it is); returns
        their orientations, in the blocks' order."""
        results: list[SensorOrientations | None] = [None] * len(blocks)
        inputs: list[ChainInput] = []
        fused_at: list[int] = []
        onboard_at: list[int] = []
        calibrated: dict[int, np.ndarray | None] = {}
        for index, block in enumerate(blocks):
            chain = self.chain(block.sensor_id)
            calibrated[index] = chain.calibrated_mag(block.mag_uT)
            if block.q_world_from_sensor is not None:
                chain.onboard = True
                onboard_at.append(index)
            elif block.gyr is not None:
                inputs.append(ChainInput(chain, block.t_s, block.gyr, block.acc,
                                         calibrated[index] if self.settings.uses_magnetometers else None))
                fused_at.append(index)
        orientation: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        for index in onboard_at:
            orientation[index] = (np.asarray(blocks[index].q_world_from_sensor, dtype=np.float64),
                                  np.zeros(len(blocks[index].t_s), dtype=np.uint8))
        for index, out in zip(fused_at, run_chains(inputs)):
            orientation[index] = (out.q_world_from_sensor, out.flags)
        order = onboard_at + fused_at
        chains = [self.chains[blocks[index].sensor_id] for index in order]
        doubt_blocks = [doubt.DoubtBlock(blocks[index].t_s, blocks[index].seq, blocks[index].gyr,
                                         None if chain.onboard else calibrated[index], *orientation[index],
                                         None if chain.onboard else chain.ekf.state.cov[0],
                                         blocks[index].calibration if chain.onboard else None)
                        for index, chain in zip(order, chains)]
        reasons = doubt.update_together([chain.doubt() for chain in chains], doubt_blocks).reasons()
        start = 0
        for index, chain in zip(order, chains):
            block = blocks[index]
            q, flags = orientation[index]
            n = len(block.t_s)
            results[index] = SensorOrientations(block.sensor_id, block.t_s, q, calibrated[index], flags, chain.onboard,
                                                reasons[start:start + n])
            start += n
        done = [r for r in results if r is not None]
        for item in done:
            self._tracks.setdefault(item.sensor_id, _Track()).add(item.t_s, item.q_world_from_sensor, item.mag_uT)
            if len(item.flags):
                self.flags[item.sensor_id] = int(item.flags[-1])
                self.doubts[item.sensor_id] = int(item.doubt[-1])
        return done

    def doubt_of(self, sensor_id: str) -> int:
        """The reasons (:mod:`mimucap.core.doubt`) the sensor's newest orientation may be wrong,
        less its own magnetometer's where the newest pose took its heading from the field the
        body shares or its joint (:func:`~mimucap.core.heading_sources.relieved`)."""
        reasons = np.array([self.doubts.get(sensor_id, 0)], dtype=doubt.DOUBT_DTYPE)
        source = np.array([self.heading_sources.get(sensor_id, heading_sources.SOURCE_FILTER)], dtype=np.uint8)
        return int(heading_sources.relieved(reasons, source)[0])

    def latest_orientations(self) -> dict[str, np.ndarray]:
        """Sensor → its newest ``q_world_from_sensor`` (4,) (sensors with one only)."""
        return {sid: track.q[-1] for sid, track in self._tracks.items() if len(track.t)}

    def pose(self, body_calibration: bodycal.BodyCalibration | None,
             sensor_segments: Mapping[str, str]) -> tuple[float, dict[str, np.ndarray]] | None:
        """The newest pose every assigned sensor has delivered for: ``(t_s, segment → (4,))``,
        or ``None`` when no new one is ready. Its instant is a sample time of the reference
        sensor that no assigned, non-silent sensor lags behind (:data:`HOLD_BACK_LIMIT_S`), so
        that every segment comes from samples of the same instant (as :func:`process_recording`
        forms it)."""
        segments = assignment_of(body_calibration, sensor_segments)
        tracks = {sid: self._tracks[sid] for sid in segments if sid in self._tracks and len(self._tracks[sid].t)}
        reference = reference_sensor(self.model, segments, list(tracks))
        if reference is None:
            return None
        newest = max(track.newest_t for track in tracks.values())
        limit = min(track.newest_t for track in tracks.values() if track.newest_t >= newest - HOLD_BACK_LIMIT_S)
        ref_t = tracks[reference].t
        position = int(np.searchsorted(ref_t, limit, side="right")) - 1
        if position < 0 or ref_t[position] <= self._last_pose_t:
            return None
        t_pose = float(ref_t[position])
        at = {sid: track.at(t_pose) for sid, track in tracks.items()}
        at = self._coupled(t_pose, at, body_calibration, tracks)
        q_segments = segments_from_sensors(self.model, at, body_calibration, sensor_segments)
        if q_segments is None:
            return None
        self._last_pose_t = t_pose
        return t_pose, q_segments

    def _coupled(self, t_pose: float, at: dict[str, np.ndarray], body_calibration: bodycal.BodyCalibration | None,
                 tracks: Mapping[str, _Track]) -> dict[str, np.ndarray]:
        """The pose's sensor orientations with their headings chosen as :func:`coupled_headings`
        chooses them for the live result (one instant at a time, averaging over the past)."""
        sensors = list(at)
        key = (tuple(sensors), id(body_calibration), self.settings.heading)
        if self._coupling is None or key != self._coupling_key:
            self._coupling = heading_sources.coupling_for(self.model, body_calibration, sensors, self.settings.heading)
            self._coupling_key = key
        if not self._coupling.active:
            self.heading_sources = {}
            return at
        q = np.stack([at[sid] for sid in sensors])
        mag = np.stack([tracks[sid].field_at(t_pose) if self.chains.get(sid) is not None
                        and self.chains[sid].mag_calibration is not None else np.full(3, np.nan) for sid in sensors])
        corrected, sources = self._coupling.step(t_pose, q, mag)
        self.heading_sources = {sid: int(sources[i]) for i, sid in enumerate(sensors)}
        return {sid: corrected[i] for i, sid in enumerate(sensors)}

    def forget_poses(self) -> None:
        """Allow the next pose to be any instant again (after a calibration changed); the
        heading coupling starts its averages anew."""
        self._last_pose_t = -np.inf
        self._coupling = None
