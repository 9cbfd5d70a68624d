"""A clock for the simulated suit that runs faster than the wall clock (for demonstrations,
screenshots and the end-to-end tests): every part of a live session reads the same clock."""

from __future__ import annotations

import time
from collections.abc import Callable

#: The largest step (s of simulated time) one reading may take: after a stall of the computer
#: the simulation slows down instead of losing the stall's samples (which a real radio would).
MAX_STEP_S = 0.5


def fast_clock(speed_up: float) -> Callable[[], float]:
    """A monotonic clock (s) that runs ``speed_up`` times as fast as ``time.monotonic``, each
    reading moving it at most :data:`MAX_STEP_S`."""
    if not speed_up > 0:
        raise ValueError(f"speed_up must be positive, got {speed_up}")
    state = [time.monotonic(), time.monotonic()]  # clock value, wall time of the last reading

    def clock() -> float:
        wall = time.monotonic()
        state[0] += min(speed_up * (wall - state[1]), MAX_STEP_S)
        state[1] = wall
        return state[0]

    return clock
