"""Estimating a node's clock against the host clock (offset and drift), NTP-style.

Model: ``device_s = device_ref_s + rate · (host_s − host_ref_s)`` with ``rate = 1 + drift``
(drift in ppm = ``(rate − 1)·1e6``). Host times are the host's monotonic clock in seconds,
device times the node's clock in seconds.

Observations:

* a **round trip** (time-sync request/response): host send ``t1``, node receive ``t2``, node
  send ``t3``, host receive ``t4``. The node's midpoint ``(t2+t3)/2`` is paired with the host's
  midpoint ``(t1+t4)/2``; the quality is the round-trip delay ``(t4−t1)−(t3−t2)``, and the
  pairing error is at most half of it.
* a **one-way** timestamp (serial lines, or UDP samples before the first answer): the node's
  time paired with the host's receive time; the quality is ``host − device`` (transport delay
  plus a constant), so the least-delayed samples win. The estimate lags the node by the
  minimum transport delay.

Robustness: observations fall into time bins of ``bin_s``; each bin keeps only its best
observation (minimum round trip / minimum delay), which removes queueing outliers. The line
is a Theil–Sen fit (median of pairwise slopes over at most ``max_fit_bins`` bins spread over
the window, median intercept over all of them) over the bins of the last ``window_s`` seconds,
so the estimate follows a drifting clock and is refreshed during the session. With a single
bin the drift is taken as zero.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ClockSyncSettings:
    """Settings of :class:`ClockSync` (defaults suit a 1–10 Hz sync exchange rate)."""

    bin_s: float = 0.5            #: s, each bin keeps its best observation
    window_s: float = 60.0        #: s, bins older than this (host time) are forgotten
    refit_interval_s: float = 0.25  #: s of host time between refits (the first fit is immediate)
    max_fit_bins: int = 40        #: the slope uses at most this many bins, evenly spread
    max_drift_ppm: float = 2000.0   #: a fitted drift beyond this is clamped (crystal clocks: <100)
    max_round_trip_s: float = 0.5   #: round trips longer than this are ignored

    def __post_init__(self) -> None:
        if not (self.bin_s > 0 and self.window_s >= self.bin_s and self.refit_interval_s >= 0):
            raise ValueError("ClockSyncSettings: need bin_s > 0, window_s >= bin_s, refit_interval_s >= 0")


@dataclass(frozen=True)
class ClockEstimate:
    """A fitted clock mapping (see the module docstring); times in seconds."""

    host_ref_s: float
    device_ref_s: float
    rate: float              #: device seconds per host second
    uncertainty_s: float     #: half the best round trip (round trips) or 0 (one-way)
    n_bins: int

    @property
    def drift_ppm(self) -> float:
        return (self.rate - 1.0) * 1e6

    def device_from_host(self, host_s):
        """Node clock reading at host time ``host_s`` (float or array)."""
        return self.device_ref_s + self.rate * (np.asarray(host_s, dtype=np.float64) - self.host_ref_s)

    def host_from_device(self, device_s):
        """Host time at node clock reading ``device_s`` (float or array)."""
        return self.host_ref_s + (np.asarray(device_s, dtype=np.float64) - self.device_ref_s) / self.rate

    def host_from_device_scalar(self, device_s: float) -> float:
        """:meth:`host_from_device` for one float (no NumPy overhead, for per-packet use)."""
        return self.host_ref_s + (device_s - self.device_ref_s) / self.rate

    def offset_s(self, host_s: float) -> float:
        """``device − host`` at host time ``host_s``."""
        return float(self.device_from_host(host_s)) - host_s


#: Clock readings beyond this many seconds (≈ 30 000 years) are corrupt and ignored.
MAX_CLOCK_S = 1e12


def _plausible(*values: float) -> bool:
    return all(math.isfinite(v) and abs(v) < MAX_CLOCK_S for v in values)


def theil_sen(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Slope and intercept of the Theil–Sen line through ``(x, y)`` (≥ 2 distinct x)."""
    i, j = np.triu_indices(len(x), k=1)
    dx = x[j] - x[i]
    keep = dx != 0
    slope = float(np.median((y[j] - y[i])[keep] / dx[keep]))
    intercept = float(np.median(y - slope * x))
    return slope, intercept


class ClockSync:
    """Online estimator of one node's clock; feed observations, read :attr:`estimate`."""

    def __init__(self, settings: ClockSyncSettings = ClockSyncSettings()) -> None:
        self.settings = settings
        # each bin: [bin index, host_s, device_s, quality]
        self._bins: deque[list[float]] = deque()
        self._estimate: ClockEstimate | None = None
        self._dirty = False
        self._last_fit_host_s = -math.inf
        self._one_way = True
        self.n_observations = 0

    def add_round_trip(self, t1_host_s: float, t2_device_s: float, t3_device_s: float,
                       t4_host_s: float) -> bool:
        """Add one exchange; returns ``False`` if it was ignored as implausible."""
        if not _plausible(t1_host_s, t2_device_s, t3_device_s, t4_host_s):
            return False
        round_trip = (t4_host_s - t1_host_s) - (t3_device_s - t2_device_s)
        if not (0.0 <= round_trip <= self.settings.max_round_trip_s) or t3_device_s < t2_device_s:
            return False
        if self._one_way:  # round trips supersede one-way observations
            self._bins.clear()
            self._one_way = False
            self._estimate = None
        self._observe(0.5 * (t1_host_s + t4_host_s), 0.5 * (t2_device_s + t3_device_s), round_trip)
        return True

    def add_one_way(self, device_s: float, host_receive_s: float) -> bool:
        """Add a node timestamp received at ``host_receive_s``; ignored once round trips exist."""
        if not self._one_way or not _plausible(device_s, host_receive_s):
            return False
        self._observe(host_receive_s, device_s, host_receive_s - device_s)
        return True

    @property
    def has_round_trips(self) -> bool:
        return not self._one_way

    def _observe(self, host_s: float, device_s: float, quality: float) -> None:
        self.n_observations += 1
        index = math.floor(host_s / self.settings.bin_s)
        if self._bins and self._bins[-1][0] == index:
            if quality < self._bins[-1][3]:
                self._bins[-1] = [index, host_s, device_s, quality]
                self._dirty = True
        elif not self._bins or index > self._bins[-1][0]:
            self._bins.append([index, host_s, device_s, quality])
            self._dirty = True
        horizon = index - self.settings.window_s / self.settings.bin_s
        while self._bins and self._bins[0][0] < horizon:
            self._bins.popleft()
        if self._dirty and (self._estimate is None
                            or host_s - self._last_fit_host_s >= self.settings.refit_interval_s):
            self._fit()
            self._last_fit_host_s = host_s

    def _fit(self) -> None:
        self._dirty = False
        data = np.array(self._bins, dtype=np.float64)
        host, device, quality = data[:, 1], data[:, 2], data[:, 3]
        host_ref = float(host[-1])
        if len(data) >= 2:
            pick = np.unique(np.linspace(0, len(data) - 1, min(len(data), self.settings.max_fit_bins)).round().astype(int))
            slope, _ = theil_sen(host[pick] - host_ref, device[pick] - device[-1])
            limit = self.settings.max_drift_ppm * 1e-6
            rate = min(max(slope, 1.0 - limit), 1.0 + limit)
            device_ref = float(device[-1]) + float(np.median(
                (device - device[-1]) - rate * (host - host_ref)))
        else:
            rate, device_ref = 1.0, float(device[-1])
        uncertainty = 0.0 if self._one_way else 0.5 * float(np.min(quality))
        self._estimate = ClockEstimate(host_ref, device_ref, rate, uncertainty, len(data))

    @property
    def estimate(self) -> ClockEstimate | None:
        """The current mapping (refitted at most every ``refit_interval_s``), ``None`` before
        the first observation."""
        if self._estimate is None and self._bins:
            self._fit()
        return self._estimate

    def refresh(self) -> ClockEstimate | None:
        """Refit now with every bin (e.g. at the end of a session) and return the estimate."""
        if self._bins:
            self._fit()
        return self._estimate
