"""The clock of a simulated suit shown by a wizard on its own (tests, screenshots, ``for_simulator``).

In the main window the live session is stepped by the window's frame pump, and the wizards'
feed tells them when samples arrive. A wizard opened on a simulated suit alone
(:class:`~mimucap.session.sources.calibration_feed.SimulatedSuitFeed`) has no such pump:
:class:`SimulatedSuitClock` is that pump, moving the suit's simulated time by the feed's
``step_s`` every ``interval_ms`` of wall time until its owner closes.
"""

from __future__ import annotations

from PyQt5 import QtCore, QtWidgets

from mimucap.session.sources.calibration_feed import SimulatedSuitFeed


class SimulatedSuitClock(QtCore.QObject):
    """Advances ``feed`` every ``interval_ms`` (ms) while ``owner`` (a dialog) is open."""

    def __init__(self, feed: SimulatedSuitFeed, interval_ms: int, owner: QtWidgets.QDialog) -> None:
        super().__init__(owner)
        if interval_ms < 1:
            raise ValueError(f"the simulated suit's clock interval must be at least 1 ms, got {interval_ms}")
        self.feed = feed
        self._timer = QtCore.QTimer(self)
        self._timer.setInterval(int(interval_ms))
        self._timer.timeout.connect(feed.advance)
        owner.finished.connect(self.stop)
        self._timer.start()

    @property
    def running(self) -> bool:
        return self._timer.isActive()

    def stop(self, *_result) -> None:
        """Stop moving the simulated time (the owner closed)."""
        self._timer.stop()
