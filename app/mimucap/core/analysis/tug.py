"""The Timed Up and Go (Podsiadlo & Richardson, "The timed 'Up & Go': a test of basic functional
mobility for frail elderly persons", 1991) and its phases as the instrumented version splits
them (Salarian et al., "iTUG, a sensitive and reliable measure of mobility", 2010): stand up,
walk out, turn, walk back, turn and sit down.

From the chair transitions (:mod:`.chair_transitions`) and the trunk's turns
(:mod:`.trunk_turns`):

* the test runs from the start of a sit-to-stand to the end of the next stand-to-sit; the
  first such pair with at least one turn between them is the test (or the pair inside the
  window ``within_s`` when one is given: the user's start and stop markers);
* **sit-to-stand**: that rise, from its start to its end (standing upright);
* **walk out**: from standing upright to the start of the first turn;
* **turn**: the first turn;
* **walk back**: from the end of that turn to the start of the last turn;
* **turn-to-sit**: from the start of the last turn to the end of sitting down. When the
  subject turns while sitting down and the trunk shows only one turn, the turn-to-sit starts
  where that sitting-down starts and the walk back ends there.

The trunk's peak turning rate of each turn is kept (Salarian et al. found turning slower in
early Parkinson's disease). Times in seconds, rates in deg/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mimucap.core.analysis.chair_transitions import SIT_TO_STAND, STAND_TO_SIT, ChairTransition
from mimucap.core.analysis.trunk_turns import TrunkTurn

#: The result keys, in the order of the test.
PHASES = ("sit_to_stand_s", "walk_out_s", "turn_s", "walk_back_s", "turn_to_sit_s")


@dataclass(frozen=True)
class TugResult:
    """The test from ``start_s`` to ``end_s``: ``phases`` key of :data:`PHASES` → duration
    (s), ``boundaries_s`` the six instants between them, ``turn_peak_dps`` and
    ``turn_to_sit_peak_dps`` the trunk's peak turning rates (deg/s; NaN without a turn)."""

    start_s: float
    end_s: float
    phases: dict[str, float]
    boundaries_s: tuple[float, ...]
    turn_peak_dps: float
    turn_to_sit_peak_dps: float

    @property
    def total_s(self) -> float:
        return self.end_s - self.start_s


def timed_up_and_go(transitions: list[ChairTransition], turns: list[TrunkTurn],
                    within_s: tuple[float, float] | None = None) -> TugResult:
    """The test (module doc); ``ValueError`` saying what is missing when none is found."""
    low, high = within_s if within_s is not None else (-math.inf, math.inf)
    rises = [tr for tr in transitions if tr.kind == SIT_TO_STAND and tr.start_s >= low]
    if not rises:
        raise ValueError("no rise from the chair found (the thighs never pass from seated to standing)")
    for rise in rises:
        sit = next((tr for tr in transitions if tr.kind == STAND_TO_SIT and tr.mid_s > rise.mid_s), None)
        if sit is None or sit.end_s > high:
            continue
        between = [turn for turn in turns if rise.end_s <= turn.peak_s <= sit.end_s]
        if between:
            return _phases(rise, sit, between)
    raise ValueError("no rise from the chair followed by a turn and by sitting down again was found")


def _phases(rise: ChairTransition, sit: ChairTransition, turns: list[TrunkTurn]) -> TugResult:
    first, last = turns[0], turns[-1]
    turn_start = max(first.start_s, rise.end_s)
    if len(turns) > 1:
        turn_end, last_start = first.end_s, last.start_s
        last_peak = last.peak_rate_dps
    else:  # one turn only: the subject turned while sitting down
        turn_end, last_start = first.end_s, max(sit.start_s, first.end_s)
        last_peak = math.nan
    bounds = (rise.start_s, rise.end_s, turn_start, turn_end, last_start, sit.end_s)
    phases = {key: float(b - a) for key, a, b in zip(PHASES, bounds[:-1], bounds[1:])}
    return TugResult(rise.start_s, sit.end_s, phases, bounds, first.peak_rate_dps, last_peak)
