"""Turns of the trunk from its rate of turning about the vertical, with their onsets and ends.

The instrumented Timed Up and Go (Salarian et al., "iTUG, a sensitive and reliable measure of
mobility", 2010) times its turns on the trunk's angular velocity about the vertical: a turn is
one bell of that rate. Here the rate (:func:`~.segment_motion.yaw_rate_dps`) is low-passed at
``lowpass_hz`` (zero phase: no delay) to calm the trunk's rotation within each stride; a turn
is a stretch turning faster than ``min_peak_dps`` whose heading changes by at least
``min_angle_deg``. From its peak the turn extends both ways until the rate, counted in the
turn's direction, reaches zero or a valley below ``valley_fraction`` of the peak (where the
next movement begins, e.g. the trunk's rotation of the first stride after the turn).

Input: ``t_s`` (T,) s and ``yaw_rate_dps`` (T,) deg/s (positive to the left). Output:
:class:`TrunkTurn` in time order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mimucap.core.analysis.signals import check_finite, check_time, lowpass


@dataclass(frozen=True)
class TurnSettings:
    """``lowpass_hz`` smoothing of the rate; ``min_peak_dps`` slowest peak rate of a turn
    (deg/s); ``min_angle_deg`` smallest turn (deg); ``valley_fraction`` of the peak below which
    a valley ends the turn."""

    lowpass_hz: float = 1.5
    min_peak_dps: float = 30.0
    min_angle_deg: float = 90.0
    valley_fraction: float = 0.2

    def __post_init__(self) -> None:
        if self.lowpass_hz <= 0 or self.min_peak_dps <= 0 or self.min_angle_deg <= 0:
            raise ValueError("turn settings need positive lowpass_hz, min_peak_dps and min_angle_deg")
        if not 0.0 < self.valley_fraction < 1.0:
            raise ValueError("valley_fraction must be between 0 and 1")


DEFAULT_TURN_SETTINGS = TurnSettings()


@dataclass(frozen=True)
class TrunkTurn:
    """One turn: ``start_s`` .. ``end_s``, ``angle_deg`` signed (positive to the left),
    ``peak_rate_dps`` the trunk's fastest turning (deg/s, positive) and when (``peak_s``)."""

    start_s: float
    end_s: float
    angle_deg: float
    peak_rate_dps: float
    peak_s: float

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


def find_trunk_turns(t_s: np.ndarray, yaw_rate_dps: np.ndarray,
                     settings: TurnSettings = DEFAULT_TURN_SETTINGS) -> list[TrunkTurn]:
    """Every turn of the trunk (module doc), in time order."""
    t = check_time(t_s, "trunk turns")
    raw = check_finite(yaw_rate_dps, "trunk turning rate")
    if raw.shape != t.shape:
        raise ValueError(f"trunk turns: {raw.shape[0]} rate samples for {t.shape[0]} time stamps")
    rate = lowpass(raw, 1.0 / float(np.median(np.diff(t))), settings.lowpass_hz)
    turns: list[TrunkTurn] = []
    fast = np.abs(rate) > settings.min_peak_dps
    padded = np.concatenate(([False], fast, [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    for a, b in zip(edges[0::2], edges[1::2]):
        peak = a + int(np.argmax(np.abs(rate[a:b])))
        sign = float(np.sign(rate[peak]))
        along = sign * rate
        start = _bound(along, peak, -1, settings.valley_fraction)
        end = _bound(along, peak, +1, settings.valley_fraction)
        if turns and t[start] < turns[-1].end_s:
            continue  # the same bell as the turn before (a second pass over the threshold)
        angle = float(np.trapezoid(rate[start:end + 1], t[start:end + 1]))
        if abs(angle) >= settings.min_angle_deg:
            turns.append(TrunkTurn(_zero_time(t, along, start, -1), _zero_time(t, along, end, +1), angle,
                                   float(along[peak]), float(t[peak])))
    return turns


def _bound(along: np.ndarray, peak: int, step: int, valley_fraction: float) -> int:
    """Index where the bell around ``peak`` ends going in direction ``step``: the first sample
    at or below zero, or a valley below ``valley_fraction`` of the peak."""
    k = peak
    last = along.shape[0] - 1
    level = valley_fraction * along[peak]
    while 0 < k < last and along[k] > 0.0:
        nxt = along[k + step]
        if nxt > along[k] and along[k] < level:
            break
        k += step
    return k


def _zero_time(t: np.ndarray, along: np.ndarray, k: int, step: int) -> float:
    """Time of the zero crossing between ``k`` and its neighbour towards the peak, or ``t[k]``
    when the bell ends in a valley above zero."""
    inner = k - step
    if not 0 <= inner < t.shape[0] or along[k] > 0.0 or along[inner] <= 0.0:
        return float(t[k])
    a, b = along[k], along[inner]
    return float(t[k] + a / (a - b) * (t[inner] - t[k]))
