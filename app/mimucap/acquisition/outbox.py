"""The worker side of the worker → supervisor queue: bounded, never blocking on data.

Sample blocks are put without waiting; when the queue is full the block is discarded and its
samples are counted (``queue_overflow``) so a stalled pipeline never grows a worker's memory
and the loss is reported, not silent. Reports are cumulative, so a report that does not fit
is simply replaced by the next one.
"""

from __future__ import annotations

import queue as queue_module
import time
from typing import Any

from mimucap.acquisition.messages import BlocksMessage, WorkerReport


class Outbox:
    """Sends messages of one source to the supervisor's queue."""

    def __init__(self, queue: Any, source: str, report_interval_s: float = 0.5) -> None:
        self._queue = queue
        self.source = source
        self.report_interval_s = report_interval_s
        self.overflow_samples = 0
        self._last_report_s = -float("inf")
        self._last_state: str | None = None

    def send_blocks(self, message: BlocksMessage) -> None:
        """Put a block message; count its samples as overflow if the queue is full."""
        try:
            self._queue.put_nowait(message)
        except queue_module.Full:
            self.overflow_samples += message.sample_count()

    def report_due(self, now_s: float) -> bool:
        return now_s - self._last_report_s >= self.report_interval_s

    def send_report(self, report: WorkerReport, final: bool = False) -> None:
        """Put a report (a final one waits up to 1 s for room in the queue)."""
        self._last_report_s = time.monotonic()
        self._last_state = report.state
        try:
            if final:
                self._queue.put(report, timeout=1.0)
            else:
                self._queue.put_nowait(report)
        except queue_module.Full:
            pass

    def state_changed(self, state: str) -> bool:
        return state != self._last_state
