"""Signal helpers for gait analysis: uniform resampling, zero-phase low-pass filtering and
sub-sample timing of extrema and zero crossings.

Times are seconds (float64), signals any unit; arrays are (N,) or (N, k) with time first.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, sosfiltfilt


def check_time(t_s: np.ndarray, what: str, min_samples: int = 10) -> np.ndarray:
    """``t_s`` as float64 (N,), finite and strictly increasing; ``ValueError`` naming ``what``."""
    t = np.asarray(t_s, dtype=np.float64)
    if t.ndim != 1 or t.shape[0] < min_samples:
        raise ValueError(f"{what}: need at least {min_samples} samples, got shape {t.shape}")
    if not np.all(np.isfinite(t)):
        raise ValueError(f"{what}: time stamps contain NaN or infinity")
    if np.any(np.diff(t) <= 0):
        index = int(np.argmax(np.diff(t) <= 0))
        raise ValueError(f"{what}: time stamps do not increase at sample {index + 1}")
    return t


def check_finite(values: np.ndarray, what: str) -> np.ndarray:
    """``values`` as float64; ``ValueError`` naming ``what`` and the first bad sample if any
    value is NaN or infinite."""
    array = np.asarray(values, dtype=np.float64)
    bad = ~np.isfinite(array)
    if np.any(bad):
        index = int(np.argmax(bad.reshape(array.shape[0], -1).any(axis=1)))
        raise ValueError(f"{what}: NaN or infinite value at sample {index}")
    return array


def uniform_grid(t_s: np.ndarray) -> tuple[np.ndarray, float]:
    """A uniform time grid over ``t_s`` at its median sample interval; returns (grid, rate_hz).
    A span that is a whole number of intervals up to rounding keeps its last sample."""
    dt = float(np.median(np.diff(t_s)))
    n = int(np.floor((t_s[-1] - t_s[0]) / dt + 1e-6)) + 1
    return t_s[0] + dt * np.arange(n), 1.0 / dt


def resample(t_s: np.ndarray, values: np.ndarray, grid_s: np.ndarray) -> np.ndarray:
    """Linear interpolation of ``values`` (N,) or (N, k) from ``t_s`` onto ``grid_s``; dropped
    samples (gaps) are bridged linearly."""
    v = np.asarray(values, dtype=np.float64)
    if v.ndim == 1:
        return np.interp(grid_s, t_s, v)
    return np.stack([np.interp(grid_s, t_s, v[:, k]) for k in range(v.shape[1])], axis=-1)


def lowpass(values: np.ndarray, rate_hz: float, cutoff_hz: float, order: int = 2) -> np.ndarray:
    """Zero-phase Butterworth low-pass (forward and backward: no delay, which would shift
    every event time) along axis 0; returns ``values`` unchanged when the cutoff is at or
    above the Nyquist frequency or the signal is too short to filter."""
    nyquist = 0.5 * rate_hz
    if cutoff_hz >= nyquist * 0.95:
        return np.asarray(values, dtype=np.float64)
    sos = butter(order, cutoff_hz / nyquist, output="sos")
    v = np.asarray(values, dtype=np.float64)
    if v.shape[0] <= 3 * (2 * len(sos) + 1):
        return v
    return sosfiltfilt(sos, v, axis=0)


def zero_crossing_time(t_s: np.ndarray, values: np.ndarray, index: int) -> float:
    """Time of the zero crossing between samples ``index`` and ``index + 1`` (linear)."""
    a, b = values[index], values[index + 1]
    if a == b:
        return float(t_s[index])
    fraction = a / (a - b)
    return float(t_s[index] + fraction * (t_s[index + 1] - t_s[index]))


def extremum_time(t_s: np.ndarray, values: np.ndarray, index: int) -> float:
    """Time of the extremum at sample ``index`` refined by a parabola through its neighbours."""
    if index <= 0 or index >= len(values) - 1:
        return float(t_s[index])
    a, b, c = values[index - 1], values[index], values[index + 1]
    denominator = a - 2.0 * b + c
    if denominator == 0.0:
        return float(t_s[index])
    offset = 0.5 * (a - c) / denominator
    offset = float(np.clip(offset, -0.5, 0.5))
    return float(t_s[index] + offset * (t_s[index + 1] - t_s[index]))
