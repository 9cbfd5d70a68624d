"""The 30-second chair stand (Jones, Rikli & Beam, "A 30-s chair-stand test as a measure of lower
body strength in community-residing older adults", 1999): how many times the subject stands up
fully from the chair in 30 s, arms crossed over the chest.

From the chair transitions (:mod:`.chair_transitions`): the test starts where the first
sit-to-stand starts (the first rise of the window ``within_s`` when one is given: the user's
start marker) and lasts ``duration_s``. A stand counts when the thighs pass halfway up
(:attr:`~.chair_transitions.ChairTransition.mid_s`) within the test: a stand more than halfway
up when the time is up counts as a full stand, as Jones et al. score it. The mean cycle time is
the mean interval between consecutive stands of the test (one full sit-stand-sit cycle each);
it is NaN with fewer than two stands. Times in seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mimucap.core.analysis.chair_transitions import SIT_TO_STAND, ChairTransition

#: The test's duration (s).
TEST_DURATION_S = 30.0


@dataclass(frozen=True)
class ChairStandResult:
    """``start_s`` the start of the first rise; ``stand_times_s`` when each counted stand passed
    halfway up; ``cycle_s`` the mean sit-stand-sit cycle (s, NaN with fewer than two stands)."""

    start_s: float
    duration_s: float
    stand_times_s: tuple[float, ...]
    cycle_s: float

    @property
    def stands(self) -> int:
        return len(self.stand_times_s)


def chair_stand(transitions: list[ChairTransition], duration_s: float = TEST_DURATION_S,
                within_s: tuple[float, float] | None = None, start_s: float | None = None) -> ChairStandResult:
    """Count the stands (module doc); ``start_s`` times the test from a given instant (the
    user's start marker) instead; ``ValueError`` when no rise from the chair is found."""
    low, high = within_s if within_s is not None else (-math.inf, math.inf)
    if start_s is not None:
        low = max(low, start_s)
    rises = [tr for tr in transitions if tr.kind == SIT_TO_STAND and low <= tr.mid_s <= high]
    if not rises:
        raise ValueError("no rise from the chair found (the thighs never pass from seated to standing)")
    start = rises[0].start_s if start_s is None else float(start_s)
    stop = min(start + duration_s, high)
    stands = tuple(tr.mid_s for tr in rises if tr.mid_s <= stop)
    cycle = float(np.mean(np.diff(stands))) if len(stands) > 1 else math.nan
    return ChairStandResult(start, stop - start, stands, cycle)
