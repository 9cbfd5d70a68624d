"""Aligning sensors onto one timeline: per-sensor samples resampled onto a common frame grid.

Sensors sample at their own instants (own clocks, jitter, drops). Fusion and the skeleton
want one frame per instant for every sensor. Frames lie on the grid ``k / rate_hz`` of the
host monotonic clock (seconds), shared by every source. A sensor's value at a frame time is
interpolated between its two neighbouring samples — linearly for ``acc`` (m/s²), ``gyr``
(rad/s) and ``mag_uT`` (µT), by slerp for ``q_world_from_sensor`` (scalar first) — provided
they are at most ``max_gap_s`` apart; otherwise the frame is marked invalid for that sensor
(``valid`` False) and its values are NaN so that they cannot pass for data. Nothing is
extrapolated.

:func:`align` is the pure batch function; :class:`TimelineAligner` does the same online,
emitting frames once they are ``delay_s`` old (late sensors get that long to deliver) and
keeping a bounded history per sensor.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from mimucap.acquisition.samples import SampleBlock
from mimucap.core import rotation as rot

#: Channels resampled, with their widths; quaternions are slerped, the rest linear.
ALIGNED_CHANNELS = {"acc": 3, "gyr": 3, "mag_uT": 3, "q_world_from_sensor": 4}


@dataclass(frozen=True)
class AlignmentSettings:
    """Settings of the common timeline."""

    rate_hz: float = 100.0      #: frames per second
    max_gap_s: float = 0.05     #: s, neighbouring samples further apart do not interpolate
    delay_s: float = 0.05       #: s, a frame is emitted when the host clock is this far past it
    history_s: float = 2.0      #: s of samples kept per sensor by the online aligner

    def __post_init__(self) -> None:
        if not (self.rate_hz > 0 and self.max_gap_s > 0 and self.delay_s >= 0 and self.history_s > self.delay_s):
            raise ValueError("AlignmentSettings: need rate_hz > 0, max_gap_s > 0, 0 <= delay_s < history_s")


@dataclass
class SensorTrack:
    """One sensor on the common timeline: ``valid`` (F,) and channel → (F, k) (NaN where invalid)."""

    valid: np.ndarray
    channels: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass
class AlignedFrames:
    """Frames ``t_s`` (F,) host monotonic seconds and each sensor's :class:`SensorTrack`."""

    t_s: np.ndarray
    sensors: dict[str, SensorTrack]


def align_stream(t_samples: np.ndarray, channels: Mapping[str, np.ndarray | None],
                 t_frames: np.ndarray, max_gap_s: float) -> SensorTrack:
    """Resample one sensor (``t_samples`` (N,) strictly increasing) at ``t_frames`` (F,)."""
    t_samples = np.asarray(t_samples, dtype=np.float64)
    t_frames = np.asarray(t_frames, dtype=np.float64)
    n, frames = len(t_samples), len(t_frames)
    valid = np.zeros(frames, dtype=bool)
    left = np.zeros(frames, dtype=np.int64)
    right = np.zeros(frames, dtype=np.int64)
    weight = np.zeros(frames)
    if n:
        upper = np.searchsorted(t_samples, t_frames, side="right")   # t[upper-1] <= t < t[upper]
        left = np.clip(upper - 1, 0, n - 1)
        right = np.clip(upper, 0, n - 1)
        on_sample = (upper >= 1) & (t_samples[left] == t_frames)
        right = np.where(on_sample, left, right)
        span = t_samples[right] - t_samples[left]
        between = (upper >= 1) & (upper < n) & (span <= max_gap_s)
        valid = on_sample | between
        weight = np.where(between & ~on_sample, (t_frames - t_samples[left]) / np.where(span > 0, span, 1.0), 0.0)
    track = SensorTrack(valid=valid)
    for name, values in channels.items():
        if values is None:
            continue
        values = np.asarray(values, dtype=np.float64)
        out = np.full((frames, values.shape[1]), np.nan)
        if np.any(valid):
            a, b, w = values[left[valid]], values[right[valid]], weight[valid]
            out[valid] = rot.slerp(a, b, w) if name == "q_world_from_sensor" else a + (b - a) * w[:, None]
        track.channels[name] = out
    return track


def frame_grid(t_start: float, t_end: float, rate_hz: float) -> np.ndarray:
    """Grid times ``k / rate_hz`` with ``t_start <= t <= t_end`` (host seconds)."""
    first = math.ceil(t_start * rate_hz - 1e-9)
    last = math.floor(t_end * rate_hz + 1e-9)
    return np.arange(first, last + 1, dtype=np.float64) / rate_hz


def align(streams: Mapping[str, tuple[np.ndarray, Mapping[str, np.ndarray | None]]],
          t_frames: np.ndarray, max_gap_s: float = 0.05) -> AlignedFrames:
    """Batch alignment: sensor → ``(t_samples, {channel: values})`` resampled at ``t_frames``."""
    t_frames = np.asarray(t_frames, dtype=np.float64)
    return AlignedFrames(t_frames, {sid: align_stream(t, ch, t_frames, max_gap_s)
                                    for sid, (t, ch) in streams.items()})


class _History:
    def __init__(self) -> None:
        self.t = np.empty(0)
        self.channels: dict[str, np.ndarray] = {}

    def add(self, block: SampleBlock) -> None:
        present = {name for name in ALIGNED_CHANNELS if getattr(block, name) is not None}
        if self.t.size and present != set(self.channels):   # channel set changed: restart
            self.t, self.channels = np.empty(0), {}
        self.t = np.concatenate([self.t, block.host_time_s])
        for name in present:
            old = self.channels.get(name, np.empty((0, ALIGNED_CHANNELS[name])))
            self.channels[name] = np.concatenate([old, getattr(block, name)])
        if self.t.size > 1 and np.any(np.diff(self.t) <= 0):
            order = np.argsort(self.t, kind="stable")
            keep = np.r_[True, np.diff(self.t[order]) > 0]
            self.t = self.t[order][keep]
            self.channels = {k: v[order][keep] for k, v in self.channels.items()}

    def trim(self, before_s: float) -> None:
        start = max(int(np.searchsorted(self.t, before_s)) - 1, 0)
        if start:
            self.t = self.t[start:]
            self.channels = {k: v[start:] for k, v in self.channels.items()}


class TimelineAligner:
    """Online alignment of the sensors in ``sensor_ids`` (others are ignored)."""

    def __init__(self, sensor_ids: list[str] | tuple[str, ...],
                 settings: AlignmentSettings = AlignmentSettings()) -> None:
        self.settings = settings
        self._history = {sid: _History() for sid in sensor_ids}
        self._next_frame: int | None = None

    def add_blocks(self, blocks: list[SampleBlock]) -> None:
        for block in blocks:
            history = self._history.get(block.sensor_id)
            if history is not None and len(block):
                history.add(block)
                if self._next_frame is None:
                    self._next_frame = math.ceil(float(block.host_time_s[0]) * self.settings.rate_hz)

    def frames(self, now_s: float) -> AlignedFrames | None:
        """Frames not emitted yet up to ``now_s − delay_s`` (``None`` if there are none)."""
        if self._next_frame is None:
            return None
        last = math.floor((now_s - self.settings.delay_s) * self.settings.rate_hz + 1e-9)
        if last < self._next_frame:
            return None
        oldest = last - int(self.settings.history_s * self.settings.rate_hz)
        self._next_frame = max(self._next_frame, oldest)   # after a stall, only what history covers
        t_frames = np.arange(self._next_frame, last + 1, dtype=np.float64) / self.settings.rate_hz
        self._next_frame = last + 1
        result = align({sid: (h.t, h.channels) for sid, h in self._history.items()},
                       t_frames, self.settings.max_gap_s)
        for history in self._history.values():
            history.trim(now_s - self.settings.history_s)
        return result
