"""Per-sensor acquisition statistics: rate, latency, drops, rejections, last-seen time.

All times are the host's monotonic clock in seconds. *Latency* is the time from a sample's
(mapped) host timestamp to its arrival in the pipeline (the supervisor's poll); *drops* are
missing sequence numbers (gaps), counted when the next sample arrives, less the samples the
source received but refused within those gaps (its ``refused_in_gaps``: they are counted as
rejections, with their reason, not as packet loss).
"""

from __future__ import annotations

import math
from bisect import bisect_left
from itertools import islice
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from mimucap.core.sensor_samples import SensorSamples

#: After this long (s) without an arrival, a sensor's rate is taken over the time up to now
#: (it falls), not up to its last arrival.
ARRIVAL_GRACE_S = 0.1


@dataclass(frozen=True)
class SensorStats:
    """A snapshot of one sensor's statistics."""

    sensor_id: str
    source: str
    received: int               #: samples delivered to the pipeline
    drops: int                  #: sequence numbers never received (gaps less refused samples)
    rate_hz: float              #: samples per second over the last ``window_s``
    latency_p50_s: float        #: NaN before the first sample
    latency_p95_s: float
    last_seen_s: float          #: host monotonic time of the last arrival (NaN if none)
    rejections: dict[str, int] = field(default_factory=dict)

    @property
    def drop_fraction(self) -> float:
        expected = self.received + self.drops
        return self.drops / expected if expected else 0.0


class _RecentValues:
    """The last ``capacity`` float64 values appended, read oldest first.

    A ring of preallocated memory (grown by doubling up to ``capacity``), so that appending
    a block and reading the values back cost numpy copies, not per-value Python work.
    """

    def __init__(self, capacity: int) -> None:
        self.capacity = max(int(capacity), 0)
        self._data = np.empty(min(self.capacity, 1024))
        self._start = 0  # index of the oldest value
        self._count = 0

    def __len__(self) -> int:
        return self._count

    def extend(self, values: np.ndarray) -> None:
        """Append ``values``, a 1-D float64 array (the oldest values beyond the capacity go)."""
        n = values.shape[0]
        if n == 0 or self.capacity == 0:
            return
        if n > self.capacity:
            values, n = values[-self.capacity :], self.capacity
        if self._count + n > self._data.size and self._data.size < self.capacity:  # grow
            ordered = self.values()
            self._data = np.empty(min(self.capacity, max(2 * self._data.size, self._count + n)))
            self._data[: self._count] = ordered
            self._start = 0
        size = self._data.size
        end = self._start + self._count
        if end >= size:
            end -= size
        stop = end + n
        if stop <= size:
            self._data[end:stop] = values
        else:
            self._data[end:] = values[: size - end]
            self._data[: stop - size] = values[size - end :]
        overwritten = max(self._count + n - size, 0)
        self._count = min(self._count + n, size)
        self._start = (self._start + overwritten) % size

    def values(self) -> np.ndarray:
        """A copy, oldest first, shape ``(len(self),)``."""
        stop = self._start + self._count
        if stop <= self._data.size:
            return self._data[self._start : stop].copy()
        return np.concatenate((self._data[self._start :], self._data[: stop - self._data.size]))


def percentiles_linear(values: np.ndarray, percents: tuple[float, ...]) -> list[float]:
    """``np.percentile(values, percents)`` (its default "linear" method), the same numbers.

    One sort of the values, then numpy's own interpolation formula for each percentile; NaN
    when ``values`` holds a NaN. ``values`` is 1-D and not empty.
    """
    ordered = np.sort(np.asarray(values, dtype=np.float64))
    n = ordered.shape[0]
    if math.isnan(ordered[-1]):  # NaN sorts last
        return [float("nan")] * len(percents)
    result = []
    for percent in percents:
        virtual = (n - 1) * (percent / 100)
        below = math.floor(virtual)
        above = below + 1
        if virtual >= n - 1:
            below = above = -1
        a, b = float(ordered[below]), float(ordered[above])
        gamma = virtual - below
        diff = b - a
        result.append(b - diff * (1 - gamma) if gamma >= 0.5 else a + diff * gamma)
    return result


def _arrival_time(arrival: tuple[float, int]) -> float:
    return arrival[0]


class SensorStatsTracker:
    """Accumulates :class:`SensorStats` for one sensor from the blocks it delivers."""

    def __init__(self, sensor_id: str, source: str, window_s: float = 2.0,
                 latency_samples: int = 4096) -> None:
        self.sensor_id = sensor_id
        self.source = source
        self.window_s = window_s
        self.received = 0
        self.gaps = 0           # sequence numbers missing between the samples received
        self.last_seq: int | None = None
        self.last_seen_s = float("nan")
        # Arrivals within the window: (host time (s), samples received before it).
        self._arrivals: deque[tuple[float, int]] = deque()
        self._arrivals_in_order = True  # arrival times never decreased (then bisect finds the window)
        self._latencies = _RecentValues(latency_samples)
        self.rejections: dict[str, int] = {}
        self.refused_in_gaps = 0  # samples the source refused within the sequence gaps (not drops)

    def add_block(self, block: SensorSamples, arrival_s: float) -> None:
        n = len(block)
        if n == 0:
            return
        # sequence numbers of a sensor are strictly increasing (workers refuse stale ones),
        # so the gaps inside a block are its span minus its length
        first, last = int(block.seq[0]), int(block.seq[-1])
        self.gaps += max(last - first + 1 - n, 0)
        if self.last_seq is not None and first > self.last_seq + 1:
            self.gaps += first - self.last_seq - 1
        self.last_seq = last if self.last_seq is None else max(self.last_seq, last)
        if self._arrivals and not arrival_s >= self._arrivals[-1][0]:
            self._arrivals_in_order = False
        self._arrivals.append((arrival_s, self.received))
        self.received += n
        self.last_seen_s = arrival_s
        while self._arrivals and self._arrivals[0][0] < arrival_s - self.window_s:
            self._arrivals.popleft()
        self._latencies.extend(np.asarray(arrival_s - block.t_s, dtype=np.float64).ravel())

    def latencies_s(self) -> np.ndarray:
        """The most recent latencies (s), oldest first."""
        return self._latencies.values()

    def _arrivals_since(self, t_from_s: float) -> list[tuple[float, int]]:
        """``(arrival time, samples it brought)`` of the arrivals at or after ``t_from_s``."""
        arrivals = self._arrivals
        first = (bisect_left(arrivals, t_from_s, key=_arrival_time) if self._arrivals_in_order
                 else 0)
        kept = list(islice(arrivals, first, None))
        brought = [after - before for (_t, before), (_u, after)
                   in zip(kept, kept[1:] + [(0.0, self.received)])]
        return [(t, n) for (t, _before), n in zip(kept, brought) if t >= t_from_s]

    def rate_hz(self, now_s: float) -> float:
        """Samples per second over the arrivals of the last ``window_s``.

        Samples come in batches (one per poll or message), so counting every sample that
        arrived within the window would be off by up to a batch at each end (a steady 100 Hz
        read as 97.5-101). The rate is instead the samples that arrived *after* the first
        arrival of the window divided by the time from that arrival to the last one: exact for
        a steady stream whatever the batching. Once nothing has arrived for
        :data:`ARRIVAL_GRACE_S`, the time runs on to ``now_s``, so a sensor that stopped
        sending shows a falling rate (and 0 once the window holds no arrival).
        """
        window = self._arrivals_since(now_s - self.window_s)
        if not window:
            return 0.0
        if len(window) == 1:
            return window[0][1] / min(self.window_s, max(now_s - window[0][0], 1e-3))
        first_t, first_n = min(window)
        last_t = max(t for t, _n in window)
        span = max(last_t - first_t, now_s - first_t - ARRIVAL_GRACE_S, 1e-3)
        return (sum(n for _t, n in window) - first_n) / span

    def snapshot(self, now_s: float) -> SensorStats:
        rate = self.rate_hz(now_s)
        latencies = self.latencies_s()
        p50, p95 = (percentiles_linear(latencies, (50, 95)) if latencies.size
                    else (float("nan"), float("nan")))
        drops = max(self.gaps - self.refused_in_gaps, 0)
        return SensorStats(self.sensor_id, self.source, self.received, drops, float(rate),
                           float(p50), float(p95), self.last_seen_s, dict(self.rejections))
