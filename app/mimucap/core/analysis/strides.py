"""Strides, turns and walking bouts of one recording, and why each refused stride was refused.

A stride of one foot runs from an initial contact (IC) to the next IC of the same foot, with
its final contact (FC, toe-off) in between: ``ic_s < fc_s < next_ic_s``. Its swing is the one
that ends at ``next_ic_s``, so its length is the foot's displacement over that swing.

Only straight walking is analysed. A stride is refused, with the reason in words, when

* the time between its contacts is not a stride (a pause: the walk stopped, or a swing was not
  seen; outside ``min_stride_s .. max_stride_s``),
* its final contact is missing or not between its initial contacts,
* it ends the walk: the foot does not swing again within ``max_stride_s`` (gait termination:
  the walker slows into standing, and the last step is shortened),
* it is irregular: it lasts more than ``max_time_ratio`` (1.5) times the median stride time of
  its foot's other candidate strides (a swing the detector did not see, such as the small
  steps of turning on the spot, joins two strides into one),
* it turns: its heading changes by more than ``max_heading_change_deg`` (45°: the smallest
  turn counted as one in turning studies, e.g. El-Gohary et al. 2014, "Continuous monitoring
  of turning in patients with movement disability", Sensors 14:356-369; the gentle
  curves of 30° that bring a walker onto the next straight stay in).

Turns are found first from a continuous heading where there is one (the pelvis's, see
:mod:`.turns`), and a stride more than half inside a turn is refused as turning too; without
one (foot sensors alone), turns are the runs of turning strides (of either foot, overlapping in
time). Walking bouts are runs of strides of either foot without a pause between them.
"""

from __future__ import annotations

import math
from bisect import bisect_left, bisect_right
from dataclasses import dataclass, replace
from itertools import accumulate

import numpy as np

SIDES = ("left", "right")


@dataclass(frozen=True)
class StrideSettings:
    """``min_stride_s``/``max_stride_s`` plausible stride times (s); ``max_heading_change_deg``
    largest heading change (deg) of a straight stride; ``max_time_ratio`` longest stride time
    as a multiple of the foot's median."""

    min_stride_s: float = 0.6
    max_stride_s: float = 2.5
    max_heading_change_deg: float = 45.0
    max_time_ratio: float = 1.5

    def __post_init__(self) -> None:
        if not 0 < self.min_stride_s < self.max_stride_s:
            raise ValueError("stride settings need 0 < min_stride_s < max_stride_s")
        if not 0 < self.max_heading_change_deg < 180:
            raise ValueError("max_heading_change_deg must be between 0 and 180")


DEFAULT_STRIDE_SETTINGS = StrideSettings()


@dataclass(frozen=True)
class Stride:
    """One stride (module doc). Times in s; ``stride_length_m`` and ``heading_change_deg``
    NaN where not estimable; ``straight`` False for a turning stride; ``analysed`` True when the
    stride enters the parameters; ``refused_because`` the reason otherwise ("" when analysed);
    ``bout`` index of its walking bout (-1 for a pause)."""

    side: str
    ic_s: float
    fc_s: float
    next_ic_s: float
    stride_length_m: float = math.nan
    heading_change_deg: float = math.nan
    straight: bool = True
    analysed: bool = True
    refused_because: str = ""
    bout: int = -1

    @property
    def stride_time_s(self) -> float:
        return self.next_ic_s - self.ic_s

    @property
    def stance_s(self) -> float:
        return self.fc_s - self.ic_s

    @property
    def swing_s(self) -> float:
        return self.next_ic_s - self.fc_s


@dataclass(frozen=True)
class Interval:
    """A time interval ``start_s .. end_s`` with a count (strides) and an angle (deg; turns)."""

    start_s: float
    end_s: float
    n_strides: int
    angle_deg: float = math.nan


def pair_strides(side: str, t_ic_s: np.ndarray, t_fc_s: np.ndarray) -> list[Stride]:
    """Candidate strides of one foot from its swings in time order: swing ``k`` ends at
    ``t_ic_s[k]``; swing ``k+1`` starts at ``t_fc_s[k+1]`` and ends at ``t_ic_s[k+1]``."""
    if side not in SIDES:
        raise ValueError(f"side must be left or right, got {side!r}")
    strides = []
    for k in range(len(t_ic_s) - 1):
        strides.append(Stride(side, float(t_ic_s[k]), float(t_fc_s[k + 1]), float(t_ic_s[k + 1])))
    return strides


def classify(strides: list[Stride], settings: StrideSettings = DEFAULT_STRIDE_SETTINGS,
             turns: list[Interval] | None = None) -> list[Stride]:
    """The strides (of one or both feet) with ``straight``, ``analysed`` and
    ``refused_because`` set (module doc). ``turns`` found beforehand from a continuous heading
    (:mod:`.turns`): a stride more than half inside one is a turning stride too.

    Each foot's initial contacts are sorted once and searched by bisection, and the turns are
    indexed by start (:class:`_TurnIndex`), so that n strides take O(n log n) time."""
    medians = {}
    contacts: dict[str, tuple[list[float], list[Stride]]] = {}
    for side in SIDES:
        times = [s.stride_time_s for s in strides
                 if s.side == side and settings.min_stride_s <= s.stride_time_s <= settings.max_stride_s]
        medians[side] = float(np.median(times)) if times else math.nan
        own = sorted((s for s in strides if s.side == side), key=lambda s: s.ic_s)
        contacts[side] = ([s.ic_s for s in own], own)
    turn_index = _TurnIndex(turns or [])
    result = []
    for s in strides:
        reason = ""
        straight = not (math.isfinite(s.heading_change_deg) and abs(s.heading_change_deg) > settings.max_heading_change_deg)
        if not settings.min_stride_s <= s.stride_time_s <= settings.max_stride_s:
            reason = (f"{s.stride_time_s:.2f} s between initial contacts is not one stride "
                      f"({settings.min_stride_s:g}-{settings.max_stride_s:g} s): a pause or a swing not seen")
        elif not (math.isfinite(s.fc_s) and s.ic_s < s.fc_s < s.next_ic_s):
            reason = "no final contact between its initial contacts"
        elif s.stride_time_s > settings.max_time_ratio * medians[s.side]:
            reason = (f"irregular: {s.stride_time_s:.2f} s, more than {settings.max_time_ratio:g} × the median "
                      f"stride time {medians[s.side]:.2f} s (a swing not seen, e.g. turning on the spot)")
        elif _ends_walk(s, *contacts[s.side], settings):
            reason = "ends the walk: the foot comes to rest after it (gait termination)"
        elif not straight:
            reason = (f"turning: heading changed by {s.heading_change_deg:+.0f}° "
                      f"(straight walking: at most {settings.max_heading_change_deg:g}°)")
        elif within := turn_index.mostly_inside(s.ic_s, s.next_ic_s):
            straight = False
            reason = (f"turning: inside the turn of {within.angle_deg:+.0f}° at "
                      f"{within.start_s:.1f}-{within.end_s:.1f} s")
        result.append(replace(s, straight=straight, analysed=not reason, refused_because=reason))
    return result


def _ends_walk(stride: Stride, ics: list[float], own: list[Stride], settings: StrideSettings) -> bool:
    """True when the foot does not start another stride (of at most ``max_stride_s``) where
    ``stride`` ends; ``own`` the foot's strides sorted by initial contact, ``ics`` theirs."""
    end = stride.next_ic_s
    first_later = bisect_left(ics, end - 1e-9)   # the foot's next initial contact
    if first_later == len(ics) or ics[first_later] - end > 1e-6:
        return True
    # The strides starting at this one's end (within 1 µs): one, or a few at most.
    around = own[bisect_left(ics, end - 2e-6):bisect_right(ics, end + 2e-6)]
    return not any(abs(o.ic_s - end) < 1e-6 and o.stride_time_s <= settings.max_stride_s for o in around)


class _TurnIndex:
    """Turns sorted by start with the latest end reached so far, to find the turns holding an
    instant without looking at every turn."""

    def __init__(self, turns: list[Interval]) -> None:
        self.turns = turns
        self.order = sorted(range(len(turns)), key=lambda i: turns[i].start_s)
        self.starts = [turns[i].start_s for i in self.order]
        self.reach = list(accumulate((turns[i].end_s for i in self.order), max))

    def mostly_inside(self, start_s: float, end_s: float) -> Interval | None:
        """The first turn (in the given order) holding more than half of ``start_s .. end_s``.
        Such a turn holds the middle of the span (else less than half of it would be inside),
        so only the turns around the middle are looked at."""
        middle, tolerance = 0.5 * (start_s + end_s), 1e-6
        k = bisect_right(self.starts, middle + tolerance)
        found = []
        while k > 0 and self.reach[k - 1] >= middle - tolerance:
            k -= 1
            turn = self.turns[self.order[k]]
            if _overlap(start_s, end_s, turn) > 0.5:
                found.append(self.order[k])
        return self.turns[min(found)] if found else None


def _overlap(start_s: float, end_s: float, turn: Interval) -> float:
    """Share (0..1) of ``start_s .. end_s`` inside ``turn``."""
    inside = min(end_s, turn.end_s) - max(start_s, turn.start_s)
    return max(inside, 0.0) / (end_s - start_s) if end_s > start_s else 0.0


def _merge(intervals: list[tuple[float, float, int, float]]) -> list[Interval]:
    merged: list[list] = []
    for start, end, count, angle in sorted(intervals):
        if merged and start <= merged[-1][1]:
            last = merged[-1]
            last[1] = max(last[1], end)
            last[2] += count
            last[3] = angle if not math.isfinite(last[3]) else (last[3] if abs(last[3]) >= abs(angle) else angle)
        else:
            merged.append([start, end, count, angle])
    return [Interval(a, b, n, g) for a, b, n, g in merged]


def bouts_and_turns(strides: list[Stride], settings: StrideSettings = DEFAULT_STRIDE_SETTINGS,
                    turns: list[Interval] | None = None) -> tuple[list[Stride], list[Interval], list[Interval]]:
    """Walking bouts (runs of strides of either foot that are not pauses) and turns; returns
    the strides with their ``bout`` index, the bouts and the turns. The turns are ``turns``
    when they were found beforehand from a continuous heading (with the number of strides
    overlapping each), else the runs of turning strides, whose angle is the summed heading
    change of the turning strides of the foot that turned most within it (deg, positive
    counter-clockwise from above)."""
    def is_walking(s: Stride) -> bool:
        return settings.min_stride_s <= s.stride_time_s <= settings.max_stride_s

    walking = [s for s in strides if is_walking(s)]
    bouts = _merge([(s.ic_s, s.next_ic_s, 1, math.nan) for s in walking])
    bout_of = _Holding(bouts)
    numbered = [replace(s, bout=bout_of(s) if is_walking(s) else -1) for s in strides]
    if turns is not None:
        # A walking stride overlapping a turn starts less than max_stride_s before its start.
        by_ic = sorted(walking, key=lambda s: s.ic_s)
        ics = [s.ic_s for s in by_ic]
        counted = [replace(t, n_strides=sum(1 for s in by_ic[bisect_left(ics, t.start_s - settings.max_stride_s - 1e-6):
                                                              bisect_right(ics, t.end_s)]
                                            if _overlap(s.ic_s, s.next_ic_s, t) > 0.0))
                   for t in turns]
        return numbered, bouts, counted
    turning = [s for s in walking if not s.straight]
    spans = _merge([(s.ic_s, s.next_ic_s, 1, math.nan) for s in turning])
    span_of = _Holding(spans)
    per_span: list[dict[str, float]] = [{side: 0 for side in SIDES} for _ in spans]
    for s in turning:   # each turning stride lies in the span it was merged into
        per_span[span_of(s)][s.side] += s.heading_change_deg
    turns = [replace(span, angle_deg=float(max(per_side.values(), key=abs))) for span, per_side in zip(spans, per_span)]
    return numbered, bouts, turns


class _Holding:
    """Index of the interval of ``intervals`` (merged: in time order, disjoint) that holds a
    whole stride, -1 when none does (by bisection)."""

    def __init__(self, intervals: list[Interval]) -> None:
        self.intervals = intervals
        self.starts = [i.start_s for i in intervals]

    def __call__(self, stride: Stride) -> int:
        k = bisect_right(self.starts, stride.ic_s) - 1
        return k if k >= 0 and stride.next_ic_s <= self.intervals[k].end_s else -1
