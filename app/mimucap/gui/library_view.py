"""The library (the page of the main window's Library workspace): subjects on the left, their
sessions in a sortable, filterable table.

The view shows what :class:`mimucap.io.library.Library` lists and forwards what the user asks:
open a session in the Review or the Analysis workspace, start a new session for the selected
subject (the Capture workspace's session panel filled with the subject's record), rename a
trial, set tags or the condition, move a session to the library's trash, compare two sessions of
a subject (a dialog). The folder is scanned off the GUI thread when the view is made, when the
workspace is shown and after each change, so files copied in by hand appear.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path

from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap.core.wording import plural
from mimucap.gui.background_task import BackgroundTask
from mimucap.gui.session_panel import display_path
from mimucap.gui.status_line import page_layout, status_line
from mimucap.io.library import Library, LibraryError, SessionEntry, SubjectEntry
from mimucap.io.library_settings import remember_library_folder
from mimucap.session.recorded.library import COMPARISON_NEEDS_CALIBRATION

log = logging.getLogger(__name__)

#: The sessions table's columns.
COLUMNS = ("Subject", "Date", "Condition", "Tags", "Trial", "Duration", "Sensors", "Calibration", "Markers", "Status")
#: Role holding a cell's sort key (dates as ISO text, durations as numbers).
SORT_ROLE = QtCore.Qt.UserRole + 1
#: Role holding a row's relative session path (first column).
PATH_ROLE = QtCore.Qt.UserRole + 2
#: The first item of the subjects list.
ALL_SUBJECTS = "All subjects"
#: Colour of a damaged session's status.
DAMAGED_COLOUR = "#b00020"
_ANY_DATE = QtCore.QDate(2000, 1, 1)


class SessionFilter(QtCore.QSortFilterProxyModel):
    """Rows of one subject (or all), a condition, a tag, and dates within [from, to]; empty
    criteria let every row through. Sorting uses :data:`SORT_ROLE`."""

    def __init__(self, parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self.subject: str | None = None
        self.condition = ""
        self.tag = ""
        self.date_from = ""
        self.date_to = ""
        self.entries: dict[str, SessionEntry] = {}
        self.setSortRole(SORT_ROLE)

    def set_criteria(self, **criteria) -> None:
        for name, value in criteria.items():
            setattr(self, name, value)
        self.invalidateFilter()

    def filterAcceptsRow(self, row: int, parent: QtCore.QModelIndex) -> bool:  # noqa: N802 (Qt API)
        path = self.sourceModel().index(row, 0, parent).data(PATH_ROLE)
        entry = self.entries.get(path)
        if entry is None:
            return False
        if self.subject is not None and entry.subject_id != self.subject:
            return False
        if self.condition and entry.condition != self.condition:
            return False
        if self.tag and self.tag not in entry.tags:
            return False
        if (self.date_from or self.date_to) and not entry.date:
            return False
        if self.date_from and entry.date < self.date_from:
            return False
        return not (self.date_to and entry.date > self.date_to)


def _item(text: str, sort_key=None, tooltip: str = "") -> QtGui.QStandardItem:
    item = QtGui.QStandardItem(text)
    item.setEditable(False)
    item.setData(text if sort_key is None else sort_key, SORT_ROLE)
    if tooltip:
        item.setToolTip(tooltip)
    return item


def session_row(entry: SessionEntry) -> list[QtGui.QStandardItem]:
    """The table cells of one session (damaged: the status in red with the reason)."""
    duration = "" if entry.duration_s is None else f"{entry.duration_s:.1f} s"
    markers = ", ".join(label for _t, label in entry.markers)
    status = "ok" if entry.ok else f"damaged: {entry.problem}"
    cells = [
        _item(entry.subject_id or "?", tooltip=entry.path),
        _item(entry.date, entry.recorded_utc, tooltip=entry.recorded_utc),
        _item(entry.condition), _item(", ".join(entry.tags)), _item(entry.trial, tooltip=entry.path),
        _item(duration, -1.0 if entry.duration_s is None else entry.duration_s),
        _item(str(len(entry.sensors)) if entry.ok else "", len(entry.sensors), tooltip=entry.sensors_text()),
        _item(entry.verdicts_text()), _item(str(len(entry.markers)) if entry.ok else "", len(entry.markers),
                                            tooltip=markers),
        _item(status, tooltip=f"{entry.path}: {entry.problem}" if entry.problem else entry.path),
    ]
    cells[0].setData(entry.path, PATH_ROLE)
    if not entry.ok:
        for cell in cells:
            cell.setForeground(QtGui.QBrush(QtGui.QColor(DAMAGED_COLOUR)))
    return cells


class LibraryView(QtWidgets.QWidget):
    """The library in ``folder``.

    Args:
        open_review: called with a session file's path to review it (the main window's).
        open_analysis: called with a session file's path to analyse it (the main window's).
        new_session: called with a subject's id, height (m or None), dominant side and notes
            to make the next recording that subject's.

    Signals:
        refreshed(): the table shows the folder as scanned just now (or the error in the banner).
    """

    refreshed = QtCore.pyqtSignal()

    def __init__(self, folder: Path, open_review: Callable[[Path], object] | None = None,
                 new_session: Callable[[str, float | None, str, str], None] | None = None,
                 parent: QtWidgets.QWidget | None = None,
                 open_analysis: Callable[[Path], object] | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("libraryView")
        self._open_review = open_review
        self._open_analysis = open_analysis
        self._new_session = new_session
        self.library: Library | None = None
        self.entries: dict[str, SessionEntry] = {}
        self.subjects: dict[str, SubjectEntry] = {}
        self.compare_dialogs: list[QtWidgets.QDialog] = []
        self._scan_task: BackgroundTask | None = None
        self._scan_again = False

        self.folder_label = QtWidgets.QLabel(self)
        self.folder_label.setTextInteractionFlags(QtCore.Qt.TextSelectableByMouse)
        change = QtWidgets.QPushButton("Change Folder…", self)
        change.clicked.connect(self.choose_folder)
        self.rescan_button = QtWidgets.QPushButton("Rescan", self)
        self.rescan_button.setToolTip("List files added, changed or removed since the last scan")
        self.rescan_button.clicked.connect(self.refresh)
        self.rebuild_button = QtWidgets.QPushButton("Rebuild Index", self)
        self.rebuild_button.setToolTip("Make the index again from the session files alone (e.g. when it is damaged)")
        self.rebuild_button.clicked.connect(lambda: self.refresh(rebuild=True))
        self.banner = QtWidgets.QLabel(self)
        self.banner.setObjectName("libraryBanner")
        self.banner.setWordWrap(True)
        self.banner.setStyleSheet(f"color: {DAMAGED_COLOUR}; font-weight: bold")
        self.banner.hide()
        top = QtWidgets.QHBoxLayout()
        top.addWidget(QtWidgets.QLabel("Library:", self))
        top.addWidget(self.folder_label, 1)
        top.addWidget(self.rescan_button)
        top.addWidget(self.rebuild_button)
        top.addWidget(change)

        self.subjects_list = QtWidgets.QListWidget(self)
        self.subjects_list.setObjectName("subjectsList")
        self.subjects_list.currentItemChanged.connect(lambda *_: self._subject_changed())
        self.subject_details = QtWidgets.QLabel(self)
        self.subject_details.setWordWrap(True)
        self.subject_details.setTextInteractionFlags(QtCore.Qt.TextSelectableByMouse)
        left = QtWidgets.QWidget(self)
        left_layout = QtWidgets.QVBoxLayout(left)
        left_layout.setContentsMargins(0, 0, 0, 0)
        left_layout.addWidget(QtWidgets.QLabel("<b>Subjects</b>", self))
        left_layout.addWidget(self.subjects_list, 1)
        left_layout.addWidget(self.subject_details)
        self.new_session_button = QtWidgets.QPushButton("New Session for Subject", self)
        self.new_session_button.setObjectName("newSessionButton")
        self.new_session_button.clicked.connect(self.start_new_session)
        left_layout.addWidget(self.new_session_button)
        self.trend_button = QtWidgets.QPushButton("Clinical Test Trend…", self)
        self.trend_button.setObjectName("trendButton")
        self.trend_button.setToolTip("The subject's clinical test results across visits, with the reference")
        self.trend_button.clicked.connect(self.open_trend)
        left_layout.addWidget(self.trend_button)

        self.condition_filter = QtWidgets.QComboBox(self)
        self.tag_filter = QtWidgets.QComboBox(self)
        self.date_from = self._date_edit()
        self.date_to = self._date_edit()
        for combo in (self.condition_filter, self.tag_filter):
            combo.setSizeAdjustPolicy(QtWidgets.QComboBox.AdjustToContents)
            combo.currentIndexChanged.connect(lambda *_: self._apply_filters())
        for edit in (self.date_from, self.date_to):
            edit.dateChanged.connect(lambda *_: self._apply_filters())
        filters = QtWidgets.QHBoxLayout()
        for label, widget in (("Condition", self.condition_filter), ("Tag", self.tag_filter),
                              ("From", self.date_from), ("To", self.date_to)):
            filters.addWidget(QtWidgets.QLabel(label, self))
            filters.addWidget(widget)
        clear = QtWidgets.QPushButton("Clear Filters", self)
        clear.clicked.connect(self.clear_filters)
        filters.addWidget(clear)
        filters.addStretch(1)

        self.model = QtGui.QStandardItemModel(0, len(COLUMNS), self)
        self.model.setHorizontalHeaderLabels(COLUMNS)
        self.proxy = SessionFilter(self)
        self.proxy.setSourceModel(self.model)
        self.table = QtWidgets.QTableView(self)
        self.table.setObjectName("sessionsTable")
        self.table.setModel(self.proxy)
        self.table.setSortingEnabled(True)
        self.table.sortByColumn(1, QtCore.Qt.AscendingOrder)
        self.table.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectRows)
        self.table.setSelectionMode(QtWidgets.QAbstractItemView.ExtendedSelection)
        self.table.verticalHeader().hide()
        self.table.horizontalHeader().setStretchLastSection(True)
        self.table.doubleClicked.connect(lambda *_: self.open_selected())
        QtWidgets.QShortcut(QtGui.QKeySequence(QtCore.Qt.Key_Return), self.table, activated=self.open_selected,
                            context=QtCore.Qt.WidgetShortcut)
        QtWidgets.QShortcut(QtGui.QKeySequence.Delete, self.table, activated=lambda: self.move_to_trash(),
                            context=QtCore.Qt.WidgetShortcut)
        self.table.selectionModel().selectionChanged.connect(lambda *_: self._update_actions())

        self.buttons: dict[str, QtWidgets.QPushButton] = {}
        actions = QtWidgets.QHBoxLayout()
        for key, text, slot in (("open", "Open for Review", self.open_selected),
                                ("analyse", "Open for Analysis", self.analyse_selected),
                                ("compare", "Compare Two…", self.compare_selected),
                                ("rename", "Rename Trial…", lambda: self.rename_trial()),
                                ("tags", "Tags…", lambda: self.set_tags()),
                                ("condition", "Condition…", lambda: self.set_condition()),
                                ("trash", "Move to Trash", lambda: self.move_to_trash())):
            button = QtWidgets.QPushButton(text, self)
            button.setObjectName(f"{key}Button")
            button.setToolTip({"open": "Enter or double-click: the session in the Review workspace",
                               "analyse": "The session's gait, range of motion and report in the Analysis workspace",
                               "trash": "Delete key; the files go to the library's "
                               "trash folder and stay there"}.get(key, ""))
            button.clicked.connect(slot)
            actions.addWidget(button)
            self.buttons[key] = button
        actions.addStretch(1)
        right = QtWidgets.QWidget(self)
        right_layout = QtWidgets.QVBoxLayout(right)
        right_layout.setContentsMargins(0, 0, 0, 0)
        right_layout.addLayout(filters)
        right_layout.addWidget(self.table, 1)
        right_layout.addLayout(actions)

        splitter = QtWidgets.QSplitter(QtCore.Qt.Horizontal, self)
        splitter.addWidget(left)
        splitter.addWidget(right)
        splitter.setStretchFactor(1, 1)
        splitter.setSizes([230, 970])
        layout = page_layout(self)
        layout.addLayout(top)
        layout.addWidget(self.banner)
        layout.addWidget(splitter, 1)
        self._status = status_line(self, layout)
        self.set_folder(Path(folder))

    def statusBar(self) -> QtWidgets.QStatusBar:  # noqa: N802 (as QMainWindow's)
        """The library's status line (what the last scan found)."""
        return self._status

    def _date_edit(self) -> QtWidgets.QDateEdit:
        edit = QtWidgets.QDateEdit(self)
        edit.setCalendarPopup(True)
        edit.setDisplayFormat("yyyy-MM-dd")
        edit.setMinimumDate(_ANY_DATE)
        edit.setSpecialValueText("any")  # shown at the minimum date: no bound
        edit.setDate(_ANY_DATE)
        return edit

    # -- the folder ------------------------------------------------------------------------
    def set_folder(self, folder: Path) -> None:
        """Show the library in ``folder`` (its index made when new; a refused index in the banner)."""
        self.folder = Path(folder)
        self.folder_label.setText(display_path(folder))
        self.folder_label.setToolTip(str(folder))
        try:
            self.library = Library(folder)
        except LibraryError as error:
            self.library = None
            self._show_error(str(error))
            self._fill([], [])
            return
        self.banner.hide()
        self.refresh()

    def choose_folder(self) -> None:
        start = str(self.library.root) if self.library is not None else str(Path.home())
        folder = QtWidgets.QFileDialog.getExistingDirectory(self, "Library Folder", start)
        if folder:
            remember_library_folder(folder)
            self.set_folder(Path(folder))

    def _show_error(self, message: str) -> None:
        log.warning("library: %s", message)
        self.banner.setText(message)
        self.banner.show()

    def refresh(self, rebuild: bool = False) -> None:
        """Scan the folder (``rebuild``: make the index again from the files) off the GUI
        thread, then show the index (:attr:`refreshed`)."""
        if self.library is None:
            self.refreshed.emit()
            return
        if self._scan_task is not None:
            self._scan_again = True
            return
        library = self.library
        self.banner.hide()
        self.statusBar().showMessage("Rebuilding the index from the session files…" if rebuild
                                     else "Scanning the library folder…")
        task = BackgroundTask(lambda _progress: library.rebuild() if rebuild else library.scan(), self)
        task.succeeded.connect(lambda report: self._scanned(library, report, None))
        task.failed.connect(lambda error: self._scanned(library, None, error))
        self._scan_task = task
        task.start()

    def wait_for_scan(self) -> None:
        """Block until a running scan has finished and been shown (tests, closing)."""
        while self._scan_task is not None:
            self._scan_task.wait()
            QtCore.QCoreApplication.sendPostedEvents()
            QtCore.QCoreApplication.processEvents()

    def _scanned(self, library: Library, report, error: str | None) -> None:
        self._scan_task = None
        if library is self.library:
            if error is not None:
                self._show_error(error)
            try:
                self._fill(library.subjects(), library.sessions())
            except LibraryError as problem:
                self._show_error(str(problem))
                self._fill([], [])
            damaged = sum(not e.ok for e in self.entries.values())
            self.statusBar().showMessage(
                f"{plural(len(self.subjects), 'subject')}, {plural(len(self.entries), 'session')}"
                + (f", {damaged} damaged (see Status)" if damaged else "")
                + (f"; {len(report.added)} new, {len(report.removed)} gone since the last scan"
                   if report is not None and (report.added or report.removed) else ""))
        if self._scan_again:
            self._scan_again = False
            self.refresh()
            return
        self.refreshed.emit()

    # -- showing -----------------------------------------------------------------------------
    def _fill(self, subjects: list[SubjectEntry], sessions: list[SessionEntry]) -> None:
        selected_subject = self.selected_subject()
        selected_paths = {e.path for e in self.selected_entries()}
        self.subjects = {s.subject_id: s for s in subjects}
        self.entries = {e.path: e for e in sessions}
        self.proxy.entries = self.entries
        self.subjects_list.blockSignals(True)
        self.subjects_list.clear()
        everything = QtWidgets.QListWidgetItem(f"{ALL_SUBJECTS} ({len(sessions)})")
        everything.setData(QtCore.Qt.UserRole, None)
        self.subjects_list.addItem(everything)
        current = everything
        for subject in subjects:
            item = QtWidgets.QListWidgetItem(f"{subject.subject_id or '(no subject id)'} ({subject.sessions})")
            item.setData(QtCore.Qt.UserRole, subject.subject_id)
            self.subjects_list.addItem(item)
            if subject.subject_id == selected_subject:
                current = item
        self.subjects_list.setCurrentItem(current)
        self.subjects_list.blockSignals(False)
        self.model.removeRows(0, self.model.rowCount())
        for entry in sessions:
            self.model.appendRow(session_row(entry))
        self._fill_choices(self.condition_filter, "any condition", sorted({e.condition for e in sessions if e.condition}))
        self._fill_choices(self.tag_filter, "any tag", sorted({t for e in sessions for t in e.tags}))
        self._subject_changed()
        self.table.resizeColumnsToContents()
        for column in (7, 9):  # calibration, status: long text, a tooltip tells the rest
            self.table.setColumnWidth(column, min(self.table.columnWidth(column), 260))
        if selected_paths:
            self.select_paths(selected_paths)
        self._update_actions()

    @staticmethod
    def _fill_choices(combo: QtWidgets.QComboBox, anything: str, values: list[str]) -> None:
        current = combo.currentData()
        combo.blockSignals(True)
        combo.clear()
        combo.addItem(anything, "")
        for value in values:
            combo.addItem(value, value)
        index = combo.findData(current) if current else 0
        combo.setCurrentIndex(max(index, 0))
        combo.blockSignals(False)

    def _subject_changed(self) -> None:
        subject_id = self.selected_subject()
        subject = self.subjects.get(subject_id) if subject_id is not None else None
        if subject is None:
            self.subject_details.setText("")
        else:
            height = "unknown" if subject.height_m is None else f"{subject.height_m:.2f} m"
            notes = f"<br><i>{subject.notes}</i>" if subject.notes else ""
            self.subject_details.setText(f"<b>{subject.subject_id}</b><br>height {height}, "
                                         f"dominant side {subject.dominance or 'unknown'}{notes}")
        self._apply_filters()

    def _apply_filters(self) -> None:
        date = lambda edit: "" if edit.date() == _ANY_DATE else edit.date().toString("yyyy-MM-dd")  # noqa: E731
        self.proxy.set_criteria(subject=self.selected_subject(), condition=self.condition_filter.currentData() or "",
                                tag=self.tag_filter.currentData() or "", date_from=date(self.date_from),
                                date_to=date(self.date_to))
        self._update_actions()

    def clear_filters(self) -> None:
        for combo in (self.condition_filter, self.tag_filter):
            combo.setCurrentIndex(0)
        for edit in (self.date_from, self.date_to):
            edit.setDate(_ANY_DATE)

    def set_date_range(self, first: str = "", last: str = "") -> None:
        """Filter by date (``YYYY-MM-DD``; '' for no bound)."""
        for edit, text in ((self.date_from, first), (self.date_to, last)):
            edit.setDate(QtCore.QDate.fromString(text, "yyyy-MM-dd") if text else _ANY_DATE)

    def visible_paths(self) -> list[str]:
        """The sessions the table shows, in its order (relative paths)."""
        return [self.proxy.index(row, 0).data(PATH_ROLE) for row in range(self.proxy.rowCount())]

    # -- selection ---------------------------------------------------------------------------
    def selected_subject(self) -> str | None:
        item = self.subjects_list.currentItem()
        return None if item is None else item.data(QtCore.Qt.UserRole)

    def select_subject(self, subject_id: str | None) -> None:
        for row in range(self.subjects_list.count()):
            if self.subjects_list.item(row).data(QtCore.Qt.UserRole) == subject_id:
                self.subjects_list.setCurrentRow(row)
                return
        raise KeyError(f"no subject {subject_id!r} in the library")

    def selected_entries(self) -> list[SessionEntry]:
        rows = self.table.selectionModel().selectedRows(0) if self.table.selectionModel() else []
        return [self.entries[index.data(PATH_ROLE)] for index in rows if index.data(PATH_ROLE) in self.entries]

    def select_paths(self, paths) -> None:
        """Select the table rows of these sessions (relative paths)."""
        selection = QtCore.QItemSelection()
        for row in range(self.proxy.rowCount()):
            if self.proxy.index(row, 0).data(PATH_ROLE) in paths:
                selection.select(self.proxy.index(row, 0), self.proxy.index(row, len(COLUMNS) - 1))
        self.table.selectionModel().select(selection, QtCore.QItemSelectionModel.ClearAndSelect)

    def _update_actions(self) -> None:
        selected = self.selected_entries()
        one_ok = len(selected) == 1 and selected[0].ok
        two = len(selected) == 2 and all(e.ok for e in selected) and selected[0].subject_id == selected[1].subject_id
        uncalibrated = [e.file_name for e in selected if "body" not in e.verdicts]
        self.buttons["open"].setEnabled(one_ok and self._open_review is not None)
        self.buttons["analyse"].setEnabled(one_ok and self._open_analysis is not None)
        self.buttons["compare"].setEnabled(two and not uncalibrated)
        if not two:
            self.buttons["compare"].setToolTip("Select two readable sessions of one subject")
        elif uncalibrated:
            self.buttons["compare"].setToolTip(f"{' and '.join(uncalibrated)}: no body calibration; "
                                               f"{COMPARISON_NEEDS_CALIBRATION}")
        else:
            self.buttons["compare"].setToolTip("")
        for key in ("rename", "tags", "condition"):
            self.buttons[key].setEnabled(one_ok)
        self.buttons["trash"].setEnabled(len(selected) >= 1)
        subject = self.selected_subject() or (selected[0].subject_id if len(selected) == 1 else None)
        self.new_session_button.setEnabled(bool(subject) and self._new_session is not None)
        self.trend_button.setEnabled(bool(subject) and self.library is not None)

    def _one(self) -> SessionEntry | None:
        selected = self.selected_entries()
        return selected[0] if len(selected) == 1 else None

    # -- actions -----------------------------------------------------------------------------
    def open_selected(self):
        entry = self._one()
        if entry is None or not entry.ok or self._open_review is None:
            return None
        return self._open_review(self.library.file(entry))

    def analyse_selected(self):
        entry = self._one()
        if entry is None or not entry.ok or self._open_analysis is None:
            return None
        return self._open_analysis(self.library.file(entry))

    def start_new_session(self) -> None:
        selected = self._one()
        subject_id = self.selected_subject() or (selected.subject_id if selected is not None else None)
        if not subject_id or self._new_session is None:
            return
        subject = self.subjects.get(subject_id)
        self._new_session(subject_id, subject.height_m if subject else None,
                          subject.dominance if subject else "", subject.notes if subject else "")

    def _change(self, what: str, change: Callable[[], SessionEntry]) -> SessionEntry | None:
        try:
            entry = change()
        except (ValueError, OSError, KeyError) as error:
            QtWidgets.QMessageBox.warning(self, what, str(error))
            return None
        self.refresh()
        return entry

    def rename_trial(self, trial: str | None = None) -> SessionEntry | None:
        """Name the selected session's trial (asked when ``trial`` is None); its file is renamed."""
        entry = self._one()
        if entry is None:
            return None
        if trial is None:
            trial, accepted = QtWidgets.QInputDialog.getText(
                self, "Rename Trial", f"Trial name of {entry.file_name}\n(letters, digits, '_', '.', '-'):",
                text=entry.trial)
            if not accepted:
                return None
        return self._change("Rename Trial", lambda: self.library.rename_trial(entry.path, trial))

    def set_tags(self, tags: list[str] | None = None) -> SessionEntry | None:
        """Set the selected session's tags (asked, comma-separated, when ``tags`` is None)."""
        entry = self._one()
        if entry is None:
            return None
        if tags is None:
            text, accepted = QtWidgets.QInputDialog.getText(self, "Tags", f"Tags of {entry.file_name} (comma-separated):",
                                                            text=", ".join(entry.tags))
            if not accepted:
                return None
            tags = text.split(",")
        return self._change("Tags", lambda: self.library.set_tags(entry.path, tags))

    def set_condition(self, condition: str | None = None) -> SessionEntry | None:
        """Set the selected session's condition (asked when ``condition`` is None)."""
        entry = self._one()
        if entry is None:
            return None
        if condition is None:
            known = sorted({e.condition for e in self.entries.values() if e.condition})
            condition, accepted = QtWidgets.QInputDialog.getItem(
                self, "Condition", f"Condition of {entry.file_name} (e.g. pre-op, 6 weeks):",
                [entry.condition] + [c for c in known if c != entry.condition], 0, True)
            if not accepted:
                return None
        return self._change("Condition", lambda: self.library.set_condition(entry.path, condition))

    def move_to_trash(self, confirm: bool = True) -> list[Path]:
        """Move the selected sessions to the library's trash folder (after asking, when ``confirm``)."""
        selected = self.selected_entries()
        if not selected:
            return []
        if confirm:
            names = "\n".join(e.file_name for e in selected[:10]) + ("\n…" if len(selected) > 10 else "")
            answer = QtWidgets.QMessageBox.question(
                self, "Move to Trash", f"Move {plural(len(selected), 'session file')} to {self.library.trash}?\n\n{names}\n\n"
                "They stay there until you delete them yourself.")
            if answer != QtWidgets.QMessageBox.Yes:
                return []
        moved = []
        for entry in selected:
            try:
                moved.append(self.library.move_to_trash(entry.path))
            except (OSError, ValueError) as error:
                QtWidgets.QMessageBox.warning(self, "Move to Trash", f"{entry.file_name}: {error}")
                break
        self.refresh()
        return moved

    def compare_selected(self):
        """Open a comparison of the two selected sessions (the older one as A), a dialog."""
        from mimucap.gui.compare_dialog import CompareDialog

        selected = self.selected_entries()
        if (len(selected) != 2 or selected[0].subject_id != selected[1].subject_id
                or any("body" not in e.verdicts for e in selected)):
            return None
        first, second = sorted(selected, key=lambda e: (e.recorded_utc, e.path))
        dialog = CompareDialog(self.library, first, second, self)
        dialog.finished.connect(lambda _result: self._compare_closed(dialog))
        self.compare_dialogs.append(dialog)
        dialog.show()
        dialog.load()
        return dialog

    def _compare_closed(self, dialog: QtWidgets.QDialog) -> None:
        """A closed comparison is let go (both sessions' data with it)."""
        if dialog in self.compare_dialogs:
            self.compare_dialogs.remove(dialog)
            dialog.deleteLater()

    def open_trend(self):
        """The selected subject's clinical test results across visits (a dialog)."""
        from mimucap.gui.trend_dialog import TrendDialog

        selected = self._one()
        subject = self.selected_subject() or (selected.subject_id if selected is not None else None)
        if not subject or self.library is None:
            return None
        dialog = TrendDialog(self.library, subject, self)
        dialog.show()
        return dialog

    def shutdown(self) -> None:
        """Finish the scan that runs and close the comparisons (the main window closes)."""
        self.wait_for_scan()
        for dialog in list(self.compare_dialogs):
            dialog.close()
        self.compare_dialogs.clear()
