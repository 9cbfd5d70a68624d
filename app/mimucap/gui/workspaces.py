"""The main window's workspaces and the mode bar that switches between them.

One window holds four workspaces, as the motion-capture suites clinicians know do (a live
capture, a review of a recording, its analysis, the library of sessions):

* **Capture**: the live 3D view and plots, the Session and Sensors panels (built by the main
  window itself);
* **Review** (:class:`ReviewWorkspace`): one recording at a time (:class:`~mimucap.gui.review_view.ReviewView`);
* **Analysis** (:class:`AnalysisWorkspace`): the analysis of the recording in Review
  (:class:`~mimucap.gui.analysis_view.AnalysisView`);
* **Library** (:class:`~mimucap.gui.library_view.LibraryView`, made when first shown).

The mode bar (:class:`ModeBar`) stays at the top whatever the workspace: the four workspaces
(Ctrl+1 … Ctrl+4), then the recording's state and the actions a session needs at any moment
(Record/Stop, Add Marker): the live sources keep running while another workspace is shown.
Short tasks (wizards, export options, a comparison) stay dialogs over the window.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap.gui.live_status_bar import RECORDING_STYLE, elapsed_text
from mimucap.gui.status_line import page_layout, status_line

if TYPE_CHECKING:  # the pages' views are imported when first made: a first start waits for none of them
    from mimucap.gui.analysis_view import AnalysisView
    from mimucap.gui.review_view import ReviewView
    from mimucap.session.recorded.review import ReviewData

#: The workspaces, in the mode bar's order (their keys are Ctrl+1 … Ctrl+4).
WORKSPACES = ("capture", "review", "analysis", "library")
#: The mode bar's label and tooltip of each workspace.
WORKSPACE_TITLES = {"capture": "Capture", "review": "Review", "analysis": "Analysis", "library": "Library"}
WORKSPACE_TIPS = {
    "capture": "The live sensors: calibrate, watch and record",
    "review": "Play a recording back, with its markers; export it",
    "analysis": "Gait parameters, range of motion and the report of the recording in Review",
    "library": "Every subject and session in the library folder: open, compare, organise",
}
#: The mode bar's workspace buttons: large, the current one marked.
MODE_BUTTON_STYLE = ("QToolButton { padding: 4px 14px; font-weight: bold; } "
                     "QToolButton:checked { background: #2c3e50; color: white; border-radius: 3px; }")


class ModeBar(QtWidgets.QToolBar):
    """The row at the top of the main window: the workspaces, the recording's state, Record/Stop
    and Add Marker.

    Signals:
        switched(str): the user chose a workspace (one of :data:`WORKSPACES`).
        record_clicked(): Record (or Stop, while recording) was pressed.
        marker_clicked(): Add Marker was pressed.
    """

    switched = QtCore.pyqtSignal(str)
    record_clicked = QtCore.pyqtSignal()
    marker_clicked = QtCore.pyqtSignal()

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__("Workspaces", parent)
        self.setObjectName("modeBar")
        self.setMovable(False)
        self.setFloatable(False)
        self.toggleViewAction().setVisible(False)  # never hidden: the actions must stay in view
        self.setToolButtonStyle(QtCore.Qt.ToolButtonTextOnly)
        group = QtWidgets.QActionGroup(self)
        #: workspace → its checkable action (Ctrl+1 … Ctrl+4)
        self.workspace_actions: dict[str, QtWidgets.QAction] = {}
        for index, name in enumerate(WORKSPACES, start=1):
            action = QtWidgets.QAction(WORKSPACE_TITLES[name], self)
            action.setCheckable(True)
            action.setShortcut(QtGui.QKeySequence(f"Ctrl+{index}"))
            action.setToolTip(f"{WORKSPACE_TIPS[name]} (Ctrl+{index})")
            action.triggered.connect(lambda _checked, n=name: self.switched.emit(n))
            group.addAction(action)
            self.addAction(action)
            button = self.widgetForAction(action)
            button.setObjectName(f"{name}ModeButton")
            button.setStyleSheet(MODE_BUTTON_STYLE)
            self.workspace_actions[name] = action
        self.workspace_actions["capture"].setChecked(True)
        spacer = QtWidgets.QWidget(self)
        spacer.setSizePolicy(QtWidgets.QSizePolicy.Expanding, QtWidgets.QSizePolicy.Preferred)
        self.addWidget(spacer)
        self.recording_badge = QtWidgets.QLabel("", self)
        self.recording_badge.setObjectName("recordingBadge")
        self.recording_badge.setStyleSheet(RECORDING_STYLE)
        self.recording_badge.setToolTip("A recording is running (it goes on whatever the workspace)")
        self._badge_action = self.addWidget(self.recording_badge)
        self._badge_action.setVisible(False)
        self.record_button = QtWidgets.QPushButton("● Record", self)
        self.record_button.setObjectName("modeRecordButton")
        self.record_button.setToolTip("Start or stop recording the live sensors (Ctrl+R)")
        # Not focused by a click: Space (the plots' Pause key) must never stop a recording.
        self.record_button.setFocusPolicy(QtCore.Qt.NoFocus)
        self.record_button.clicked.connect(self.record_clicked)
        self.addWidget(self.record_button)
        self.marker_button = QtWidgets.QPushButton("Add Marker", self)
        self.marker_button.setObjectName("modeMarkerButton")
        self.marker_button.setToolTip("A marker at this moment of the live session (M); its label is the one "
                                      "typed in the Session panel, if any")
        self.marker_button.setFocusPolicy(QtCore.Qt.NoFocus)
        self.marker_button.clicked.connect(self.marker_clicked)
        self.addWidget(self.marker_button)

    def set_workspace(self, name: str) -> None:
        """Mark ``name`` as the workspace shown (without emitting ``switched``)."""
        self.workspace_actions[name].setChecked(True)

    def set_recording(self, on: bool) -> None:
        """The Record button as Stop while recording, and the badge shown (from 00:00)."""
        self.record_button.setText("■ Stop" if on else "● Record")
        self.recording_badge.setText(elapsed_text(0.0))
        self._badge_action.setVisible(on)

    def show_elapsed(self, elapsed_s: float) -> None:
        """The badge shows a recording ``elapsed_s`` long."""
        self.recording_badge.setText(elapsed_text(elapsed_s))

    def set_live(self, live: bool) -> None:
        """Record and Add Marker act on a live session only."""
        self.record_button.setEnabled(live)
        self.marker_button.setEnabled(live)


class EmptyPage(QtWidgets.QWidget):
    """What a workspace shows while it has nothing to show: a title, a sentence on how to get
    something, and buttons that do it; its own status line (messages while it is shown)."""

    def __init__(self, title: str, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.title = QtWidgets.QLabel(f"<h2>{title}</h2>", self)
        self.title.setAlignment(QtCore.Qt.AlignCenter)
        self.text = QtWidgets.QLabel(self)
        self.text.setObjectName("emptyText")
        self.text.setWordWrap(True)
        self.text.setAlignment(QtCore.Qt.AlignCenter)
        self.buttons = QtWidgets.QHBoxLayout()
        self.buttons.addStretch(1)
        layout = page_layout(self)
        layout.addStretch(1)
        layout.addWidget(self.title)
        layout.addWidget(self.text)
        layout.addLayout(self.buttons)
        layout.addStretch(2)
        self.status = status_line(self, layout)

    def add_button(self, text: str, clicked: Callable[[], object]) -> QtWidgets.QPushButton:
        """A button in the row under the sentence (call :meth:`finish_buttons` after the last)."""
        button = QtWidgets.QPushButton(text, self)
        button.clicked.connect(lambda: clicked())
        self.buttons.addWidget(button)
        return button

    def finish_buttons(self) -> None:
        """The row of buttons is complete: it is centred."""
        self.buttons.addStretch(1)


class ReviewWorkspace(QtWidgets.QStackedWidget):
    """The Review workspace: one recording (a :class:`ReviewView`), or a page saying how to
    open one.

    Args:
        ask_to_open: File → Open (asks for a file).
        show_library: switches to the Library workspace.

    Signals:
        changed(): a recording was opened, loaded, reloaded or closed (the window's actions follow).
        loaded(): the recording's result is shown.
    """

    changed = QtCore.pyqtSignal()
    loaded = QtCore.pyqtSignal()

    def __init__(self, ask_to_open: Callable[[], object], show_library: Callable[[], object],
                 parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("reviewWorkspace")
        self.empty = EmptyPage("No recording open", self)
        self.empty.text.setText("Open a recording from the Library, or a session file (File → Open Recording…). "
                                "After a recording, Stop → Review shows it here.")
        self.empty.add_button("Open Recording…", ask_to_open)
        self.empty.add_button("Library", show_library)
        self.empty.finish_buttons()
        self.addWidget(self.empty)
        self.view: ReviewView | None = None

    def statusBar(self) -> QtWidgets.QStatusBar:  # noqa: N802 (as QMainWindow's)
        return self.view.statusBar() if self.view is not None else self.empty.status

    def open(self, path: str | Path) -> ReviewView:
        """Show session file ``path`` (the recording shown before is let go) and load it."""
        self.close_recording()
        from mimucap.gui.review_view import ReviewView

        view = ReviewView(path, self)
        view.loaded.connect(self._loaded)
        view.busy.connect(self.changed)
        view.failed.connect(lambda message: self._failed(view, message))
        self.addWidget(view)
        self.view = view
        self.setCurrentWidget(view)
        view.load()
        self.changed.emit()
        return view

    def _loaded(self) -> None:
        self.changed.emit()
        self.loaded.emit()

    def _failed(self, view: ReviewView, message: str) -> None:
        """Say why the file cannot be reviewed, and show the empty page again."""
        if view is not self.view:
            return
        QtWidgets.QMessageBox.warning(self, "Cannot open the session",
                                      f"{message}\n\nCheck that the file is a MimuCap session (.h5).")
        self.close_recording()
        self.empty.status.showMessage(f"Cannot review {view.path.name}: {message}", 15000)

    def close_recording(self, wait_ms: int = 0) -> None:
        """Let the recording shown go (its data with it; a loading still running is given
        ``wait_ms`` to finish: the program closing); the empty page shows."""
        view, self.view = self.view, None
        if view is None:
            return
        view.shutdown(wait_ms)
        self.removeWidget(view)
        view.hide()
        view.deleteLater()
        self.setCurrentWidget(self.empty)
        self.changed.emit()


class AnalysisWorkspace(QtWidgets.QStackedWidget):
    """The Analysis workspace: the analysis of the recording in Review (an :class:`AnalysisView`,
    made again when Review shows another recording or result), or a page saying how to get one.

    Args:
        show_review: switches to the Review workspace.
        show_library: switches to the Library workspace.
    """

    def __init__(self, show_review: Callable[[], object], show_library: Callable[[], object],
                 parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("analysisWorkspace")
        self.empty = EmptyPage("No recording to analyse", self)
        self.empty.add_button("Review", show_review)
        self.empty.add_button("Library", show_library)
        self.empty.finish_buttons()
        self.addWidget(self.empty)
        self.view: AnalysisView | None = None
        self.show_for(None)

    def statusBar(self) -> QtWidgets.QStatusBar:  # noqa: N802 (as QMainWindow's)
        return self.view.statusBar() if self.view is not None else self.empty.status

    def show_for(self, data: ReviewData | None, loading: str = "") -> AnalysisView | None:
        """Show the analysis of ``data`` (run now unless it is the one shown), or, without data,
        the empty page (``loading``: the file Review is opening, whose analysis follows)."""
        if data is None:
            self.clear()
            self.empty.text.setText(
                f"Opening {loading} in Review; its analysis follows." if loading else
                "The analysis works on the recording in Review: open one there, or choose one in the Library "
                "(Open for Analysis).")
            return None
        if self.view is not None and self.view.data is data:
            return self.view
        self.clear()
        from mimucap.gui.analysis_view import AnalysisView

        view = AnalysisView(self, data)
        self.addWidget(view)
        self.view = view
        self.setCurrentWidget(view)
        view.run()
        return view

    def clear(self, wait_ms: int = 0) -> None:
        """Let the analysis shown go (one still running is given ``wait_ms`` to finish: the
        program closing); the empty page shows."""
        view, self.view = self.view, None
        if view is not None:
            view.shutdown(wait_ms)
            self.removeWidget(view)
            view.hide()
            view.deleteLater()
        self.setCurrentWidget(self.empty)
