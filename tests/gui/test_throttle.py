"""The repaint schedule: at most its rate on average whatever the events' rate, late repaints do
not push the later ones back, a long pause restarts it."""

from __future__ import annotations

import pytest

from mimucap.gui.throttle import RepaintThrottle


def _repaints(throttle: RepaintThrottle, event_times, delay_s: float = 0.0) -> list[float]:
    """When a widget repaints for events at ``event_times`` (s): at once when due, else when its
    timer ends (``delay_s`` late), the events meanwhile coalesced."""
    painted, timer_end = [], None
    for t in event_times:
        if timer_end is not None and timer_end <= t:
            throttle.painted(timer_end)
            painted.append(timer_end)
            timer_end = None
        if timer_end is not None:
            continue
        wait = throttle.wait_s(t)
        if wait <= 0:
            throttle.painted(t)
            painted.append(t)
        else:
            timer_end = t + wait + delay_s
    return painted


def test_events_faster_than_the_rate_are_held_to_it():
    throttle = RepaintThrottle(30.0)
    painted = _repaints(throttle, [k * 0.001 for k in range(3001)])  # 1 kHz for 3 s
    assert len(painted) == pytest.approx(90, abs=1)
    assert min(b - a for a, b in zip(painted, painted[1:])) >= 1 / 30 - 1e-9


def test_each_event_of_a_slower_clock_repaints_at_once_with_some_slack():
    throttle = RepaintThrottle(60.0, slack=0.1)
    events = [k * 0.016 for k in range(625)]  # the 62.5 Hz pump for 10 s
    assert _repaints(throttle, events) == events


def test_late_repaints_do_not_lower_the_rate():
    throttle = RepaintThrottle(30.0, slack=0.05)
    events = [k * 0.016 for k in range(625)]
    painted = _repaints(throttle, events, delay_s=0.008)  # every timer 8 ms late
    assert len(painted) / 10.0 >= 29.0


def test_a_pause_restarts_the_schedule_and_bad_settings_are_refused():
    throttle = RepaintThrottle(30.0)
    throttle.painted(0.0)
    assert throttle.wait_s(0.01) > 0
    throttle.painted(5.0)  # long after it was due
    assert throttle.wait_s(5.0) == pytest.approx(1 / 30)
    with pytest.raises(ValueError, match="positive"):
        RepaintThrottle(0.0)
    with pytest.raises(ValueError, match="slack"):
        RepaintThrottle(30.0, slack=1.0)
