"""The comparison of two sessions of a subject: for each session the part compared (the whole
recording or between two markers), then every table of the comparison (a named table each, as
:func:`mimucap.session.recorded.library.compare` makes them) with A, B and the difference.

Both sessions are processed off the GUI thread by the one pipeline
(:func:`mimucap.session.recorded.review.load_review`); changing a window recomputes the tables only.
"""

from __future__ import annotations

import logging
from pathlib import Path

from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap.core.analysis.rom import marker_words
from mimucap.core.pipeline.settings import RESULT_LABELS, RESULT_REPROCESSED
from mimucap.gui.background_task import BackgroundTask
from mimucap.gui.menus import closes_with_keys
from mimucap.gui.screen_fit import fit_on_screen
from mimucap.gui.session_panel import display_path
from mimucap.io.analysis_tables import write_comparison_csv
from mimucap.io.library import Library, SessionEntry
from mimucap.session.recorded.library import ComparedSession, ComparisonTable, TimeWindow, compare
from mimucap.session.recorded.review import load_review

log = logging.getLogger(__name__)

#: Colours of a difference column: larger in B, smaller in B.
MORE_COLOUR, LESS_COLOUR = "#1b5e20", "#b00020"
#: Differences at least this large (°) are coloured: smaller ones are within what the sensors measure.
HIGHLIGHT_DEG = 1.0


class WindowPicker(QtWidgets.QGroupBox):
    """One session's description and the part of it compared: from / to (start, markers, end)."""

    changed = QtCore.pyqtSignal()

    def __init__(self, title: str, entry: SessionEntry, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(title, parent)
        self.entry = entry
        self.markers: list = []
        details = ", ".join(part for part in (entry.date, entry.condition, ", ".join(entry.tags), entry.trial) if part)
        label = QtWidgets.QLabel(f"<b>{entry.file_name}</b><br>{details}", self)
        label.setTextInteractionFlags(QtCore.Qt.TextSelectableByMouse)
        self.start = QtWidgets.QComboBox(self)
        self.end = QtWidgets.QComboBox(self)
        for combo in (self.start, self.end):
            combo.setEnabled(False)
            combo.currentIndexChanged.connect(lambda *_: self.changed.emit())
        form = QtWidgets.QFormLayout(self)
        form.addRow(label)
        form.addRow("From", self.start)
        form.addRow("To", self.end)

    def set_markers(self, markers: list) -> None:
        """Offer the session's markers (``io.session.Marker``) as window bounds."""
        self.markers = list(markers)
        for combo, edge in ((self.start, "start of the recording"), (self.end, "end of the recording")):
            combo.blockSignals(True)
            combo.clear()
            combo.addItem(edge, None)
            for index, marker in enumerate(self.markers):
                combo.addItem(f"{marker_words(marker.label)} ({marker.t_s:.2f} s)", index)
            combo.setEnabled(bool(self.markers))
            combo.blockSignals(False)

    def set_bounds(self, first: int | None, second: int | None) -> None:
        """Choose marker indexes (None: the recording's start / end)."""
        for combo, value in ((self.start, first), (self.end, second)):
            combo.setCurrentIndex(max(combo.findData(value), 0) if value is not None else 0)

    def window(self) -> TimeWindow:
        """The part chosen (``ValueError`` naming this session when the markers do not make one)."""
        try:
            return TimeWindow.between_markers(self.markers, self.start.currentData(), self.end.currentData())
        except ValueError as error:
            raise ValueError(f"{self.title()}: {error}") from None


def _cell(value, signed: bool = False) -> QtWidgets.QTableWidgetItem:
    if value is None:
        item = QtWidgets.QTableWidgetItem("–")
    elif isinstance(value, float):
        shown = round(value, 1) + 0.0  # no "-0.0"
        item = QtWidgets.QTableWidgetItem(f"{shown:+.1f}" if signed and shown else f"{shown:.1f}")
        item.setTextAlignment(int(QtCore.Qt.AlignRight | QtCore.Qt.AlignVCenter))
    else:
        item = QtWidgets.QTableWidgetItem(str(value))
    item.setFlags(item.flags() & ~QtCore.Qt.ItemIsEditable)
    return item


def table_widget(table: ComparisonTable, parent: QtWidgets.QWidget | None = None) -> QtWidgets.QTableWidget:
    """A read-only table of ``table``; its last column (the difference) coloured by sign."""
    widget = QtWidgets.QTableWidget(len(table.rows), len(table.headers), parent)
    widget.setHorizontalHeaderLabels(table.headers)
    widget.verticalHeader().hide()
    for row, values in enumerate(table.rows):
        for column, value in enumerate(values):
            last = column == len(values) - 1
            item = _cell(value, signed=last)
            if last and isinstance(value, float) and abs(value) >= HIGHLIGHT_DEG:
                item.setForeground(QtGui.QBrush(QtGui.QColor(MORE_COLOUR if value > 0 else LESS_COLOUR)))
                font = item.font()
                font.setBold(True)
                item.setFont(font)
            widget.setItem(row, column, item)
    header = widget.horizontalHeader()
    header.setSectionResizeMode(QtWidgets.QHeaderView.Stretch)
    header.setSectionResizeMode(0, QtWidgets.QHeaderView.ResizeToContents)
    return widget


class CompareDialog(QtWidgets.QDialog):
    """Comparison of ``first`` (A) and ``second`` (B), two sessions of one subject in ``library``
    (a dialog over the Library workspace, which stays usable beside it); call :meth:`load` after
    ``show()``.

    Signals:
        compared(): the tables show the current windows (or :attr:`error` says why not).
    """

    compared = QtCore.pyqtSignal()

    def __init__(self, library: Library, first: SessionEntry, second: SessionEntry,
                 parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        closes_with_keys(self)  # Esc as every dialog, and the platform's Close keys
        self.setObjectName("compareDialog")
        self.setWindowTitle(f"Compare: {first.subject_id}: {first.file_name} / {second.file_name}")
        fit_on_screen(self, 1100, 720, parent)
        self.library = library
        self.entries = (first, second)
        self.reviews = None
        self.tables: list[ComparisonTable] = []
        self.table_widgets: list[QtWidgets.QTableWidget] = []  # one per table, in order
        self.error: str | None = None
        self._task: BackgroundTask | None = None

        self.pickers = (WindowPicker("A", first, self), WindowPicker("B", second, self))
        pickers = QtWidgets.QHBoxLayout()
        for picker in self.pickers:
            picker.changed.connect(self.recompute)
            pickers.addWidget(picker, 1)
        self.result_combo = QtWidgets.QComboBox(self)
        self.result_combo.setObjectName("resultCombo")
        for result, label in RESULT_LABELS.items():
            self.result_combo.addItem(label, result)
        self.result_combo.setCurrentIndex(self.result_combo.findData(RESULT_REPROCESSED))
        self.result_combo.currentIndexChanged.connect(lambda *_: self.load())
        result_row = QtWidgets.QHBoxLayout()
        result_row.addWidget(QtWidgets.QLabel("Joint angles of both sessions:", self))
        result_row.addWidget(self.result_combo)
        result_row.addStretch(1)
        self.message = QtWidgets.QLabel("Processing both sessions…", self)
        self.message.setWordWrap(True)
        self.progress = QtWidgets.QProgressBar(self)
        self.progress.setRange(0, 100)
        self.tables_area = QtWidgets.QWidget(self)
        self.tables_layout = QtWidgets.QVBoxLayout(self.tables_area)
        self.tables_layout.setContentsMargins(0, 0, 0, 0)
        self.save_button = QtWidgets.QPushButton("Save as CSV…", self)
        self.save_button.setEnabled(False)
        self.save_button.clicked.connect(self.ask_to_save_csv)
        self.saved_label = QtWidgets.QLabel(self)
        self.saved_label.setObjectName("savedLabel")
        self.saved_label.setTextInteractionFlags(QtCore.Qt.TextSelectableByMouse)
        close = QtWidgets.QPushButton("Close", self)
        close.setAutoDefault(False)
        close.clicked.connect(self.close)
        buttons = QtWidgets.QHBoxLayout()
        buttons.addWidget(self.saved_label, 1)
        buttons.addWidget(self.save_button)
        buttons.addWidget(close)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addLayout(pickers)
        layout.addLayout(result_row)
        layout.addWidget(self.message)
        layout.addWidget(self.progress)
        layout.addWidget(self.tables_area, 1)
        layout.addLayout(buttons)

    @property
    def result(self) -> str:
        """Which result of the processing both sessions show (``core.pipeline.settings.RESULTS``)."""
        return self.result_combo.currentData()

    def load(self) -> None:
        """Process both sessions in the background (the result chosen), then show the tables."""
        if self._task is not None:
            self._task.let_go()
        files = [self.library.file(entry) for entry in self.entries]
        result = self.result

        def work(progress):
            first = load_review(files[0], progress=lambda f: progress(0.5 * f), result=result)
            second = load_review(files[1], progress=lambda f: progress(0.5 + 0.5 * f), result=result)
            return first, second

        self.reviews, self.tables, self.error = None, [], None
        self.message.setText("Processing both sessions…")
        self.progress.setValue(0)
        self.progress.show()
        self._task = BackgroundTask(work, self)
        self._task.progress.connect(lambda fraction: self.progress.setValue(int(100 * fraction)))
        self._task.succeeded.connect(self._loaded)
        self._task.failed.connect(self._failed)
        self._task.start()

    def _loaded(self, reviews) -> None:
        self.reviews = reviews
        self.progress.hide()
        for picker, review in zip(self.pickers, reviews):
            picker.set_markers(review.markers)
        self.recompute()

    def _failed(self, error: str) -> None:
        self.error = f"Cannot compare: {error}"
        self.progress.hide()
        self.message.setText(self.error)
        self.compared.emit()

    def recompute(self) -> None:
        """The tables for the windows chosen now."""
        if self.reviews is None:
            return
        try:
            sides = [ComparedSession.from_review(entry, review, picker.window())
                     for entry, review, picker in zip(self.entries, self.reviews, self.pickers)]
            self.tables = compare(*sides)
            self.error = None
        except ValueError as error:
            self.tables, self.error = [], str(error)
        self._show_tables()
        self.compared.emit()

    def _show_tables(self) -> None:
        while self.tables_layout.count():
            widget = self.tables_layout.takeAt(0).widget()
            if widget is not None:
                widget.hide()  # gone from the window now; deleted when the event loop runs
                widget.setParent(None)
                widget.deleteLater()
        if self.error is not None:
            self.message.setText(self.error)
        else:
            sources = ", ".join(sorted({review.pose_source for review in self.reviews}))
            self.message.setText(f"B − A: positive where B (the later session) moves more. Poses from: {sources}.")
        self.table_widgets = []
        for table in self.tables:
            box = QtWidgets.QGroupBox(table.name, self.tables_area)
            box_layout = QtWidgets.QVBoxLayout(box)
            self.table_widgets.append(table_widget(table, box))
            box_layout.addWidget(self.table_widgets[-1], 1)
            if table.note:
                note = QtWidgets.QLabel(table.note, box)
                note.setWordWrap(True)
                box_layout.addWidget(note)
            self.tables_layout.addWidget(box, 1)
        self.save_button.setEnabled(bool(self.tables))

    def save_csv(self, path: str | Path) -> Path:
        """Write the tables as CSV (:func:`mimucap.io.analysis_tables.write_comparison_csv`)."""
        return write_comparison_csv(path, self.tables)

    def ask_to_save_csv(self) -> None:
        first, second = self.entries
        suggestion = self.library.root / f"{first.subject_id}_compare_{first.date}_{second.date}.csv"
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save Comparison", str(suggestion), "CSV (*.csv)")
        if path:
            try:
                self.saved_label.setText(f"Saved {display_path(self.save_csv(path))}")
            except OSError as error:
                QtWidgets.QMessageBox.warning(self, "Save Comparison", str(error))

    def done(self, result: int) -> None:
        """Closed (Close, Esc, Ctrl+W or the title bar): the processing still running is let go."""
        if self._task is not None:
            self._task.let_go()
        super().done(result)
