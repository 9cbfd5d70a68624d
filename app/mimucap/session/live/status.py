"""The live session's status part: what the panels and the status bar show, published as events
at a steady rate (no Qt).

The sensors' rates, drops and latencies are statistics over an interval, and a person reads a
table a few times a second at most: :class:`StatusPublisher` publishes them at
:data:`STATUS_RATE_HZ` from the session's :meth:`~mimucap.session.live.live_session.LiveSession.step` (the
one clock of the live view), instead of each widget asking the session on a timer of its own.
Events whose value changes rarely (the source's problem, the packets refused from no known
sensor, the sensors refused as not paired) are emitted only when the value differs from the one last published.

Interface: ``StatusPublisher(session, events, clock)``; :meth:`StatusPublisher.tick` from every
step (publishes when :data:`STATUS_RATE_HZ` says so, or at once after :meth:`mark_due`);
:meth:`StatusPublisher.publish` publishes now. ``session`` offers ``sensor_rows()`` and what
:func:`~mimucap.session.live.checklist.recording_checklist` reads, and its parts ``recorder``
(``info()``, ``publish_progress()``), ``sensors`` (``publish_state()``, ``forget_state()``) and
``evaluation`` (``publish_errors()``). It emits ``status`` and ``checklist`` into ``events``
(an :class:`~mimucap.session.events.EmitterGroup`, declared in
:class:`~mimucap.session.live.live_session.LiveSession`'s docstring); the parts emit the rest.
"""

from __future__ import annotations

from collections.abc import Callable

from mimucap.session.events import EmitterGroup
from mimucap.session.live.checklist import recording_checklist

#: How often the status is published (Hz): the sensor table, the checklist, the recording's
#: progress, the accuracy check. Four times a second shows a stale sensor within a second and a
#: recording's clock without visible lag; rates and drops are per-interval figures anyway.
STATUS_RATE_HZ = 4.0


class StatusPublisher:
    """Publishes a live session's status into ``events`` at :data:`STATUS_RATE_HZ`.

    Args:
        session: the :class:`~mimucap.session.live.live_session.LiveSession` (see the module doc).
        events: the session's events.
        clock: monotonic clock (s) of the publications (the wall's: people read the status).
        rate_hz: publications per second.
    """

    def __init__(self, session, events: EmitterGroup, clock: Callable[[], float],
                 rate_hz: float = STATUS_RATE_HZ) -> None:
        if not rate_hz > 0:
            raise ValueError(f"the status rate must be positive, got {rate_hz}")
        self._session = session
        self._events = events
        self._clock = clock
        self.interval_s = 1.0 / float(rate_hz)
        self._last_s = float("-inf")
        self._due = True

    def mark_due(self, *_why) -> None:
        """Publish at the next :meth:`tick` whatever the rate (something the status shows changed:
        an assignment, a calibration, a recording started); an event's arguments are ignored."""
        self._due = True

    def tick(self) -> bool:
        """Publish if an interval has passed since the last publication (or one is due);
        returns whether it published."""
        now = self._clock()
        if not self._due and now - self._last_s < self.interval_s:
            return False
        self.publish(now)
        return True

    def publish(self, now: float | None = None) -> None:
        """Publish the whole status now: ``status`` and, while recording, ``recording_progress``
        (else ``checklist``) always; ``source_problem``, ``refused`` and ``unpaired`` when they changed since
        the last publication; ``truth_errors`` when the source has truth and someone listens."""
        self._last_s = self._clock() if now is None else now
        self._due = False
        session, events = self._session, self._events
        checklist = not session.recorder.active and bool(events.checklist.callbacks)
        if events.status.callbacks or checklist:  # the rows are the costly part: only when read
            rows = session.sensor_rows()
            events.status.emit(rows)
            if checklist:
                events.checklist.emit(recording_checklist(session, rows))
        session.recorder.publish_progress()
        session.sensors.publish_state()
        session.evaluation.publish_errors()

    def forget(self) -> None:
        """Forget what was published (the next publication emits every event again, e.g. for
        widgets that have just subscribed)."""
        self._session.sensors.forget_state()
        self._due = True
