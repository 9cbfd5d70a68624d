"""The timed walking tests: the 10-metre walk and the 2- and 6-minute walks.

* **Start**: the first step, the final contact (toe-off) that begins the first run of at least
  ``min_steps`` swings (of either foot) without a pause longer than ``max_step_gap_s``; a
  weight shift or the handling of the sensors before the test is no such run. Within the
  window ``within_s`` when one is given (the user's start and stop markers).
* **10-metre walk** (Bohannon & Andrews, "Normal walking speed: a descriptive meta-analysis",
  2011: the walkway's first and last 2 m let the subject speed up and slow down): the middle
  60 % of the walkway (6 m of 10) is timed, from where the walked distance
  (:mod:`.progression`) since the start reaches 20 % of ``walkway_m`` to where it reaches
  80 %; the speed is that distance over that time. The cadence (steps/min) counts the initial
  contacts of both feet in the timed section: 60 × (contacts − 1) over the time from the first
  to the last.
* **2- and 6-minute walks** (ATS, "ATS statement: guidelines for the six-minute walk test",
  2002): the distance walked in ``duration_s`` from the start, its mean speed, and the
  distance and speed of each minute; the last minute against the first in per cent.

Times in seconds, distances in metres, speeds in m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mimucap.core.analysis.gait_events import SwingEvents
from mimucap.core.analysis.progression import Progression


@dataclass(frozen=True)
class StartSettings:
    """``min_steps`` swings that make a walk; ``max_step_gap_s`` longest pause between the
    starts of consecutive swings (of either foot) within it."""

    min_steps: int = 4
    max_step_gap_s: float = 1.5


DEFAULT_START_SETTINGS = StartSettings()


@dataclass(frozen=True)
class TenMetreWalk:
    """``start_s`` first step; ``timed_s`` (start, end) of the timed middle section;
    ``timed_m`` its length; ``speed_m_s``; ``cadence_steps_min`` (NaN with fewer than two
    contacts in the section)."""

    start_s: float
    timed_s: tuple[float, float]
    timed_m: float
    speed_m_s: float
    cadence_steps_min: float


@dataclass(frozen=True)
class TimedWalk:
    """``start_s`` first step; ``duration_s``; ``distance_m``; ``speed_m_s``; per minute
    ``minute_distances_m``; ``last_vs_first_minute_percent`` the last full minute's distance
    as a percentage of the first's."""

    start_s: float
    duration_s: float
    distance_m: float
    speed_m_s: float
    minute_distances_m: tuple[float, ...]

    @property
    def minute_speeds_m_s(self) -> tuple[float, ...]:
        return tuple(d / 60.0 for d in self.minute_distances_m)

    @property
    def last_vs_first_minute_percent(self) -> float:
        d = self.minute_distances_m
        return 100.0 * d[-1] / d[0] if len(d) > 1 and d[0] > 0 else math.nan


def walking_start(events: dict[str, SwingEvents], within_s: tuple[float, float] | None = None,
                  settings: StartSettings = DEFAULT_START_SETTINGS) -> float:
    """The first step (module doc); ``ValueError`` when no walk is found."""
    low, high = within_s if within_s is not None else (-math.inf, math.inf)
    lifts = sorted(float(fc) for found in events.values() for fc in found.t_fc_s
                   if math.isfinite(fc) and low <= fc <= high)
    for k in range(len(lifts) - settings.min_steps + 1):
        run = lifts[k:k + settings.min_steps]
        if max(np.diff(run), default=0.0) <= settings.max_step_gap_s:
            return run[0]
    raise ValueError(f"no walk found: no {settings.min_steps} steps in a row"
                     + ("" if within_s is None else f" between {low:.1f} and {high:.1f} s"))


def ten_metre_walk(progression: Progression, events: dict[str, SwingEvents], start_s: float,
                   walkway_m: float = 10.0) -> TenMetreWalk:
    """The 10-metre walk (module doc) from ``start_s``; ``ValueError`` when the walk does not
    cover the timed section."""
    if not walkway_m > 0:
        raise ValueError(f"the walkway must be longer than 0 m, got {walkway_m}")
    origin = progression.distance_at(start_s)
    enter = progression.time_at_distance(origin + 0.2 * walkway_m, after_s=start_s)
    leave = progression.time_at_distance(origin + 0.8 * walkway_m, after_s=start_s)
    if not (math.isfinite(enter) and math.isfinite(leave)):
        walked = float(progression.distance_m[-1] - origin)
        raise ValueError(f"the walk covers {walked:.1f} m of the {walkway_m:g}-m walkway: it does not "
                         f"reach the end of the timed section at {0.8 * walkway_m:g} m")
    timed = 0.6 * walkway_m
    contacts = np.sort([float(ic) for found in events.values() for ic in found.t_ic_s
                        if math.isfinite(ic) and enter <= ic <= leave])
    cadence = 60.0 * (contacts.shape[0] - 1) / (contacts[-1] - contacts[0]) if contacts.shape[0] > 1 else math.nan
    return TenMetreWalk(start_s, (enter, leave), timed, timed / (leave - enter), float(cadence))


def timed_walk(progression: Progression, start_s: float, duration_s: float) -> TimedWalk:
    """The distance walked in ``duration_s`` from ``start_s`` (module doc); ``ValueError``
    when the recording ends before the test does."""
    end = start_s + duration_s
    if progression.t_s[-1] < end:
        raise ValueError(f"the recording ends {progression.t_s[-1] - start_s:.1f} s after the first step, "
                         f"before the {duration_s:g}-s test does")
    marks = [start_s + 60.0 * k for k in range(int(duration_s // 60) + 1)]
    at = [progression.distance_at(x) for x in marks]
    distance = progression.distance_at(end) - at[0]
    return TimedWalk(start_s, duration_s, distance, distance / duration_s, tuple(float(v) for v in np.diff(at)))
