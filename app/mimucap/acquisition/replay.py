"""Replay driver: plays already-loaded sensor streams back in (scaled) real time.

The acquisition layer does not read files (``io`` is out of its reach); the caller (see
``mimucap.session.sources``) loads a session file or an export and hands the arrays over in a
:class:`ReplaySourceConfig`. Sample ``k`` of a stream recorded at ``t_s[k]`` is released at
host time ``start + (t_s[k] − t0) / speed`` and stamped with that host time; the recorded time
is kept as ``device_time_s``. The source reports ``finished`` after its last sample.

A recorded row that a live source would refuse (NaN or infinity: ``non_finite``; beyond
:class:`~mimucap.acquisition.samples.ValueLimits`: ``out_of_range``) is never released:
:meth:`ReplayStream.from_recording` sets it apart, and the driver counts it as a rejection with
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
from mimucap.acquisition.samples import CHANNELS, DEFAULT_LIMITS, SampleBlock, ValueLimits, refused_rows


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


@dataclass(frozen=True, eq=False)
class ReplayStream:
    """One sensor's recorded samples: ``t_s`` (N,) s increasing, ``seq`` (N,) int, channels as
    in :class:`~mimucap.acquisition.samples.SampleBlock` (``None`` when absent), and the rows
    refused before replay (``refused``, see :meth:`from_recording`)."""

    sensor_id: str
    t_s: np.ndarray
    seq: np.ndarray
    acc: np.ndarray | None = None
    gyr: np.ndarray | None = None
    mag_uT: np.ndarray | None = None
    q_world_from_sensor: np.ndarray | None = None
    calibration: np.ndarray | None = None
    battery_pct: np.ndarray | None = None
    refused: RefusedRows | None = None

    def __post_init__(self) -> None:
        n = len(self.t_s)
        if len(self.seq) != n or (n > 1 and not np.all(np.diff(self.t_s) >= 0)):
            raise ValueError(f"replay sensor {self.sensor_id}: t_s must be non-decreasing and match seq")
        for name in CHANNELS:
            value = getattr(self, name)
            if value is not None and len(value) != n:
                raise ValueError(f"replay sensor {self.sensor_id}: {name} has {len(value)} rows, t_s has {n}")

    @classmethod
    def from_recording(cls, sensor_id: str, t_s: np.ndarray, seq: np.ndarray,
                       channels: dict[str, np.ndarray], limits: ValueLimits = DEFAULT_LIMITS) -> "ReplayStream":
        """The stream of a recording's rows, validated as a live source validates samples
        (:func:`~mimucap.acquisition.samples.refused_rows`): a row with a NaN, an infinity or a
        value beyond ``limits`` is kept apart in ``refused`` with its reason; the quaternions
        of the other rows are normalised. ``channels`` as in
        :class:`~mimucap.acquisition.samples.SampleBlock` (absent channels left out)."""
        t_s, seq = np.asarray(t_s, dtype=np.float64), np.asarray(seq, dtype=np.int64)
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
        return cls(sensor_id, t_s[good], seq[good], refused=refused, **kept)

    @property
    def n_refused(self) -> int:
        """Rows refused before replay."""
        return 0 if self.refused is None else len(self.refused.t_s)

    @property
    def first_t_s(self) -> float:
        """Recorded time (s) of the first row, released or refused (``inf`` when empty)."""
        firsts = [float(t[0]) for t in (self.t_s, () if self.refused is None else self.refused.t_s) if len(t)]
        return min(firsts, default=float("inf"))

    def refused_between(self, released: int) -> int:
        """Refused rows whose sequence numbers lie between the first and the ``released``-th
        released row: the gaps they leave in the released numbers are not drops."""
        if self.refused is None or released < 2:
            return 0
        first, last = self.seq[0], self.seq[released - 1]
        return int(np.count_nonzero((self.refused.seq > first) & (self.refused.seq < last)))


@dataclass(frozen=True, eq=False)
class ReplaySourceConfig:
    """A replay source (picklable; the arrays travel to the worker process once)."""

    name: str = "replay"
    streams: tuple[ReplayStream, ...] = ()
    speed: float = 1.0              #: × real time
    block_interval_s: float = 0.01  #: s of host time between released blocks
    report_interval_s: float = 0.5
    #: (sensor id, segment) pairs: where the recording says each sensor was worn
    segments: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        if not self.speed > 0:
            raise ValueError(f"replay speed must be > 0, got {self.speed}")

    def sensor_segments(self) -> dict[str, str]:
        """Sensor id → the segment it was worn on in the recording (those it names)."""
        return dict(self.segments)


class ReplayDriver:
    def __init__(self, config: ReplaySourceConfig, outbox: Outbox) -> None:
        self.config = config
        self.outbox = outbox
        self.released = 0
        self.streams = [s for s in config.streams if len(s.t_s) or s.n_refused]
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
                            refused_in_gaps=self.refused_in_gaps())

    def refused_in_gaps(self) -> dict[str, int]:
        """Per sensor, the refused rows numbered between released ones so far."""
        in_gaps = {stream.sensor_id: stream.refused_between(released)
                   for stream, released in zip(self.streams, self.positions) if stream.refused is not None}
        return {sensor: n for sensor, n in in_gaps.items() if n}

    def run(self, stop: Event) -> None:
        streams = self.streams
        if not streams:
            self.outbox.send_report(self.report(STATE_FINISHED, "nothing to replay"))
            return
        t0 = min(s.first_t_s for s in streams)
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
                self._count_refused(index, stream, horizon)
            if blocks:
                self.released += sum(len(b) for b in blocks)
                self.outbox.send_blocks(BlocksMessage(self.config.name, tuple(blocks),
                                                      refused_in_gaps=self.refused_in_gaps()))
            if all(positions[i] >= len(s.t_s) and self.refused_positions[i] >= s.n_refused
                   for i, s in enumerate(streams)):
                refused = self.rejections.total()
                self.summary = f"replayed {self.released} samples" + (f", refused {refused}" if refused else "")
                self.outbox.send_report(self.report(STATE_FINISHED))
                return
            if self.outbox.report_due(now):
                self.outbox.send_report(self.report(STATE_RUNNING))
            stop.wait(self.config.block_interval_s)

    def _count_refused(self, index: int, stream: ReplayStream, horizon: float) -> None:
        """Count the refused rows of ``stream`` recorded up to ``horizon`` (s) as rejections."""
        if stream.refused is None:
            return
        begin = self.refused_positions[index]
        end = int(np.searchsorted(stream.refused.t_s, horizon, side="right"))
        if end <= begin:
            return
        self.refused_positions[index] = end
        counter = self.rejections_by_sensor.setdefault(stream.sensor_id, RejectionCounter())
        for reason, count in zip(*np.unique(stream.refused.reasons[begin:end], return_counts=True)):
            self.rejections.add(str(reason), int(count))
            counter.add(str(reason), int(count))

    def _block(self, stream: ReplayStream, begin: int, end: int, start: float, t0: float,
               now: float) -> SampleBlock:
        t = np.asarray(stream.t_s[begin:end], dtype=np.float64)
        channels = {name: None if getattr(stream, name) is None else np.asarray(getattr(stream, name)[begin:end])
                    for name in CHANNELS}
        return SampleBlock(self.config.name, stream.sensor_id,
                           np.asarray(stream.seq[begin:end], dtype=np.int64), t,
                           start + (t - t0) / self.config.speed, np.full(len(t), now), **channels)
