"""Replay driver: plays already-loaded sensor samples back in (scaled) real time.

The acquisition layer does not read files (``io`` is out of its reach); the caller (see
``mimucap.session.sources``) loads a session file or an export and hands the arrays over in a
:class:`ReplaySourceConfig`. Sample ``k`` of a sensor recorded at ``t_s[k]`` is released at
host time ``start + (t_s[k] − t0) / speed`` and stamped with that host time; the recorded time
is kept as ``device_time_s``. The source reports ``finished`` after its last sample.

A recorded row that a live source would refuse (NaN or infinity: ``non_finite``; beyond
:class:`~mimucap.acquisition.samples.ValueLimits`: ``out_of_range``) is never released:
:func:`replayable` sets it apart, and the driver counts it as a rejection with
its reason when the replay reaches its time, per sensor and for the source, as the packet
intake does. Its sequence number is reported in ``refused_in_gaps`` so that the gap it leaves
is not counted as a drop (packet loss).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from threading import Event

import numpy as np

from mimucap.acquisition.messages import STATE_FINISHED, STATE_RUNNING, BlocksMessage, WorkerReport
from mimucap.acquisition.outbox import Outbox
from mimucap.acquisition.rejections import RejectionCounter
from mimucap.acquisition.samples import DEFAULT_LIMITS, ValueLimits, refused_rows
from mimucap.core.device_identity import SensorDevice
from mimucap.core.samples import CHANNELS, SensorSamples


@dataclass(frozen=True, eq=False)
class RefusedRows:
    """Rows of a recording that are not replayed: ``t_s`` (M,) s recorded time, non-decreasing;
    ``seq`` (M,) int; ``reasons`` (M,) :class:`~mimucap.acquisition.rejections.Rejection`
    values (str)."""

    t_s: np.ndarray
    seq: np.ndarray
    reasons: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.t_s)
        if len(self.seq) != n or len(self.reasons) != n or (n > 1 and not np.all(np.diff(self.t_s) >= 0)):
            raise ValueError("refused rows: t_s must be non-decreasing and match seq and reasons")

    def __len__(self) -> int:
        return len(self.t_s)

    def between(self, first_seq: int, last_seq: int) -> int:
        """Refused rows whose sequence numbers lie strictly between ``first_seq`` and
        ``last_seq``: the gaps they leave in the released numbers are not drops."""
        return int(np.count_nonzero((self.seq > first_seq) & (self.seq < last_seq)))


def replayable(samples: SensorSamples, limits: ValueLimits = DEFAULT_LIMITS) -> tuple[SensorSamples, RefusedRows | None]:
    """A recording's samples split as a live source validates samples
    (:func:`~mimucap.acquisition.samples.refused_rows`): the rows to replay (``t_s`` recorded
    time, ``seq``, the channels, quaternions normalised; ``segment`` kept), and the rows with a
    NaN, an infinity or a value beyond ``limits``, with their reasons (``None`` when every
    row is replayable)."""
    sensor_id = samples.sensor_id
    t_s, seq = np.asarray(samples.t_s, dtype=np.float64), np.asarray(samples.seq, dtype=np.int64)
    channels = {name: getattr(samples, name) for name in samples.channels()}
    for name, value in {"seq": seq, **channels}.items():
        if len(value) != len(t_s):
            raise ValueError(f"replay sensor {sensor_id}: {name} has {len(value)} rows, t_s has {len(t_s)}")
    reasons = refused_rows(channels, limits) if channels else np.full(len(t_s), "")
    good = reasons == ""
    kept = {name: np.asarray(value)[good] for name, value in channels.items()}
    q = kept.get("q_world_from_sensor")
    if q is not None:
        kept["q_world_from_sensor"] = q / np.linalg.norm(q, axis=1, keepdims=True)
    refused = None if good.all() else RefusedRows(t_s[~good], seq[~good], reasons[~good])
    return SensorSamples(sensor_id, t_s[good], seq[good], segment=samples.segment, **kept), refused


@dataclass(frozen=True, eq=False)
class ReplaySourceConfig:
    """A replay source (picklable; the arrays travel to the worker process once).

    ``streams``: each sensor's recorded samples to replay (``t_s`` recorded time, increasing;
    ``segment`` where the recording says the sensor was worn), as :func:`replayable` gives
    them; ``refused``: (sensor id, rows refused before replay) pairs; ``devices``: (sensor id,
    the device the recording says it was) pairs, reported as the source's."""

    name: str = "replay"
    streams: tuple[SensorSamples, ...] = ()
    refused: tuple[tuple[str, RefusedRows], ...] = ()
    devices: tuple[tuple[str, SensorDevice], ...] = ()
    speed: float = 1.0              #: × real time
    block_interval_s: float = 0.01  #: s of host time between released blocks
    report_interval_s: float = 0.5

    def __post_init__(self) -> None:
        if not self.speed > 0:
            raise ValueError(f"replay speed must be > 0, got {self.speed}")
        for stream in self.streams:
            n = len(stream.t_s)
            if len(stream.seq) != n or (n > 1 and not np.all(np.diff(stream.t_s) >= 0)):
                raise ValueError(f"replay sensor {stream.sensor_id}: t_s must be non-decreasing and match seq")
            for name in stream.channels():
                rows = len(getattr(stream, name))
                if rows != n:
                    raise ValueError(f"replay sensor {stream.sensor_id}: {name} has {rows} rows, t_s has {n}")
        unknown = sorted(set(dict(self.refused)) - {stream.sensor_id for stream in self.streams})
        if unknown:
            raise ValueError(f"replay: refused rows of sensors without a stream: {', '.join(unknown)}")

    def sensor_segments(self) -> dict[str, str]:
        """Sensor id → the segment it was worn on in the recording (those it names)."""
        return {stream.sensor_id: stream.segment for stream in self.streams if stream.segment}


class ReplayDriver:
    def __init__(self, config: ReplaySourceConfig, outbox: Outbox) -> None:
        self.config = config
        self.outbox = outbox
        self.released = 0
        refused = dict(config.refused)
        self.streams = [s for s in config.streams if len(s.t_s) or refused.get(s.sensor_id) is not None]
        self.refused = [refused.get(s.sensor_id) for s in self.streams]   # per stream, or None
        self.positions = [0] * len(self.streams)           # rows released, per stream
        self.refused_positions = [0] * len(self.streams)   # refused rows counted, per stream
        self.rejections = RejectionCounter()
        self.rejections_by_sensor: dict[str, RejectionCounter] = {}
        self.summary = ""   # what was replayed, once finished (kept in every later report)

    def report(self, state: str, message: str = ""):
        """A cumulative report: rejections (total and per sensor) and, per sensor, the refused
        rows numbered between released ones (``refused_in_gaps``)."""
        message = message or self.summary
        by_sensor = {sensor: counter.as_dict() for sensor, counter in self.rejections_by_sensor.items()}
        return WorkerReport(self.config.name, state, message, self.rejections.as_dict(),
                            rejections_by_sensor=by_sensor, overflow_samples=self.outbox.overflow_samples,
                            refused_in_gaps=self.refused_in_gaps(), devices=dict(self.config.devices))

    def refused_in_gaps(self) -> dict[str, int]:
        """Per sensor, the refused rows numbered between released ones so far."""
        in_gaps = {stream.sensor_id: refused.between(stream.seq[0], stream.seq[released - 1])
                   for stream, refused, released in zip(self.streams, self.refused, self.positions)
                   if refused is not None and released >= 2}
        return {sensor: n for sensor, n in in_gaps.items() if n}

    def run(self, stop: Event) -> None:
        streams = self.streams
        if not streams:
            self.outbox.send_report(self.report(STATE_FINISHED, "nothing to replay"))
            return
        # the first recorded row, released or refused
        t0 = min(float(t[0]) for stream, refused in zip(streams, self.refused)
                 for t in (stream.t_s, () if refused is None else refused.t_s) if len(t))
        start = time.monotonic()
        positions = self.positions
        self.outbox.send_report(self.report(STATE_RUNNING))
        while not stop.is_set():
            now = time.monotonic()
            horizon = t0 + (now - start) * self.config.speed
            blocks = []
            for index, stream in enumerate(streams):
                begin = positions[index]
                end = int(np.searchsorted(stream.t_s, horizon, side="right"))
                if end > begin:
                    positions[index] = end
                    blocks.append(self._block(stream, begin, end, start, t0, now))
                self._count_refused(index, horizon)
            if blocks:
                self.released += sum(len(b) for b in blocks)
                self.outbox.send_blocks(BlocksMessage(self.config.name, tuple(blocks),
                                                      refused_in_gaps=self.refused_in_gaps()))
            if all(positions[i] >= len(s.t_s) and self.refused_positions[i] >= len(self.refused[i] or ())
                   for i, s in enumerate(streams)):
                refused = self.rejections.total()
                self.summary = f"replayed {self.released} samples" + (f", refused {refused}" if refused else "")
                self.outbox.send_report(self.report(STATE_FINISHED))
                return
            if self.outbox.report_due(now):
                self.outbox.send_report(self.report(STATE_RUNNING))
            stop.wait(self.config.block_interval_s)

    def _count_refused(self, index: int, horizon: float) -> None:
        """Count the refused rows of stream ``index`` recorded up to ``horizon`` (s) as rejections."""
        refused = self.refused[index]
        if refused is None:
            return
        begin = self.refused_positions[index]
        end = int(np.searchsorted(refused.t_s, horizon, side="right"))
        if end <= begin:
            return
        self.refused_positions[index] = end
        counter = self.rejections_by_sensor.setdefault(self.streams[index].sensor_id, RejectionCounter())
        for reason, count in zip(*np.unique(refused.reasons[begin:end], return_counts=True)):
            self.rejections.add(str(reason), int(count))
            counter.add(str(reason), int(count))

    def _block(self, stream: SensorSamples, begin: int, end: int, start: float, t0: float,
               now: float) -> SensorSamples:
        """Rows ``begin:end`` of ``stream`` as a source delivers them: stamped with the host time
        of their release, the recorded time kept as ``device_time_s``."""
        t = np.asarray(stream.t_s[begin:end], dtype=np.float64)
        channels = [None if (value := getattr(stream, name)) is None else np.asarray(value[begin:end])
                    for name in CHANNELS]
        return SensorSamples(stream.sensor_id, start + (t - t0) / self.config.speed,
                             np.asarray(stream.seq[begin:end], dtype=np.int64), *channels,
                             device_time_s=t, receive_time_s=np.full(len(t), now), source=self.config.name)
