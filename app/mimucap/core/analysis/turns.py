"""Turns from a continuous heading signal (the pelvis's, from its orientation): intervals where
the body turns steadily, found before the strides are judged.

After El-Gohary et al. 2014 ("Continuous monitoring of turning in patients with movement
disability", Sensors 14:356-369): the heading rate is low-passed (``lowpass_hz``, removing the
pelvis's rotation within each stride), samples turning faster than ``rate_threshold_dps``
are grouped into intervals (gaps shorter than ``merge_gap_s`` bridged), each interval grows
outwards while the rate stays above a quarter of the threshold, and an interval counts as a
turn when its heading changes by at least ``min_angle_deg``.

Input: ``t_s`` (T,) s and ``heading_rad`` (T,) unwrapped heading (rad, positive counter-
clockwise from above). Output: :class:`~.strides.Interval` with ``angle_deg`` signed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mimucap.core.analysis.signals import check_finite, check_time, lowpass, resample, uniform_grid
from mimucap.core.analysis.strides import Interval


@dataclass(frozen=True)
class TurnSettings:
    """``lowpass_hz`` smoothing of the heading rate; ``rate_threshold_dps`` turning rate (°/s);
    ``merge_gap_s`` pauses bridged within one turn (s); ``min_angle_deg`` smallest turn (°)."""

    lowpass_hz: float = 0.8
    rate_threshold_dps: float = 15.0
    merge_gap_s: float = 0.5
    min_angle_deg: float = 45.0


DEFAULT_TURN_SETTINGS = TurnSettings()


def find_turns(t_s: np.ndarray, heading_rad: np.ndarray, settings: TurnSettings = DEFAULT_TURN_SETTINGS) -> list[Interval]:
    """The turns of a heading signal (module doc)."""
    t = check_time(t_s, "heading")
    heading = check_finite(heading_rad, "heading")
    grid, rate_hz = uniform_grid(t)
    psi = resample(t, heading, grid)
    rate = lowpass(np.gradient(psi, 1.0 / rate_hz), rate_hz, settings.lowpass_hz)
    fast = np.abs(np.degrees(rate)) > settings.rate_threshold_dps
    turns: list[Interval] = []
    index = np.flatnonzero(fast)
    if index.size == 0:
        return turns
    gap = max(int(round(settings.merge_gap_s * rate_hz)), 1)
    starts = [index[0]]
    ends = []
    for a, b in zip(index[:-1], index[1:]):
        if b - a > gap:
            ends.append(a)
            starts.append(b)
    ends.append(index[-1])
    slow = np.abs(np.degrees(rate)) > 0.25 * settings.rate_threshold_dps
    for a, b in zip(starts, ends):
        while a > 0 and slow[a - 1]:
            a -= 1
        while b < grid.shape[0] - 1 and slow[b + 1]:
            b += 1
        angle = float(np.degrees(psi[b] - psi[a]))
        if abs(angle) >= settings.min_angle_deg:
            if turns and grid[a] <= turns[-1].end_s:
                continue
            turns.append(Interval(float(grid[a]), float(grid[b]), 0, angle))
    return turns

