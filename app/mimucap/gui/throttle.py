"""How often a widget may repaint: at most a given rate on average, whatever rate its model's
events come at.

A widget that follows a model's events (the 3D view, the plots) marks itself out of date on each
event and repaints when :meth:`RepaintThrottle.wait_s` says so (at once, or after a single-shot
timer of that many seconds); it tells :meth:`RepaintThrottle.painted` when it did. The next
repaint is due one interval after the previous one was *due*, not after it happened: a repaint
that came late (a busy event loop, a timer rounded to the millisecond) does not push every later
one back, so the average rate holds; a repaint later than a whole interval restarts the schedule
from now instead of allowing a burst.
"""

from __future__ import annotations

import math


class RepaintThrottle:
    """At most ``rate_hz`` repaints a second on average (see the module doc).

    Args:
        rate_hz: the most repaints a second (the screen's 60 for the 3D view, 30 for the plots).
        slack: share of the interval the schedule may run ahead (0 ≤ slack < 1): the events that
            bring new data come on a clock of their own (the 16 ms pump), and a schedule on a
            slightly shorter interval lets each event's repaint happen when it comes instead of
            waiting a fraction of a millisecond, or a whole interval now and then.
    """

    def __init__(self, rate_hz: float, slack: float = 0.0) -> None:
        if not rate_hz > 0:
            raise ValueError(f"the repaint rate must be positive, got {rate_hz}")
        if not 0.0 <= slack < 1.0:
            raise ValueError(f"the slack must be in [0, 1), got {slack}")
        self.rate_hz = float(rate_hz)
        self.interval_s = (1.0 - slack) / self.rate_hz
        self._due_s = -math.inf

    def wait_s(self, now_s: float) -> float:
        """Seconds (s, > 0) until the next repaint is due, or ≤ 0 when it may happen now."""
        return self._due_s - now_s

    def painted(self, now_s: float) -> None:
        """A repaint happened at ``now_s`` (s, the same clock as :meth:`wait_s`)."""
        due = self._due_s + self.interval_s
        if not now_s - self.interval_s <= self._due_s <= now_s:  # early (forced), or an interval late
            due = now_s + self.interval_s
        self._due_s = due

    @staticmethod
    def timer_ms(wait_s: float) -> int:
        """A single-shot timer's interval (ms) that ends no sooner than ``wait_s``."""
        return int(math.ceil(1000.0 * wait_s)) if wait_s > 0 else 0
