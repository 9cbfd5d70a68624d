"""Replay driver: plays already-loaded sensor streams back in (scaled) real time.

The acquisition layer does not read files (``io`` is out of its reach); the caller (see
``mimucap.session.sources``) loads a session file or an export and hands the arrays over in a
:class:`ReplaySourceConfig`. Sample ``k`` of a stream recorded at ``t_s[k]`` is released at
host time ``start + (t_s[k] − t0) / speed`` and stamped with that host time; the recorded time
is kept as ``device_time_s``. The source reports ``finished`` after its last sample.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from threading import Event

import numpy as np

from mimucap.acquisition.messages import STATE_FINISHED, STATE_RUNNING, BlocksMessage, WorkerReport
from mimucap.acquisition.outbox import Outbox
from mimucap.acquisition.samples import CHANNELS, SampleBlock


@dataclass(frozen=True, eq=False)
class ReplayStream:
    """One sensor's recorded samples: ``t_s`` (N,) s increasing, ``seq`` (N,) int, channels as
    in :class:`~mimucap.acquisition.samples.SampleBlock` (``None`` when absent)."""

    sensor_id: str
    t_s: np.ndarray
    seq: np.ndarray
    acc: np.ndarray | None = None
    gyr: np.ndarray | None = None
    mag_uT: np.ndarray | None = None
    q_world_from_sensor: np.ndarray | None = None
    calibration: np.ndarray | None = None
    battery_pct: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.t_s)
        if len(self.seq) != n or (n > 1 and not np.all(np.diff(self.t_s) >= 0)):
            raise ValueError(f"replay sensor {self.sensor_id}: t_s must be non-decreasing and match seq")
        for name in CHANNELS:
            value = getattr(self, name)
            if value is not None and len(value) != n:
                raise ValueError(f"replay sensor {self.sensor_id}: {name} has {len(value)} rows, t_s has {n}")


@dataclass(frozen=True, eq=False)
class ReplaySourceConfig:
    """A replay source (picklable; the arrays travel to the worker process once)."""

    name: str = "replay"
    streams: tuple[ReplayStream, ...] = ()
    speed: float = 1.0              #: × real time
    block_interval_s: float = 0.01  #: s of host time between released blocks
    report_interval_s: float = 0.5

    def __post_init__(self) -> None:
        if not self.speed > 0:
            raise ValueError(f"replay speed must be > 0, got {self.speed}")


class ReplayDriver:
    def __init__(self, config: ReplaySourceConfig, outbox: Outbox) -> None:
        self.config = config
        self.outbox = outbox
        self.released = 0

    def report(self, state: str, message: str = ""):
        return WorkerReport(self.config.name, state, message, overflow_samples=self.outbox.overflow_samples)

    def run(self, stop: Event) -> None:
        streams = [s for s in self.config.streams if len(s.t_s)]
        if not streams:
            self.outbox.send_report(self.report(STATE_FINISHED, "nothing to replay"))
            return
        t0 = min(float(s.t_s[0]) for s in streams)
        start = time.monotonic()
        positions = [0] * len(streams)
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
            if blocks:
                self.released += sum(len(b) for b in blocks)
                self.outbox.send_blocks(BlocksMessage(self.config.name, tuple(blocks)))
            if all(positions[i] >= len(s.t_s) for i, s in enumerate(streams)):
                self.outbox.send_report(self.report(STATE_FINISHED, f"replayed {self.released} samples"))
                return
            if self.outbox.report_due(now):
                self.outbox.send_report(self.report(STATE_RUNNING))
            stop.wait(self.config.block_interval_s)

    def _block(self, stream: ReplayStream, begin: int, end: int, start: float, t0: float,
               now: float) -> SampleBlock:
        t = np.asarray(stream.t_s[begin:end], dtype=np.float64)
        channels = {name: None if getattr(stream, name) is None else np.asarray(getattr(stream, name)[begin:end])
                    for name in CHANNELS}
        return SampleBlock(self.config.name, stream.sensor_id,
                           np.asarray(stream.seq[begin:end], dtype=np.int64), t,
                           start + (t - t0) / self.config.speed, np.full(len(t), now), **channels)
