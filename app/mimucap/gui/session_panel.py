"""The session panel: subject record, the checklist before recording, record start/stop with
what is recorded where (and a progress bar while the file is written), markers.

It follows the live session's events (:meth:`SessionPanel.set_session`): ``checklist``,
``recording_progress`` and ``marker``; the main window handles its buttons' signals.
"""

from __future__ import annotations

import html
from pathlib import Path

from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap.core.wording import plural
from mimucap.session.live.recording import RecordingInfo
from mimucap.session.live.checklist import CheckItem
from mimucap.session.subject import DOMINANCE, Subject

#: How a checklist item is marked: ok, or to look at.
CHECK_MARKS = {True: ("✔", "#2ca02c"), False: ("⚠", "#c05800")}


def display_path(path) -> str:
    """``path`` as a person reads it: the home folder written ``~`` (shorter, and the same on
    every screenshot)."""
    text = str(path)
    home = str(Path.home())
    if home not in ("", "/") and (text == home or text.startswith(home.rstrip("/") + "/")):
        return "~" + text[len(home.rstrip("/")):]
    return text


def _size(n_bytes: int) -> str:
    for unit in ("bytes", "kB", "MB", "GB"):
        if n_bytes < 1024 or unit == "GB":
            return f"{n_bytes:.0f} {unit}" if unit == "bytes" else f"{n_bytes:.1f} {unit}"
        n_bytes /= 1024.0
    return ""


class SessionPanel(QtWidgets.QWidget):
    """Subject fields, the checklist before recording, what the recording says, the next
    marker's label and the markers placed (Record/Stop and Add Marker are the mode bar's)."""

    marker_requested = QtCore.pyqtSignal(str)

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("sessionPanel")
        subject_box = QtWidgets.QGroupBox("Subject", self)
        self.subject_id = QtWidgets.QLineEdit("S001", subject_box)
        self.subject_id.setObjectName("subjectId")
        self.height = QtWidgets.QDoubleSpinBox(subject_box)
        self.height.setObjectName("subjectHeight")
        self.height.setRange(0.5, 2.5)
        self.height.setDecimals(2)
        self.height.setSingleStep(0.01)
        self.height.setSuffix(" m")
        self.height.setValue(1.75)
        self.dominance = QtWidgets.QComboBox(subject_box)
        self.dominance.addItems(DOMINANCE)
        self.notes = QtWidgets.QPlainTextEdit(subject_box)
        self.notes.setPlaceholderText("Notes (no personal data)")
        self.notes.setMaximumHeight(60)
        self.condition = QtWidgets.QLineEdit(subject_box)
        self.condition.setObjectName("sessionCondition")
        self.condition.setPlaceholderText("e.g. pre-op, 6 weeks")
        self.tags = QtWidgets.QLineEdit(subject_box)
        self.tags.setObjectName("sessionTags")
        self.tags.setPlaceholderText("comma-separated")
        form = QtWidgets.QFormLayout(subject_box)
        form.addRow("Id", self.subject_id)
        form.addRow("Height", self.height)
        form.addRow("Dominant side", self.dominance)
        form.addRow(self.notes)
        form.addRow("Condition", self.condition)
        form.addRow("Tags", self.tags)

        self.checklist_box = QtWidgets.QGroupBox("Before recording", self)
        self.checklist_box.setObjectName("checklistBox")
        self.checklist_labels: dict[str, QtWidgets.QLabel] = {}
        QtWidgets.QVBoxLayout(self.checklist_box).setSpacing(2)

        # Record/Stop and Add Marker are the mode bar's (always in view, one place): the panel
        # holds what the recording says, the next marker's label and the markers placed.
        record_box = QtWidgets.QGroupBox("Recording", self)
        self.record_status = QtWidgets.QLabel("Not recording", record_box)
        self.record_status.setObjectName("recordStatus")
        self.record_status.setWordWrap(True)
        self.record_status.setTextInteractionFlags(QtCore.Qt.TextSelectableByMouse)
        self.marker_label = QtWidgets.QLineEdit(record_box)
        self.marker_label.setObjectName("markerLabel")
        self.marker_label.setPlaceholderText("marker label")
        self.marker_label.setToolTip("The label of the next marker (Add Marker, M, or Enter here); it is used "
                                     "once, then the field empties.")
        self.marker_label.returnPressed.connect(self.request_marker)
        self.markers_list = QtWidgets.QListWidget(record_box)
        self.markers_list.setObjectName("markersList")
        self.markers_list.setMaximumHeight(110)
        self.saving_bar = QtWidgets.QProgressBar(record_box)
        self.saving_bar.setObjectName("savingBar")
        self.saving_bar.setRange(0, 100)
        self.saving_bar.setFormat("Saving %p %")
        self.saving_bar.setVisible(False)
        layout = QtWidgets.QVBoxLayout(record_box)
        layout.addWidget(self.record_status)
        layout.addWidget(self.saving_bar)
        layout.addWidget(self.marker_label)
        layout.addWidget(self.markers_list)

        main = QtWidgets.QVBoxLayout(self)
        main.addWidget(subject_box)
        main.addWidget(self.checklist_box)
        main.addWidget(record_box)
        main.addStretch(1)
        self._session = None

    def set_session(self, session) -> None:
        """Follow ``session``'s checklist, recording progress and markers (``None``: none); the
        previous session is let go (unsubscribed) and its markers leave the list (they were
        on its clock)."""
        previous, self._session = self._session, session
        callbacks = (("checklist", self.show_checklist), ("recording_progress", self.show_info),
                     ("marker", self._marker_placed))
        if previous is not None:
            for name, callback in callbacks:
                getattr(previous.events, name).disconnect(callback)
        self.markers_list.clear()
        if session is not None:
            for name, callback in callbacks:
                getattr(session.events, name).connect(callback)

    def _marker_placed(self, t_s: float, label: str, recorded: bool) -> None:
        """List a marker the session placed, at its time in the recording when recorded."""
        started_s = self._session.recording_started_s if self._session is not None else None
        in_recording = recorded and started_s is not None
        self.add_marker_line(label, t_s - started_s if in_recording else None)

    def subject(self) -> Subject:
        """The subject the fields describe (``ValueError`` naming the bad field)."""
        return Subject(subject_id=self.subject_id.text().strip(), height_m=round(self.height.value(), 3),
                       dominance=self.dominance.currentText(), notes=self.notes.toPlainText().strip())

    def set_subject(self, subject_id: str, height_m: float | None, dominance: str, notes: str) -> None:
        """Fill the subject fields (a known subject's record; the height unchanged when None)."""
        self.subject_id.setText(subject_id)
        if height_m is not None:
            self.height.setValue(height_m)
        if dominance in DOMINANCE:
            self.dominance.setCurrentText(dominance)
        self.notes.setPlainText(notes)

    def session_fields(self) -> tuple[str, list[str]]:
        """The condition and the tags (split at commas) of the next recording."""
        return self.condition.text().strip(), [t.strip() for t in self.tags.text().split(",") if t.strip()]

    def set_subject_editable(self, editable: bool) -> None:
        for widget in (self.subject_id, self.height, self.dominance, self.notes, self.condition, self.tags):
            widget.setEnabled(editable)

    def set_recording(self, on: bool) -> None:
        """While recording, the subject's fields are kept as the recording has them."""
        self.set_subject_editable(not on)

    def request_marker(self) -> None:
        """Ask for a marker with the typed label, then clear the field: a label is used once
        (the next press without typing is a plain "marker")."""
        label = self.marker_label.text().strip()
        self.marker_label.clear()
        self.marker_requested.emit(label)

    def show_checklist(self, items: list[CheckItem]) -> None:
        """Show the checklist before recording: one line per item, marked ✔ or ⚠."""
        layout = self.checklist_box.layout()
        for item in items:
            label = self.checklist_labels.get(item.key)
            if label is None:
                label = QtWidgets.QLabel(self.checklist_box)
                label.setObjectName(f"check_{item.key}")
                label.setWordWrap(True)
                label.setTextFormat(QtCore.Qt.RichText)
                layout.addWidget(label)
                self.checklist_labels[item.key] = label
            mark, colour = CHECK_MARKS[item.ok]
            text = (f"<span style='color:{colour}'>{mark}</span> <b>{html.escape(item.title)}</b>: "
                    f"{html.escape(item.text)}")
            if label.text() != text:
                label.setText(text)
            label.setProperty("ok", item.ok)

    def show_saving(self, saving: bool) -> None:
        """Show the progress bar (from 0) while a stopped recording's file is written."""
        self.saving_bar.setValue(0)
        self.saving_bar.setVisible(saving)

    def show_saving_progress(self, fraction: float) -> None:
        """How much of the session file is written (``fraction`` 0..1)."""
        self.saving_bar.setValue(int(round(100.0 * min(max(fraction, 0.0), 1.0))))

    def show_info(self, info: RecordingInfo | None, last_message: str = "") -> None:
        if info is None:
            self.record_status.setText(last_message or "Not recording")
            return
        minutes, seconds = divmod(info.elapsed_s, 60.0)
        self.record_status.setText(
            f"Recording {int(minutes):02d}:{seconds:04.1f}, {_size(info.size_bytes)}, "
            f"{plural(info.markers, 'marker')}\n→ {display_path(info.path)}")

    def add_marker_line(self, label: str, recording_t_s: float | None) -> None:
        """List a marker: at its time in the recording (s since the recording started, as
        review and export show it), or greyed as not recorded (``recording_t_s`` None)."""
        if recording_t_s is None:
            item = QtWidgets.QListWidgetItem(f"{'–':>8}    {label} (not recorded)")
            item.setForeground(self.palette().brush(QtGui.QPalette.Disabled, QtGui.QPalette.Text))
            item.setToolTip("Markers are saved only while recording.")
        else:
            item = QtWidgets.QListWidgetItem(f"{recording_t_s:8.2f} s  {label}")
        self.markers_list.addItem(item)
        self.markers_list.scrollToBottom()
