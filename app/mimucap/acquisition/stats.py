"""Per-sensor acquisition statistics: rate, latency, drops, rejections, last-seen time.

All times are the host's monotonic clock in seconds. *Latency* is the time from a sample's
(mapped) host timestamp to its arrival in the pipeline (the supervisor's poll); *drops* are
missing sequence numbers (gaps), counted when the next sample arrives.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from mimucap.acquisition.samples import SampleBlock


@dataclass(frozen=True)
class SensorStats:
    """A snapshot of one sensor's statistics."""

    sensor_id: str
    source: str
    received: int               #: samples delivered to the pipeline
    drops: int                  #: sequence numbers never received (gaps)
    rate_hz: float              #: samples per second over the last ``window_s``
    latency_p50_s: float        #: NaN before the first sample
    latency_p95_s: float
    last_seen_s: float          #: host monotonic time of the last arrival (NaN if none)
    rejections: dict[str, int] = field(default_factory=dict)

    @property
    def drop_fraction(self) -> float:
        expected = self.received + self.drops
        return self.drops / expected if expected else 0.0


class SensorStatsTracker:
    """Accumulates :class:`SensorStats` for one sensor from the blocks it delivers."""

    def __init__(self, sensor_id: str, source: str, window_s: float = 2.0,
                 latency_samples: int = 4096) -> None:
        self.sensor_id = sensor_id
        self.source = source
        self.window_s = window_s
        self.received = 0
        self.drops = 0
        self.last_seq: int | None = None
        self.last_seen_s = float("nan")
        self._arrivals: deque[tuple[float, int]] = deque()
        self._latencies: deque[float] = deque(maxlen=latency_samples)
        self.rejections: dict[str, int] = {}

    def add_block(self, block: SampleBlock, arrival_s: float) -> None:
        n = len(block)
        if n == 0:
            return
        # sequence numbers of a sensor are strictly increasing (workers refuse stale ones),
        # so the gaps inside a block are its span minus its length
        first, last = int(block.seq[0]), int(block.seq[-1])
        self.drops += max(last - first + 1 - n, 0)
        if self.last_seq is not None and first > self.last_seq + 1:
            self.drops += first - self.last_seq - 1
        self.last_seq = last if self.last_seq is None else max(self.last_seq, last)
        self.received += n
        self.last_seen_s = arrival_s
        self._arrivals.append((arrival_s, n))
        while self._arrivals and self._arrivals[0][0] < arrival_s - self.window_s:
            self._arrivals.popleft()
        self._latencies.extend((arrival_s - block.host_time_s).tolist())

    def latencies_s(self) -> np.ndarray:
        """The most recent latencies (s), oldest first."""
        return np.asarray(self._latencies, dtype=np.float64)

    def snapshot(self, now_s: float) -> SensorStats:
        in_window = [(t, n) for t, n in self._arrivals if t >= now_s - self.window_s]
        span = self.window_s
        if self.received and in_window:
            first_arrival = self._arrivals[0][0] if len(self._arrivals) else now_s
            span = min(self.window_s, max(now_s - first_arrival, 1e-3))
        rate = sum(n for _t, n in in_window) / span if in_window else 0.0
        latencies = self.latencies_s()
        p50, p95 = (np.percentile(latencies, [50, 95]).tolist() if latencies.size
                    else (float("nan"), float("nan")))
        return SensorStats(self.sensor_id, self.source, self.received, self.drops, float(rate),
                           float(p50), float(p95), self.last_seen_s, dict(self.rejections))
