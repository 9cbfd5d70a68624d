"""Long work off the GUI thread: a function runs in a ``QThread`` and reports progress.

``BackgroundTask(fn)`` calls ``fn(progress)`` in a worker thread, where ``progress(fraction)``
emits :attr:`BackgroundTask.progress`; the result arrives through :attr:`finished`, a
failure (its message, also logged) through :attr:`failed`. Signals are delivered in the GUI
thread, so slots can touch widgets.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from PyQt5 import QtCore

log = logging.getLogger(__name__)


class BackgroundTask(QtCore.QThread):
    progress = QtCore.pyqtSignal(float)
    succeeded = QtCore.pyqtSignal(object)
    failed = QtCore.pyqtSignal(str)

    def __init__(self, work: Callable[[Callable[[float], None]], Any], parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self._work = work
        self.result: Any = None
        self.error: str | None = None

    def run(self) -> None:  # runs in the worker thread
        try:
            self.result = self._work(self.progress.emit)
        except (ValueError, OSError) as error:
            # A file the user chose is not what it should be: their problem to act on, said in
            # the window; the log keeps the sentence, without a traceback that reads like a crash.
            from mimucap.io.json_document import describe_os_error

            self.error = describe_os_error(error) if isinstance(error, OSError) else f"{error}"
            log.warning("%s", self.error)
            self.failed.emit(self.error)
            return
        except Exception as error:  # a defect of ours: reported in the window, logged with its traceback
            log.exception("background task failed")
            self.error = f"{error}"
            self.failed.emit(self.error)
            return
        self.succeeded.emit(self.result)

    def let_go(self, wait_ms: int = 0) -> None:
        """Its result is no longer wanted (the page that asked for it goes away): nothing is told
        any more, and the thread finishes on its own (given ``wait_ms`` to finish first: the
        program closing), kept alive by the application until then (a ``QThread`` destroyed
        while it runs takes the process down)."""
        for signal in (self.succeeded, self.failed, self.progress):
            try:
                signal.disconnect()
            except TypeError:
                pass  # nothing connected (let go before)
        if wait_ms > 0:
            self.wait(wait_ms)
        if self.isRunning():
            self.setParent(QtCore.QCoreApplication.instance())
            self.finished.connect(self.deleteLater)
