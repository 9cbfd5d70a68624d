"""What the live plots draw, computed without Qt: decimated curves, per-column bounds,
vertical ranges that stay still, and round tick values.

* :func:`peak_decimate` shortens a long window to at most ``max_points`` rows keeping every
  bin's extremes, so that no peak or gap disappears from a plot a few hundred pixels wide;
* :func:`column_bounds` gives each column's finite minimum and maximum (None when empty);
* :class:`SteadyRange` grows at once to hold the data and shrinks only after the data has
  used less than half of it for :data:`SHRINK_AFTER_S` (a still axis is cheap to draw and easy
  to read);
* :func:`nice_ticks` picks about four round values (1, 2 or 5 × 10^k) with their labels.

Units are those of the data (s on the time axis; m/s², rad/s, µT or deg on the other).
"""

from __future__ import annotations

import numpy as np

#: Seconds a plot's data must stay well inside its range before the range shrinks.
SHRINK_AFTER_S = 2.0

#: Most points drawn per curve (a plot is a few hundred pixels wide; longer windows are
#: decimated to each bin's extremes).
MAX_POINTS = 1200


def peak_decimate(x: np.ndarray, values: np.ndarray, max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Shorten ``x`` ``(N,)`` and ``values`` ``(N, C)`` to at most ``max_points`` rows keeping
    each bin's minimum and maximum (per column), so that no peak disappears from a plot."""
    n = len(x)
    if n <= max_points:
        return x, values
    per_bin = int(np.ceil(2 * n / max_points))
    bins = n // per_bin
    head = bins * per_bin
    shaped = values[:head].reshape(bins, per_bin, values.shape[1])
    # fmin/fmax skip NaN, and an all-NaN bin stays NaN (a gap), without nanmin's warning
    low, high = np.fmin.reduce(shaped, axis=1), np.fmax.reduce(shaped, axis=1)
    out_values = np.empty((2 * bins, values.shape[1]))
    out_values[0::2], out_values[1::2] = low, high
    x_bins = x[:head].reshape(bins, per_bin)
    out_x = np.empty(2 * bins)
    out_x[0::2], out_x[1::2] = x_bins[:, 0], x_bins[:, -1]
    if head < n:  # the newest few samples as they are
        out_x = np.concatenate([out_x, x[head:]])
        out_values = np.concatenate([out_values, values[head:]])
    return out_x, out_values


def nice_ticks(low: float, high: float, wanted: int = 4, most: int | None = None) -> list[tuple[float, str]]:
    """About ``wanted`` round values (steps of 1, 2 or 5 × 10^k) inside ``low`` … ``high``,
    each with its label (as many decimals as the step needs); never more than ``most`` of them
    (at least two): a coarser step instead (e.g. a plot too short for more labels) or, when a
    coarser step would leave a single value, the values nearest zero (positive first)."""
    span = high - low
    if not span > 0 or not np.isfinite(span):
        return []
    raw = span / wanted
    magnitude = 10.0 ** np.floor(np.log10(raw))
    step = next(m * magnitude for m in (1.0, 2.0, 5.0, 10.0) if m * magnitude >= raw * (1 - 1e-9))
    values = _multiples(low, high, step)
    while most is not None and len(values) > max(most, 2):
        coarser = _next_round_step(step)
        if len(_multiples(low, high, coarser)) < 2:
            # the coarser step would leave a single tick: keep this one, the values nearest 0
            values = np.sort(values[np.argsort(np.abs(values) - 1e-9 * np.sign(values), kind="stable")[:max(most, 2)]])
            break
        step, values = coarser, _multiples(low, high, coarser)
    decimals = max(0, -int(np.floor(np.log10(step) + 1e-9)))
    return [(float(v), f"{0.0 if abs(v) < step / 1e6 else v:.{decimals}f}") for v in values]


def _multiples(low: float, high: float, step: float) -> np.ndarray:
    """The multiples of ``step`` from ``low`` to ``high`` (inclusive, to rounding)."""
    first = np.ceil(low / step - 1e-9) * step
    return np.arange(first, high + 1e-9 * step, step)


def _next_round_step(step: float) -> float:
    """The round step after ``step`` in 1, 2, 5, 10, 20, … × 10^k."""
    magnitude = 10.0 ** np.floor(np.log10(step) + 1e-9)
    mantissa = step / magnitude
    return (2.0 if mantissa < 1.5 else 5.0 if mantissa < 3.5 else 10.0) * magnitude


def column_bounds(values: np.ndarray) -> tuple[list[float | None], list[float | None]]:
    """Per column of ``values`` ``(N, C)``: its smallest and largest finite value (None if none)."""
    if len(values) == 0:
        return [None] * values.shape[1], [None] * values.shape[1]
    low, high = np.fmin.reduce(values, axis=0), np.fmax.reduce(values, axis=0)  # NaN skipped
    return ([None if np.isnan(v) else float(v) for v in low], [None if np.isnan(v) else float(v) for v in high])


class SteadyRange:
    """A vertical range that grows at once to hold the data and shrinks only after the data
    has used less than half of it for :data:`SHRINK_AFTER_S` (a steady axis is cheap to draw
    and easy to read)."""

    def __init__(self, min_span: float) -> None:
        self.min_span = float(min_span)
        self.low, self.high = -0.5 * self.min_span, 0.5 * self.min_span
        self._small_since: float | None = None

    def update(self, low: float | None, high: float | None, now_s: float) -> bool:
        """Fit the range to data spanning ``low`` … ``high`` (None: no data); True if it changed."""
        if low is None or high is None:
            return False
        lo, hi = float(low), float(high)
        span = max(hi - lo, self.min_span)
        centre = 0.5 * (lo + hi)
        wanted = (centre - 0.6 * span, centre + 0.6 * span)  # 10 % margin on each side
        if lo < self.low or hi > self.high:
            self.low, self.high = wanted
            self._small_since = None
            return True
        if span < 0.5 * (self.high - self.low) and (self.high - self.low) > 1.2 * self.min_span + 1e-12:
            if self._small_since is None:
                self._small_since = now_s
            elif now_s - self._small_since >= SHRINK_AFTER_S:
                self.low, self.high = wanted
                self._small_since = None
                return True
        else:
            self._small_since = None
        return False
