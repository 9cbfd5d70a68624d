"""Step 3 of the processing path: every sensor at the same instants (no I/O, no Qt).

A pose is formed at a sample instant ``t`` of the *reference sensor* (the root segment's sensor
when there is one: :func:`reference_sensor`) from every sensor's orientation at that same
instant: exact at its own sample times, slerp between two of its samples, held after its last
one, absent (NaN) before its first (:func:`orientation_at`). What the chains report beside the
orientation comes along, taken from the sample at or before the instant (:class:`SensorsAtInstants`):
the stage after this one (:mod:`.segments`) sees all sensors at once, which is where
constraints between the sensors of a joint can act.

The batch form (:func:`sensors_at_instants`) forms every instant of a recording from the
sensors' whole tracks; the live form keeps each sensor's recent samples (:class:`LiveTrack`)
and forms the newest instant every assigned sensor has delivered for (:func:`newest_instant`),
so that every segment of a live pose comes from samples of the same instant, as in the batch
form.

Times are float64 seconds; quaternions ``[w, x, y, z]``, world ENU.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from mimucap.core import rotation, skeleton

#: A sensor silent for longer than this (s) no longer holds back a live pose (it is held).
HOLD_BACK_LIMIT_S = 1.0
#: Samples a live sensor track keeps: a pose needs its sensors' last second or so
#: (:data:`HOLD_BACK_LIMIT_S`), and each new block copies the track.
TRACK_CAPACITY = 256


@dataclass(frozen=True)
class SensorsAtInstants:
    """Every sensor at the same instants: what the segment stage (:mod:`.segments`) receives.

    ``t_s`` (T,) s, or a float for one live instant; for each sensor (mappings sensor id → array,
    with the instants' shape in front): ``q_world_from_sensor`` (…, 4) (NaN where the sensor has
    no orientation yet); ``flags`` (…,) uint8 the filter's flags at the sample at or before the
    instant (:data:`~mimucap.core.fusion.state.FLAG_NAMES`: a rejected or missing magnetometer,
    rest, ...); ``heading_std_rad`` (…,) the filter's heading standard deviation there (NaN for
    an on-board orientation); ``q_world_from_sensor_no_mag`` (…, 4) the orientation of a
    magnetometer-free filter, for the sensors whose chain runs one; ``mag_uT`` (…, 3) the
    calibrated field of the sample at or before the instant (NaN before the first), for the
    sensors with a magnetometer calibration (a raw field's magnitude and dip say nothing two
    sensors could share). ``heading_source`` (…,) uint8 where each sensor's heading came from
    (:data:`~mimucap.core.heading_sources.SOURCE_NAMES`), set by a joint coupling that chooses
    it (empty: each filter's own).
    """

    t_s: np.ndarray | float
    q_world_from_sensor: Mapping[str, np.ndarray]
    flags: Mapping[str, np.ndarray] = field(default_factory=dict)
    heading_std_rad: Mapping[str, np.ndarray] = field(default_factory=dict)
    q_world_from_sensor_no_mag: Mapping[str, np.ndarray] = field(default_factory=dict)
    mag_uT: Mapping[str, np.ndarray] = field(default_factory=dict)
    heading_source: Mapping[str, np.ndarray] = field(default_factory=dict)


@dataclass(frozen=True)
class SensorTrack:
    """One sensor's samples as the chain gave them, for forming instants: ``t_s`` (N,)
    increasing, ``q_world_from_sensor`` (N, 4), ``flags`` (N,) uint8, ``heading_std_rad`` (N,),
    ``q_world_from_sensor_no_mag`` (N, 4) or None, ``mag_uT`` (N, 3) the calibrated field or
    None. Only the rows with an orientation (see :meth:`finite`)."""

    t_s: np.ndarray
    q_world_from_sensor: np.ndarray
    flags: np.ndarray
    heading_std_rad: np.ndarray
    q_world_from_sensor_no_mag: np.ndarray | None = None
    mag_uT: np.ndarray | None = None

    @classmethod
    def finite(cls, t_s, q_world_from_sensor, flags=None, heading_std_rad=None, q_no_mag=None,
               mag_uT=None) -> "SensorTrack":
        """The rows of a chain's output that hold an orientation (``flags`` zeros and
        ``heading_std_rad`` NaN when not given)."""
        q = np.asarray(q_world_from_sensor, dtype=np.float64)
        keep = np.isfinite(q).all(axis=1)
        n = len(q)
        flags = np.zeros(n, dtype=np.uint8) if flags is None else np.asarray(flags)
        heading = np.full(n, math.nan) if heading_std_rad is None else np.asarray(heading_std_rad)
        return cls(np.asarray(t_s, dtype=np.float64)[keep], q[keep], flags[keep], heading[keep],
                   None if q_no_mag is None else np.asarray(q_no_mag)[keep],
                   None if mag_uT is None else np.asarray(mag_uT, dtype=np.float64)[keep])


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


def value_at(t_query: np.ndarray, t_s: np.ndarray, values: np.ndarray, before_first) -> np.ndarray:
    """``values`` (N, …) of a sensor's samples at ``t_s`` (N,) at the instants ``t_query`` (M,):
    those of the sample at or before each instant (held after the last), ``before_first``
    before the first sample. (M, …)."""
    t_query = np.asarray(t_query, dtype=np.float64)
    values = np.asarray(values)
    index = np.searchsorted(t_s, t_query, side="right") - 1
    out = values[np.clip(index, 0, None)] if len(t_s) else np.empty(t_query.shape + values.shape[1:], values.dtype)
    out = np.array(out, copy=True)
    out[index < 0] = before_first
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


def sensors_at_instants(t_pose: np.ndarray, tracks: Mapping[str, SensorTrack]) -> SensorsAtInstants:
    """Every sensor of ``tracks`` at the instants ``t_pose`` (T,) (the batch form; see the
    module docstring)."""
    q = {sid: orientation_at(t_pose, track.t_s, track.q_world_from_sensor) for sid, track in tracks.items()}
    flags = {sid: value_at(t_pose, track.t_s, track.flags, 0) for sid, track in tracks.items()}
    heading = {sid: value_at(t_pose, track.t_s, track.heading_std_rad, math.nan) for sid, track in tracks.items()}
    free = {sid: orientation_at(t_pose, track.t_s, track.q_world_from_sensor_no_mag)
            for sid, track in tracks.items() if track.q_world_from_sensor_no_mag is not None}
    mag = {sid: value_at(t_pose, track.t_s, track.mag_uT, math.nan)
           for sid, track in tracks.items() if track.mag_uT is not None}
    return SensorsAtInstants(t_pose, q, flags, heading, free, mag)


class LiveTrack:
    """One sensor's recent samples with an orientation (at most :data:`TRACK_CAPACITY`), for
    the live form."""

    def __init__(self, capacity: int = TRACK_CAPACITY) -> None:
        self.t = np.empty(0)
        self.q = np.empty((0, 4))
        self.flags = np.empty(0, dtype=np.uint8)
        self.heading_std_rad = np.empty(0)
        self.q_no_mag: np.ndarray | None = None
        self.mag_uT: np.ndarray | None = None
        self.capacity = capacity

    def add(self, t_s: np.ndarray, q: np.ndarray, flags: np.ndarray, heading_std_rad: np.ndarray,
            q_no_mag: np.ndarray | None = None, mag_uT: np.ndarray | None = None) -> None:
        """Append a chain's new samples (rows without an orientation, or not after the newest
        one kept, are left out); ``mag_uT`` (N, 3) the calibrated field or None."""
        keep = np.isfinite(q).all(axis=1)
        if len(self.t) and len(t_s) and t_s[0] <= self.t[-1]:
            keep &= np.asarray(t_s) > self.t[-1]
        if not keep.any():
            return
        if q_no_mag is not None and self.q_no_mag is None:  # rows kept before have none
            self.q_no_mag = np.full((len(self.t), 4), np.nan)
        if mag_uT is not None and self.mag_uT is None:
            self.mag_uT = np.full((len(self.t), 3), np.nan)
        cut = -self.capacity
        self.t = np.concatenate([self.t, np.asarray(t_s)[keep]])[cut:]
        self.q = np.concatenate([self.q, np.asarray(q)[keep]])[cut:]
        self.flags = np.concatenate([self.flags, np.asarray(flags)[keep]])[cut:]
        self.heading_std_rad = np.concatenate([self.heading_std_rad, np.asarray(heading_std_rad)[keep]])[cut:]
        if self.q_no_mag is not None:
            new = np.full((int(keep.sum()), 4), np.nan) if q_no_mag is None else np.asarray(q_no_mag)[keep]
            self.q_no_mag = np.concatenate([self.q_no_mag, new])[cut:]
        if self.mag_uT is not None:
            new = np.full((int(keep.sum()), 3), np.nan) if mag_uT is None else np.asarray(mag_uT)[keep]
            self.mag_uT = np.concatenate([self.mag_uT, new])[cut:]

    @property
    def newest_t(self) -> float:
        return float(self.t[-1]) if len(self.t) else float("nan")

    def as_sensor_track(self) -> SensorTrack:
        """The samples kept, as the batch form holds a sensor's orientations."""
        return SensorTrack(self.t, self.q, self.flags, self.heading_std_rad, self.q_no_mag, self.mag_uT)

    def at(self, t_s: float) -> tuple[np.ndarray, int, float, np.ndarray | None]:
        """``(q_world_from_sensor (4,), flags, heading_std_rad, q_no_mag (4,) or None)`` at the
        instant ``t_s``: the orientation as :func:`orientation_at` gives it, the rest from the
        sample at or before it; a pose at this sensor's newest sample (every sensor of a
        synchronous suit) is read directly."""
        if len(self.t) and self.t[-1] <= t_s:
            return self._row(len(self.t) - 1, self.q[-1], None if self.q_no_mag is None else self.q_no_mag[-1])
        index = int(np.searchsorted(self.t, t_s, side="right")) - 1
        if index < 0:
            nothing = np.full(4, np.nan)
            return nothing, 0, math.nan, None if self.q_no_mag is None else nothing
        if self.t[index] == t_s:
            return self._row(index, self.q[index], None if self.q_no_mag is None else self.q_no_mag[index])
        fraction = float((t_s - self.t[index]) / (self.t[index + 1] - self.t[index]))
        free = None if self.q_no_mag is None else slerp_one(self.q_no_mag[index], self.q_no_mag[index + 1], fraction)
        return self._row(index, slerp_one(self.q[index], self.q[index + 1], fraction), free)

    def _row(self, index: int, q: np.ndarray, q_no_mag: np.ndarray | None):
        return q, int(self.flags[index]), float(self.heading_std_rad[index]), q_no_mag

    def field_at(self, t_s: float) -> np.ndarray | None:
        """The calibrated field (3,) of the sample at or before ``t_s`` (NaN before the first);
        None for a sensor without one."""
        if self.mag_uT is None:
            return None
        index = int(np.searchsorted(self.t, t_s, side="right")) - 1
        return self.mag_uT[index] if index >= 0 else np.full(3, np.nan)


def slerp_one(q0: np.ndarray, q1: np.ndarray, fraction: float) -> np.ndarray:
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


def _reference_times(model: skeleton.SkeletonModel, segment_of_sensor: Mapping[str, str],
                     tracks: Mapping[str, LiveTrack]) -> tuple[np.ndarray, float] | None:
    """The reference sensor's sample times and the newest instant every assigned sensor has
    delivered for (a sensor silent for longer than :data:`HOLD_BACK_LIMIT_S` is held); ``None``
    without a reference sensor."""
    tracks = {sid: tracks[sid] for sid in segment_of_sensor if sid in tracks and len(tracks[sid].t)}
    reference = reference_sensor(model, segment_of_sensor, list(tracks))
    if reference is None:
        return None
    newest = max(track.newest_t for track in tracks.values())
    limit = min(track.newest_t for track in tracks.values() if track.newest_t >= newest - HOLD_BACK_LIMIT_S)
    return tracks[reference].t, limit


def newest_instant(model: skeleton.SkeletonModel, segment_of_sensor: Mapping[str, str],
                   tracks: Mapping[str, LiveTrack], after_s: float) -> float | None:
    """The newest pose instant every assigned sensor has delivered for (the live form), later
    than ``after_s``: a sample time of the reference sensor that no assigned sensor lags
    behind, unless it has been silent for longer than :data:`HOLD_BACK_LIMIT_S` (it is then
    held). ``None`` when there is no new one."""
    found = _reference_times(model, segment_of_sensor, tracks)
    if found is None:
        return None
    ref_t, limit = found
    position = int(np.searchsorted(ref_t, limit, side="right")) - 1
    if position < 0 or ref_t[position] <= after_s:
        return None
    return float(ref_t[position])


def instants_after(model: skeleton.SkeletonModel, segment_of_sensor: Mapping[str, str],
                   tracks: Mapping[str, LiveTrack], after_s: float) -> np.ndarray:
    """Every pose instant later than ``after_s`` up to :func:`newest_instant`'s (the reference
    sensor's sample times every assigned sensor has delivered for), (P,) s: a consumer that
    wants each sample instant (a stream at the sensors' rate) gets those that the newest pose
    alone skips. Reaches back :data:`TRACK_CAPACITY` samples at most."""
    found = _reference_times(model, segment_of_sensor, tracks)
    if found is None:
        return np.empty(0)
    ref_t, limit = found
    return ref_t[(ref_t > after_s) & (ref_t <= limit)]


def live_sensors_at(t_pose: float, tracks: Mapping[str, LiveTrack]) -> SensorsAtInstants:
    """Every sensor of ``tracks`` at the one instant ``t_pose`` (the live form)."""
    q, flags, heading, free, mag = {}, {}, {}, {}, {}
    for sid, track in tracks.items():
        q[sid], flags[sid], heading[sid], no_mag = track.at(t_pose)
        if no_mag is not None:
            free[sid] = no_mag
        field_uT = track.field_at(t_pose)
        if field_uT is not None:
            mag[sid] = field_uT
    return SensorsAtInstants(t_pose, q, flags, heading, free, mag)


class CoupledInstants:
    """The last instants (at most :data:`TRACK_CAPACITY`) as the segment stage's joint coupling
    made them, in the live form: the coupling is stepped once over every instant
    (:meth:`~mimucap.core.pipeline.live.LivePipeline.pose`), and the poses shown and streamed
    are read from here. ``stage_key`` names the assignment they were made with."""

    def __init__(self, stage_key: tuple | None = None) -> None:
        self.stage_key = stage_key
        self.t = np.empty(0)
        self.q: dict[str, np.ndarray] = {}
        self.source: dict[str, np.ndarray] = {}

    @property
    def newest_t(self) -> float:
        return float(self.t[-1]) if len(self.t) else -math.inf

    def add(self, instants: SensorsAtInstants) -> None:
        """Append coupled ``instants`` (``t_s`` (P,) after :attr:`newest_t`); a sensor new to
        them has no rows before (NaN)."""
        t_new = np.atleast_1d(np.asarray(instants.t_s, dtype=np.float64))
        count, cut = len(self.t), -TRACK_CAPACITY
        for sid, q in instants.q_world_from_sensor.items():
            kept = self.q.get(sid, np.full((count, 4), np.nan))
            self.q[sid] = np.concatenate([kept, np.reshape(q, (-1, 4))])[cut:]
        for sid in set(self.q) - set(instants.q_world_from_sensor):
            self.q[sid] = np.concatenate([self.q[sid], np.full((len(t_new), 4), np.nan)])[cut:]
        for sid in set(self.source) | set(instants.heading_source):
            kept = self.source.get(sid, np.zeros(count, dtype=np.uint8))
            new = instants.heading_source.get(sid, np.zeros(len(t_new), dtype=np.uint8))
            self.source[sid] = np.concatenate([kept, np.reshape(new, -1)])[cut:]
        self.t = np.concatenate([self.t, t_new])[cut:]

    def at(self, t_query: np.ndarray) -> SensorsAtInstants | None:
        """The kept instants among ``t_query`` (P,) s, in order; None when none is kept."""
        rows = np.flatnonzero(np.isin(self.t, t_query))
        if not len(rows):
            return None
        return SensorsAtInstants(self.t[rows], {sid: q[rows] for sid, q in self.q.items()},
                                 heading_source={sid: s[rows] for sid, s in self.source.items()})
