"""Writing stopped recordings' session files off the GUI thread, and saying how it went.

A stopped recording (:class:`~mimucap.session.live.recording.RecordingToSave`) leaves a journal
that holds every sample; converting it into the session file takes seconds for a long
recording. :class:`RecordingSaver` runs each conversion in a
:class:`~mimucap.gui.background_task.BackgroundTask` and tells the window what became of it:
``saved(live_session, RecordingResult)``, ``not_saved(message)`` (the journal is kept and the
message says how to recover it), ``progress(fraction)`` of the newest file, and ``idle()`` once
no file is being written any more (a window closed meanwhile closes then).
"""

from __future__ import annotations

from PyQt5 import QtCore, QtWidgets

from mimucap.gui.background_task import BackgroundTask


class RecordingSaver(QtCore.QObject):
    """Writes session files for ``parent`` (the main window), one background task each."""

    saved = QtCore.pyqtSignal(object, object)
    not_saved = QtCore.pyqtSignal(str)
    progress = QtCore.pyqtSignal(float)
    idle = QtCore.pyqtSignal()

    def __init__(self, parent: QtWidgets.QWidget) -> None:
        super().__init__(parent)
        #: the tasks writing a session file now
        self.tasks: list[BackgroundTask] = []

    def save(self, live_session, pending) -> None:
        """Write ``pending``'s session file (a recording of ``live_session``) in the background."""
        task = BackgroundTask(pending.save, self.parent())
        task.progress.connect(self.progress)
        task.setObjectName(pending.session_path.name)
        task.succeeded.connect(lambda result: self.saved.emit(live_session, result))
        task.failed.connect(lambda error: self.not_saved.emit(
            f"The session file {pending.session_path} could not be written ({error}); every sample is "
            f"kept in {pending.recorder.journal_path}: run `mimucap recover {pending.session_path}`."))
        task.finished.connect(lambda: self._finished(task))
        self.tasks.append(task)
        task.start()

    def _finished(self, task: BackgroundTask) -> None:
        if task in self.tasks:
            self.tasks.remove(task)
        if not self.saving:
            self.idle.emit()

    @property
    def saving(self) -> bool:
        """True while a session file is being written."""
        return any(task.isRunning() for task in self.tasks)

    def wait(self) -> None:
        """Block until every session file being written is written (their signals delivered)."""
        for task in list(self.tasks):
            task.wait()
        QtCore.QCoreApplication.sendPostedEvents()  # deliver the tasks' results now

    def closing_dialog(self, parent: QtWidgets.QWidget) -> QtWidgets.QProgressDialog:
        """A modal progress dialog while the files are written before the window closes (a
        fraction only when one file is written: several would make the bar jump between them)."""
        names = ", ".join(str(task.objectName()) for task in self.tasks if task.objectName())
        single = len(self.tasks) == 1
        dialog = QtWidgets.QProgressDialog(f"Writing the session file before closing…\n{names}".strip(),
                                           "", 0, 100 if single else 0, parent)
        if single:
            self.tasks[0].progress.connect(lambda fraction: dialog.setValue(int(round(100.0 * fraction))))
        dialog.setObjectName("closingProgress")
        dialog.setWindowTitle("MimuCap")
        dialog.setCancelButton(None)  # the file must be written: the journal is converted whole
        dialog.setWindowModality(QtCore.Qt.WindowModal)
        dialog.setMinimumDuration(0)
        return dialog
