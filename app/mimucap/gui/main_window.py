"""The main window: one window with four workspaces (:mod:`mimucap.gui.workspaces`) switched
from the mode bar at its top: Capture (the 3D skeleton view, live plots, sensor panel and
session panel around a :class:`~mimucap.session.live.live_session.LiveSession`), Review (a
recording played back), Analysis (the recording in Review analysed) and Library. The live
session runs whatever the workspace shown; the mode bar keeps Record/Stop, Add Marker and the
recording's state in view.

The window holds no data: it shows what the live session has and forwards what the user
asks. One timer moves time forward: the pump (:data:`PUMP_INTERVAL_MS`) runs the session's
pipeline (:meth:`~mimucap.session.live.live_session.LiveSession.step`). Nothing polls the session: each
widget subscribes to the session's events when the session is set (the 3D view to ``frame``,
the plots to ``data``, the sensor panel to ``status``, the session panel to ``checklist``,
``recording_progress`` and ``marker``, the status bar (:mod:`mimucap.gui.live_status_bar`) to
``status``, ``pose_source``, ``source_problem``, ``refused``, ``truth_errors``, ``recording``
and ``recording_progress``) and lets it go when the source changes or the window closes. The 3D view and the plots coalesce the events into at most one picture per
frame interval (60 and 30 a second); the session publishes its status 4 times a second.
"""

from __future__ import annotations

import dataclasses
import importlib

import logging
from collections.abc import Callable
from pathlib import Path

from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap import __version__
from mimucap.acquisition.pairing import UnpairedSensor
from mimucap.acquisition.source_spec import ReplaySpec, parse_source_spec
from mimucap.gui.assignment_dialog import AssignmentDialog, remembered_assignment
from mimucap.gui.background_task import BackgroundTask
from mimucap.gui.capture import ask_to_save_screenshot, save_screenshot
from mimucap.gui.live_plots import LivePlots
from mimucap.gui.live_status_bar import LiveStatusBar
from mimucap.gui.recording_saver import RecordingSaver
from mimucap.gui.lsl_switch import LslSwitch
from mimucap.gui.menus import choice_actions, truth_action
from mimucap.gui.workspaces import WORKSPACES, AnalysisWorkspace, ModeBar, ReviewWorkspace
from mimucap.gui.scene.view import SceneView
from mimucap.gui.screen_fit import fit_on_screen
from mimucap.gui.scrolling import scrolling
from mimucap.gui.sensor_panel import SensorPanel
from mimucap.gui.session_panel import SessionPanel, display_path
from mimucap.gui.settings import gui_settings
from mimucap.gui.source_dialog import (
    DEFAULT_SPEC,
    PairDevicesDialog,
    SourceDialog,
    last_skeleton_model,
    last_source_spec,
    remember_source,
)
from mimucap.io.calibration_store import user_data_dir
from mimucap.io.recording_import import IMPORT_SUFFIXES, import_recording
from mimucap.session.views.camera import CAMERA_PRESETS
from mimucap.session.views.skeleton_figure import DISPLAY_MODES
from mimucap.session.live.kernel_preparation import KernelPreparation
from mimucap.session.live.live_session import LiveSession, open_live_session
from mimucap.io.library import library_fields, recording_path
from mimucap.io.library_settings import configured_library_folder, remember_library_folder
from mimucap.session.live.checklist import CheckItem, recording_checklist

log = logging.getLogger(__name__)

#: Whether this process has compiled the fusion kernels (see :meth:`MainWindow.start`).
_kernels_ready = False

#: The frame clock (ms): the live pipeline is pumped and the 3D view rendered 62.5 times a
#: second, so a sample waits at most one tick before it is drawn.
PUMP_INTERVAL_MS = 16
#: The window's size where the screen has room (px): a 1920 × 1080 screen shows the 3D view,
#: the plots and the tables large; smaller screens get their free area (:func:`fit_on_screen`).
WINDOW_SIZE_PX = (1680, 1000)
#: The Sensors dock's height when the window opens (px).
SENSOR_DOCK_START_PX = 190
#: A dock takes at most this share of a small window's height (Sensors) or width (Session).
DOCK_MOST_SHARE = 0.3
ABOUT_TEXT = (
    "<h3>MimuCap {version}</h3>"
    "<p>Human motion capture with magnetic-inertial sensors: live skeleton, joint angles, "
    "recording, review and export.</p>"
    "<p>Built with PyQt5, VTK, pyqtgraph, NumPy, SciPy and h5py.</p>"
)


#: The wizards (name → module, class). Each is imported when it is first opened: the
#: clinical-test wizard alone pulls in scipy.signal, seconds of a first start's import time.
WIZARDS = {
    "magnetometer": ("mimucap.gui.wizards.magnetometer", "MagnetometerWizard"),
    "body": ("mimucap.gui.wizards.body", "BodyCalibrationWizard"),
    "rom": ("mimucap.gui.wizards.rom", "RomWizard"),
    "clinical_test": ("mimucap.gui.wizards.clinical_test", "ClinicalTestWizard"),
}


def wizard_class(name: str) -> type:
    """The wizard class ``name`` (a key of :data:`WIZARDS`), imported on first use."""
    module, attribute = WIZARDS[name]
    return getattr(importlib.import_module(module), attribute)


class MainWindow(QtWidgets.QMainWindow):
    """MimuCap's main window.

    Signals:
        recording_saved(object): a stopped recording's session file was written (its
            ``RecordingResult``).

    Args:
        source: the source spec to start with (default: the one chosen last time).
        session_factory: builds a :class:`LiveSession` from a spec (tests pass one with a
            fast clock); by default :func:`open_live_session` with the skeleton model chosen
            in the source dialog (:attr:`model_name`).
    """

    recording_saved = QtCore.pyqtSignal(object)

    def __init__(self, source: str | None = None,
                 session_factory: Callable[[str], LiveSession] | None = None) -> None:
        super().__init__()
        self.setObjectName("mainWindow")
        self.setWindowTitle("MimuCap")
        fit_on_screen(self, *WINDOW_SIZE_PX)
        self.model_name = last_skeleton_model()
        self.session_factory = session_factory or (
            lambda spec: open_live_session(spec, model_name=self.model_name))
        self.live: LiveSession | None = None
        self.library_view = None  # gui.library_view.LibraryView once the Library is first shown
        self._unreviewed: Path | None = None  # a recording saved since Review last showed one
        self._review_then_analyse = False  # the recording opening in Review is to be analysed
        self._live_truth = False  # whether the live source has the simulator's truth
        self._last_record_message = ""
        #: writes stopped recordings' session files in the background
        self.saver = RecordingSaver(self)
        self.saver.saved.connect(self._recording_saved)
        self.saver.not_saved.connect(self._recording_not_saved)
        self.saver.idle.connect(self._saving_done)
        self._warm_up: BackgroundTask | None = None
        self._preparation: KernelPreparation | None = None
        self._wizard: QtWidgets.QWidget | None = None
        self._sensors_seen: set[str] = set()  # sensors the remembered assignment was offered to
        self.last_recording = None  # RecordingResult of the last recording saved
        self._closing_progress: QtWidgets.QProgressDialog | None = None
        self._guide: QtWidgets.QWidget | None = None  # Help → User Guide, made when first asked
        #: Asked before recording while an item of the checklist is not ok (the items not ok);
        #: True records anyway. Tests and scripts may replace it.
        self.confirm_recording: Callable[[list[CheckItem]], bool] = self._ask_to_record_anyway

        self.scene_view = SceneView(self)
        self.plots = LivePlots(self, relative_time=True)
        splitter = QtWidgets.QSplitter(QtCore.Qt.Horizontal, self)
        splitter.addWidget(self.scene_view)
        splitter.addWidget(self.plots)
        splitter.setStretchFactor(0, 3)
        splitter.setStretchFactor(1, 2)
        splitter.setSizes([760, 520])
        self.review = ReviewWorkspace(self.ask_open_session, lambda: self.show_workspace("library"), self)
        self.review.changed.connect(self._update_review_actions)
        self.review.loaded.connect(self._review_loaded)
        self.analysis = AnalysisWorkspace(lambda: self.show_workspace("review"),
                                          lambda: self.show_workspace("library"), self)
        self.library_page = QtWidgets.QWidget(self)  # holds the library view once made
        QtWidgets.QVBoxLayout(self.library_page).setContentsMargins(0, 0, 0, 0)
        self.workspaces = QtWidgets.QStackedWidget(self)
        self.workspaces.setObjectName("workspaces")
        for page in (splitter, self.review, self.analysis, self.library_page):
            self.workspaces.addWidget(page)
        self.setCentralWidget(self.workspaces)
        self.mode_bar = ModeBar(self)
        self.addToolBar(QtCore.Qt.TopToolBarArea, self.mode_bar)
        self.mode_bar.switched.connect(self.show_workspace)
        self.mode_bar.record_clicked.connect(self.toggle_recording)

        self.session_panel = SessionPanel(self)
        self.session_dock = self._dock("Session", "sessionDock", scrolling(self.session_panel),
                                       QtCore.Qt.LeftDockWidgetArea)
        self.sensor_panel = SensorPanel(self)
        self.sensor_dock = self._dock("Sensors", "sensorDock", self.sensor_panel, QtCore.Qt.BottomDockWidgetArea)
        scrollbar = self.style().pixelMetric(QtWidgets.QStyle.PM_ScrollBarExtent)
        #: dock → (size it keeps (px), the direction it is sized in); see :meth:`resizeEvent`
        self._dock_sizes = {
            self.sensor_dock: (SENSOR_DOCK_START_PX, QtCore.Qt.Vertical),
            self.session_dock: (self.session_panel.sizeHint().width() + scrollbar, QtCore.Qt.Horizontal)}
        for dock, (size, orientation) in self._dock_sizes.items():
            self.resizeDocks([dock], [size], orientation)
        self.installEventFilter(self)

        self.session_panel.marker_requested.connect(self.add_marker)
        self.mode_bar.marker_clicked.connect(self.session_panel.request_marker)
        self.session_panel.height.valueChanged.connect(self._height_changed)
        self.saver.progress.connect(self.session_panel.show_saving_progress)

        self._build_menus()
        self._build_status_bar()

        self._pump = QtCore.QTimer(self)
        self._pump.setTimerType(QtCore.Qt.PreciseTimer)
        self._pump.setInterval(PUMP_INTERVAL_MS)
        self._pump.timeout.connect(self._pump_pipeline)
        #: the window's own subscriptions to the live session's events (event name → callback)
        self._subscriptions = {
            "truth_available": self._live_truth_available, "sensors": self._assign_remembered,
            "recording_failed": self._recording_failed, "unpaired": self._unpaired_heard,
            "recording_progress": lambda info: self.mode_bar.show_elapsed(info.elapsed_s)}
        #: the sensors the source refuses as not paired; the device ids offered for pairing so far
        self._unpaired: list[UnpairedSensor] = []
        self._offered: set[str] = set()
        self._pair_dialog: PairDevicesDialog | None = None
        self.source_error: str | None = None
        if not self.open_source(source or last_source_spec(), interactive=False) and source is None:
            error = self.source_error  # a remembered source that went away: say so over the fallback
            self.open_source(DEFAULT_SPEC, interactive=False)
            self.source_error = error
            self.statusBar().showMessage(f"{error[0].upper()}{error[1:]}; showing the simulated suit instead.")

    # -- construction ------------------------------------------------------------------------
    def _dock(self, title: str, name: str, widget: QtWidgets.QWidget, area) -> QtWidgets.QDockWidget:
        """``widget`` in a movable (not closable) dock named ``name`` at ``area``."""
        dock = QtWidgets.QDockWidget(title, self)
        dock.setObjectName(name)
        dock.setWidget(widget)
        dock.setFeatures(QtWidgets.QDockWidget.DockWidgetMovable)
        self.addDockWidget(area, dock)
        return dock

    def _build_menus(self) -> None:
        bar = self.menuBar()
        file_menu = bar.addMenu("&File")
        self.action_source = file_menu.addAction("Choose &Source…", self.choose_source)
        self.action_source.setShortcut(QtGui.QKeySequence("Ctrl+Shift+O"))
        self.action_open = file_menu.addAction("&Open Recording…", self.ask_open_session)
        self.action_open.setShortcut(QtGui.QKeySequence.Open)
        self.action_open.setStatusTip("A session file (or an Xsens MVNX or OpenSense file to import) in the Review workspace")
        self.action_close_recording = file_menu.addAction("&Close Recording", self.review.close_recording)
        self.action_close_recording.setShortcut(QtGui.QKeySequence.Close)
        self.action_export = file_menu.addAction("&Export Recording…", self.export_recording)
        self.action_export.setShortcut(QtGui.QKeySequence("Ctrl+E"))
        self.action_export.setStatusTip("Export the recording in Review (else the last one recorded)")
        self.action_folder = file_menu.addAction("Library &Folder…", self.choose_recording_folder)
        file_menu.addSeparator()
        self.lsl_switch = LslSwitch(self, file_menu)
        file_menu.addSeparator()
        self.action_save_screenshot = file_menu.addAction("Save Screens&hot…",
                                                          lambda: ask_to_save_screenshot(self, "mimucap.png"))
        self.action_save_screenshot.setShortcut(QtGui.QKeySequence("Ctrl+Shift+S"))
        file_menu.addSeparator()
        self.action_quit = file_menu.addAction("&Quit", self.close)
        self.action_quit.setShortcut(QtGui.QKeySequence.Quit)

        session_menu = bar.addMenu("&Session")
        self.action_assign = session_menu.addAction("&Assign Sensors…", self.assign_sensors)
        self.action_record = session_menu.addAction("Start &Recording", self.toggle_recording)
        self.action_record.setShortcut(QtGui.QKeySequence("Ctrl+R"))
        self.action_marker = session_menu.addAction("Add &Marker", self.session_panel.request_marker)
        self.action_marker.setShortcut(QtGui.QKeySequence("M"))
        self.action_pair = session_menu.addAction("&Pair Devices…", self.pair_devices)
        self.action_pair.setEnabled(False)

        view_menu = bar.addMenu("&View")
        #: workspace → the action that shows it (in the mode bar and this menu)
        self.workspace_actions = self.mode_bar.workspace_actions
        for name in WORKSPACES:
            view_menu.addAction(self.workspace_actions[name])
        self.action_library = self.workspace_actions["library"]
        view_menu.addSeparator()
        self.camera_actions = choice_actions(view_menu.addMenu("&Camera"), CAMERA_PRESETS, str.capitalize,
                                             self.set_camera_preset, self.scene_view.camera_preset,
                                             numbered_shortcuts="Alt")
        self.display_actions = choice_actions(view_menu.addMenu("&Display Mode"), DISPLAY_MODES,
                                              lambda name: f"{name.capitalize()} Mode", self.set_display_mode, "world")
        self.action_toggle_display = view_menu.addAction("&Toggle Body/World", self.toggle_display_mode)
        self.action_toggle_display.setShortcut(QtGui.QKeySequence("B"))
        view_menu.addSeparator()
        self.action_floor = view_menu.addAction("Show &Floor")
        self.action_floor.setCheckable(True)
        self.action_floor.setChecked(True)
        self.action_floor.toggled.connect(self._update_stage)
        self.action_axes = view_menu.addAction("Show World &Axes")
        self.action_axes.setCheckable(True)
        self.action_axes.setChecked(True)
        self.action_axes.toggled.connect(self._update_stage)
        self.action_truth = truth_action(view_menu, lambda _on: self._update_ghost())
        # The key belongs to the plots' Pause button (a second shortcut on the same key would
        # make both ambiguous); the menu names it.
        self.action_pause_plots = view_menu.addAction("&Pause Plots\tSpace")
        self.action_pause_plots.setCheckable(True)
        self.action_pause_plots.toggled.connect(self.plots.pause_button.setChecked)
        self.plots.pause_button.toggled.connect(self.action_pause_plots.setChecked)
        self.action_play = view_menu.addAction("Play/Pause &Review", self._toggle_play)
        self.action_play.setShortcut(QtGui.QKeySequence("Ctrl+Space"))
        self._update_review_actions()

        self.calibrate_menu = bar.addMenu("&Calibrate")
        self.action_magcal = self.calibrate_menu.addAction("&Magnetometers…", lambda: self.open_wizard("magnetometer"))
        self.action_bodycal = self.calibrate_menu.addAction("&Body…", lambda: self.open_wizard("body"))
        assess = bar.addMenu("&Assess")
        self.action_rom = assess.addAction("&Range of Motion…", lambda: self.open_wizard("rom"))
        self.action_clinical_test = assess.addAction("&Clinical Test…", lambda: self.open_wizard("clinical_test"))

        help_menu = bar.addMenu("&Help")
        self.action_guide = help_menu.addAction("&User Guide", self.show_user_guide)
        self.action_guide.setShortcut(QtGui.QKeySequence.HelpContents)
        self.action_about = help_menu.addAction("&About MimuCap", self.show_about)

    def _build_status_bar(self) -> None:
        self.live_status = LiveStatusBar(self.statusBar(), lambda: self.scene_view.render_times)
        self.live_status.hint_changed.connect(self.scene_view.set_hint)

    # -- workspaces ------------------------------------------------------------------------------
    @property
    def workspace(self) -> str:
        """The workspace shown (one of :data:`~mimucap.gui.workspaces.WORKSPACES`)."""
        return WORKSPACES[self.workspaces.currentIndex()]

    def show_workspace(self, name: str) -> None:
        """Show workspace ``name``; the live session runs on whichever is shown. The Session and
        Sensors panels and the live status bar belong to Capture; the other workspaces have their
        own status lines. Review shows a recording saved since it last showed one; Analysis
        analyses the recording in Review; the Library is made when first shown."""
        if name not in WORKSPACES:
            raise ValueError(f"unknown workspace {name!r}; one of {', '.join(WORKSPACES)}")
        if name == "review" and self._unreviewed is not None:
            path, self._unreviewed = self._unreviewed, None
            self.open_review(path)
            return
        capture = name == "capture"
        for dock in (self.session_dock, self.sensor_dock):
            dock.setVisible(capture)
        self.statusBar().setVisible(capture)
        self.workspaces.setCurrentIndex(WORKSPACES.index(name))
        self.mode_bar.set_workspace(name)
        if capture:
            for dock, (size, orientation) in self._dock_sizes.items():
                self.resizeDocks([dock], [size], orientation)
        elif name == "analysis":
            self._show_analysis()
        elif name == "library":
            self._show_library()
        self._update_title()

    def say(self, message: str, timeout_ms: int = 0) -> None:
        """Show ``message`` in the status line of the workspace shown (the window's status bar
        in Capture)."""
        page = self.workspaces.currentWidget()
        bar = page.statusBar() if hasattr(page, "statusBar") else None
        if self.library_view is not None and page is self.library_page:
            bar = self.library_view.statusBar()
        (bar or self.statusBar()).showMessage(message, timeout_ms)

    def _update_title(self) -> None:
        recording = self.live is not None and self.live.recording
        view = self.review.view if self.workspace in ("review", "analysis") else None
        title = "MimuCap" if view is None else f"{view.path.name} — MimuCap"
        self.setWindowTitle(f"● Recording — {title}" if recording else title)

    def _update_review_actions(self) -> None:
        """The actions on the recording in Review follow it (none, loading, shown); without a
        recording in Review, Analysis has none either."""
        view = self.review.view
        if view is None:
            self.analysis.clear()
            self._review_then_analyse = False  # what was to be analysed is gone (closed, unreadable)
        ready = view is not None and view.ready
        last = self.last_recording
        has_last = last is not None and last.session_path is not None and sum(last.samples.values()) > 0
        self.action_export.setEnabled(ready or has_last)
        self.action_close_recording.setEnabled(view is not None)
        self.action_play.setEnabled(ready)
        self._update_truth_action()
        self._update_title()

    def _review_loaded(self) -> None:
        """The recording in Review is shown: Analysis follows it (analysed when it is shown)."""
        data = self.review.view.player.data
        if self._review_then_analyse:
            self._review_then_analyse = False
            self.show_workspace("analysis")
        elif self.workspace == "analysis":
            self.analysis.show_for(data)
        elif self.analysis.view is not None and self.analysis.view.data is not data:
            self.analysis.clear()  # another recording or result: analysed again when asked

    def _show_analysis(self) -> None:
        view = self.review.view
        if view is not None and view.player is not None and view.ready:
            self.analysis.show_for(view.player.data)
        else:
            self.analysis.show_for(None, loading=view.path.name if view is not None else "")

    def _toggle_play(self) -> None:
        if self.review.view is not None and self.review.view.ready:
            self.show_workspace("review")
            self.review.view.play_button.toggle()

    # -- the live session ----------------------------------------------------------------------
    def open_source(self, spec: str, interactive: bool = True) -> bool:
        """Stop the current source and start ``spec``; False (and a message, in a dialog when
        ``interactive``, else in the status bar and :attr:`source_error`) if it fails."""
        if self._refused_while_recording():
            return False
        try:
            session = self.session_factory(spec)
        except (ValueError, OSError) as error:
            log.warning("cannot open source %s: %s", spec, error)
            self.source_error = f"cannot open source {spec}: {error}"
            self.statusBar().showMessage(f"Cannot open source {spec}: {error}")
            if interactive:
                QtWidgets.QMessageBox.warning(self, "Source", f"Cannot open source {spec}:\n{error}\n\nChoose another source (File → Choose Source).")
            return False
        previous = self.live
        self._stop_live()
        self.source_error = None
        self.statusBar().clearMessage()
        self._close_wizard("the source changed")
        self.live = session
        kept = self._keep_body_calibration(previous, session)
        # A replayed recording keeps the placement stored in it (the source gives it); other
        # sources take the assignment made last time.
        replayed = isinstance(parse_source_spec(spec), ReplaySpec)
        remembered = {} if replayed else remembered_assignment()
        for sensor_id, segment in remembered.items():
            if sensor_id in session.sensor_ids and segment in session.model.segment_names:
                session.assign_sensor(sensor_id, segment)
        self._sensors_seen = set(session.sensor_ids)   # later ones: _assign_remembered
        session.set_height(self.session_panel.height.value())
        session.set_display_mode(next(k for k, a in self.display_actions.items() if a.isChecked()))
        self.scene_view.set_figure(session.builder)
        self._connect_live(session)
        if self.isVisible():
            self.start()
        if kept:
            self.statusBar().showMessage(kept, 10000)
        return True

    @staticmethod
    def _keep_body_calibration(previous: LiveSession | None, session: LiveSession) -> str:
        """Carry the body calibration over to the new source when it drives the same skeleton
        (the sensors that are still worn keep their segments; magnetometer calibrations come
        from the store by themselves); returns what the status bar should say ("" if nothing)."""
        calibration = None if previous is None else previous.body_calibration
        if calibration is None or previous.model.name != session.model.name:
            return ""
        session.apply_body_calibration(calibration)
        return (f"The body calibration ({len(calibration.sensors)} segments) is kept for the new source; "
                "Calibrate → Body… to redo it.")

    def _refused_while_recording(self) -> bool:
        """True (and said in a dialog) while recording: the source cannot change then."""
        if self.live is not None and self.live.recording:
            QtWidgets.QMessageBox.warning(self, "Recording", "Stop the recording before changing the source.")
            return True
        return False

    def _connect_live(self, session: LiveSession) -> None:
        """Every widget follows ``session``'s events (the previous session's are let go), and the
        session publishes its state once for them."""
        self.scene_view.set_model(session)
        self.plots.set_source(session)
        self.sensor_panel.set_session(session)
        self.session_panel.set_session(session)
        self.live_status.set_session(session)
        self.mode_bar.set_live(True)
        for name, callback in self._subscriptions.items():
            getattr(session.events, name).connect(callback)
        self._update_ghost()
        self._live_truth_available(session.has_truth)
        self.lsl_switch.follow(session)
        session.publish_status()

    def _disconnect_live(self) -> None:
        """Every widget lets the live session go (no subscription of this window stays on it)."""
        live = self.live
        self.scene_view.set_model(None)
        self.plots.set_source(None)
        self.sensor_panel.set_session(None)
        self.session_panel.set_session(None)
        self.live_status.set_session(None)
        self.mode_bar.set_live(False)
        self.lsl_switch.follow(None)
        if live is not None:
            for name, callback in self._subscriptions.items():
                getattr(live.events, name).disconnect(callback)

    def _stop_live(self) -> None:
        if self.live is None:
            return
        self._disconnect_live()
        try:
            self.live.stop()
        except Exception:  # a source failing to stop must not keep the window from closing
            log.exception("stopping the source failed")
        self.live = None

    def start(self) -> None:
        """Start the source, pumping, rendering and refreshing (call after ``show()``).

        The first time in a process, the fusion kernels are made ready first, by a background
        thread (:mod:`mimucap.session.live.kernel_preparation`): the module compiled ahead of time at
        installation when it is current, else numba's cache, filled by a child process when it
        lacks them; so the GUI thread never compiles them on the first sample."""
        global _kernels_ready
        if not _kernels_ready:
            if self._warm_up is None:
                self._preparation = KernelPreparation()
                self._warm_up = BackgroundTask(lambda _progress: self._preparation.run(), self)
                self._warm_up.succeeded.connect(self._kernels_compiled)
                self._warm_up.failed.connect(self._kernels_compiled)  # then they compile on first use
                self._warm_up.start()
                self.statusBar().showMessage("Preparing the orientation filters (the first start after an "
                                             "installation takes up to a minute)…")
            return
        self._start_live()

    def _kernels_compiled(self, _result=None) -> None:
        global _kernels_ready
        _kernels_ready = True
        self.statusBar().clearMessage()
        if self.isVisible() and self._warm_up is not None:
            self._start_live()

    @property
    def starting(self) -> bool:
        """True while the fusion kernels are being prepared before the first start."""
        return not _kernels_ready

    def _start_live(self) -> None:
        if self.live is not None and not self.live.started:
            self.live.start()
        self._pump.start()
        self.scene_view.start()

    def _pump_pipeline(self) -> None:
        """The clock of the live view: the session takes in what arrived and tells its
        subscribers what changed."""
        if self.live is None:
            return
        try:
            self.live.step()
        except Exception as error:  # shown, logged; the pump stops instead of looping on an error
            log.exception("live pipeline failed")
            self._pump.stop()
            self.say(f"Live data stopped: {error}. Choose the source again (File → Choose Source).")

    def _recording_failed(self, message: str) -> None:
        """The recording could not be written: end it and say why, once the session's step is
        over (a dialog's event loop must not run the pump inside the step)."""
        QtCore.QTimer.singleShot(0, lambda: self._end_failed_recording(message))

    def _end_failed_recording(self, message: str) -> None:
        if self.live is not None and self.live.recording:
            self._finish_recording()
        QtWidgets.QMessageBox.critical(self, "Recording stopped", message)

    def _update_ghost(self) -> None:
        """Show the simulator's truth as a ghost figure and dashed curves when asked, live and in
        Review (sources and recordings without truth give none)."""
        on = self.action_truth.isChecked()
        self.scene_view.set_ghost_visible(on)
        self.plots.set_show_truth(on)
        if self.review.view is not None:
            self.review.view.set_show_truth(on)

    def _live_truth_available(self, available: bool) -> None:
        self._live_truth = bool(available)
        self._update_truth_action()

    def _update_truth_action(self) -> None:
        """View → Show Simulator Truth is offered while the live source or the recording in
        Review has the simulator's truth."""
        live = self.live is not None and self._live_truth
        self.action_truth.setEnabled(live or (self.review.view is not None and self.review.view.has_truth))

    def _assign_remembered(self, sensor_ids) -> None:
        """Wear each sensor that appeared since the last call (a worker source's sensors appear
        with their first samples: the session's ``sensors`` event) on the segment remembered
        for it, unless that segment is taken."""
        live = self.live
        new = [sid for sid in sensor_ids if sid not in self._sensors_seen]
        if live is None or not new:
            return
        self._sensors_seen.update(new)
        remembered = remembered_assignment()
        for sensor_id in new:
            segment = remembered.get(sensor_id)
            if (segment in live.model.segment_names and sensor_id not in live.sensor_segments
                    and segment not in live.sensor_segments.values()):
                live.assign_sensor(sensor_id, segment)

    # -- user actions: source, sensors, recording ------------------------------------------------
    def choose_source(self) -> None:
        """Ask for a source and a skeleton; both are used and remembered only if the source
        opens (not while recording, nor when it fails)."""
        if self._refused_while_recording():
            return
        dialog = SourceDialog(self, self.live.label if self.live is not None else None, self.model_name)
        if dialog.exec_() != QtWidgets.QDialog.Accepted:
            return
        previous_model, self.model_name = self.model_name, dialog.model_name
        if self.open_source(dialog.spec):
            remember_source(dialog.spec, dialog.model_name)
        else:
            self.model_name = previous_model

    def _unpaired_heard(self, sensors: list[UnpairedSensor]) -> None:
        """The source refuses ``sensors`` as not paired: offer to pair each device the first
        time it is heard (Session → Pair Devices… offers them again). A node still to say which
        device it is (its hello on the way) is left out until it has said."""
        self._unpaired = [sensor for sensor in sensors if sensor.device.settled]
        self.action_pair.setEnabled(any(sensor.pairable for sensor in sensors))
        if any(sensor.pairable and sensor.device.device_id not in self._offered for sensor in sensors):
            self.pair_devices()

    def pair_devices(self) -> None:
        """Offer to pair the devices the source refuses as not paired (a dialog that leaves the
        live view running; one at a time)."""
        live = self.live
        if live is None or live.pairing_store is None or self._pair_dialog is not None or not self._unpaired:
            return
        self._offered.update(sensor.device.device_id for sensor in self._unpaired if sensor.pairable)
        dialog = self._pair_dialog = PairDevicesDialog(self, live.label, self._unpaired)
        dialog.finished.connect(lambda result: self._pair_dialog_closed(dialog, result))
        dialog.open()

    def _pair_dialog_closed(self, dialog: PairDevicesDialog, result: int) -> None:
        """Pair the devices chosen, and open the source again so that it lets them in (after
        the recording, if one runs); offer what was heard meanwhile."""
        self._pair_dialog = None
        chosen = dialog.chosen() if result == QtWidgets.QDialog.Accepted else []
        live = self.live
        if chosen and live is not None and live.pairing_store is not None:
            try:
                added = live.pairing_store.pair((sensor.device.device_id, sensor.sensor) for sensor in chosen)
            except (ValueError, OSError) as error:
                log.warning("cannot pair: %s", error)
                QtWidgets.QMessageBox.warning(self, "Pair Devices", f"Cannot pair the devices: {error}")
                return
            if live.recording:
                self.statusBar().showMessage(f"Paired {len(added)} devices: they join when the source is opened "
                                             "again after this recording (File → Choose Source…).", 10000)
            elif self.open_source(live.label):
                self.statusBar().showMessage(f"Paired {len(added)} devices; the source was opened again "
                                             "to take their data.", 10000)
        if any(sensor.pairable and sensor.device.device_id not in self._offered for sensor in self._unpaired):
            self.pair_devices()

    def assign_sensors(self) -> None:
        if self.live is None:
            return
        dialog = AssignmentDialog(self, self.live.sensor_ids, self.live.model.segment_names, self.live.sensor_segments)
        self._dialog = dialog
        if dialog.exec_() == QtWidgets.QDialog.Accepted:
            self.apply_assignment(dialog.assignment())

    def apply_assignment(self, assignment: dict[str, str]) -> None:
        for sensor_id in list(self.live.sensor_segments):
            if sensor_id not in assignment:
                self.live.assign_sensor(sensor_id, None)
        for sensor_id, segment in assignment.items():
            self.live.assign_sensor(sensor_id, segment)

    @staticmethod
    def library_folder() -> Path:
        """The library folder as configured (:mod:`mimucap.io.library_settings`); not chosen
        yet: the documents folder's "MimuCap Library" (or the recording folder chosen before the
        library existed). Not created here."""
        documents = QtCore.QStandardPaths.writableLocation(QtCore.QStandardPaths.DocumentsLocation)
        default = Path(documents) / "MimuCap Library" if documents else user_data_dir() / "library"
        return configured_library_folder(gui_settings().value("recording/folder", str(default)))

    def recording_folder(self) -> Path:
        """Where recordings go: the library folder (created when needed; ``OSError`` if it cannot
        be, e.g. a network drive that went away)."""
        folder = self.library_folder()
        folder.mkdir(parents=True, exist_ok=True)
        return folder

    def _folder_to_browse(self) -> Path:
        """The recording folder for a file dialog to start in, or the home folder (said in the
        status bar) when it is out of reach: the user can still browse and choose another."""
        try:
            return self.recording_folder()
        except OSError as error:
            log.warning("recording folder unavailable: %s", error)
            self.say(f"The recording folder is out of reach ({error}); "
                                         "choose another one (File → Library Folder).", 10000)
            return Path.home()

    def choose_recording_folder(self) -> None:
        folder = QtWidgets.QFileDialog.getExistingDirectory(self, "Library Folder", str(self._folder_to_browse()))
        if folder:
            remember_library_folder(folder)
            self.say(f"Recordings go to the library {folder}", 5000)
            if self.library_view is not None:
                self.library_view.set_folder(Path(folder))

    def toggle_recording(self) -> None:
        self._record_toggled(not (self.live is not None and self.live.recording))

    def _record_toggled(self, on: bool) -> None:
        if self.live is None:
            self.session_panel.set_recording(False)
            return
        if on and not self.live.recording:
            self.start_recording()
        elif not on and self.live.recording:
            self._finish_recording()

    def start_recording(self, metadata: dict | None = None, subject_details: dict | None = None) -> bool:
        """Start recording the live session into the library, after the checklist (and the
        person's consent to record what is not ready); ``metadata`` adds keys to the session's
        metadata (a guided clinical test's settings), ``subject_details`` fields to the subject
        record (``age_years``, ``sex``, ``weight_kg``, which the tests' norms depend on). True
        when recording."""
        if self.live is None or self.live.recording:
            return False
        checklist = recording_checklist(self.live)
        self.session_panel.show_checklist(checklist)
        not_ok = [item for item in checklist if not item.ok]
        if not_ok and not self.confirm_recording(not_ok):
            self.session_panel.set_recording(False)
            return False
        try:
            subject = dataclasses.replace(self.session_panel.subject(), **(subject_details or {}))
            condition, tags = self.session_panel.session_fields()
            path = recording_path(self.recording_folder(), subject.subject_id)
            fields = library_fields(condition, tags, path.stem.rsplit("_", 1)[-1])
            self.live.start_recording(path, subject.to_dict(), {"library": fields, **(metadata or {})})
        except (ValueError, OSError) as error:
            self.session_panel.set_recording(False)
            log.warning("cannot record: %s", error)
            hint = "\n\nChoose another library folder (File → Library Folder)." if isinstance(error, OSError) else ""
            QtWidgets.QMessageBox.warning(self, "Cannot record", f"{error}{hint}")
            return False
        self.session_panel.markers_list.clear()
        self._show_recording(True)
        self.session_panel.show_info(self.live.recording_info())
        self.statusBar().clearMessage()  # the badge and the file's name say it, uncovered
        return True

    def stop_recording(self) -> None:
        """Stop recording (the session file is written in the background; ``recording_saved``
        follows)."""
        if self.live is not None and self.live.recording:
            self._finish_recording()

    def _ask_to_record_anyway(self, items: list[CheckItem]) -> bool:
        """Ask whether to record although ``items`` of the checklist are not ok."""
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Warning, "Before recording",
                                    "Not everything is ready for a recording:", parent=self)
        box.setInformativeText("\n".join(f"• {item.title}: {item.text}" for item in items)
                               + "\n\nThe recording may not be usable for analysis. Record anyway?")
        record = box.addButton("Record Anyway", QtWidgets.QMessageBox.AcceptRole)
        box.addButton(QtWidgets.QMessageBox.Cancel)
        box.setDefaultButton(QtWidgets.QMessageBox.Cancel)
        box.exec_()
        return box.clickedButton() is record

    def _show_recording(self, on: bool) -> None:
        """The window's controls while recording (``on``) or not: the Record buttons (mode bar,
        session panel) and menu item, the mode bar's REC badge, the subject fields, Choose
        Source (no source change while recording) and the window title (the status bar's red
        indicator follows the session's ``recording``); the checklist is shown only before
        recording."""
        self.session_panel.set_recording(on)
        self.mode_bar.set_recording(on)
        self.action_record.setText("Stop &Recording" if on else "Start &Recording")
        self.action_source.setEnabled(not on)
        self.session_panel.checklist_box.setVisible(not on)
        self._update_title()

    def _finish_recording(self, wait: bool = False) -> None:
        """Stop recording at once; the session file is written in a background thread (the
        journal holds every sample until then). ``wait``: block until it is written."""
        live = self.live
        pending = live.end_recording()
        self._show_recording(False)
        message = f"Saving the session to {display_path(pending.session_path)}…"
        self.session_panel.show_info(None, message)
        self.session_panel.show_saving(True)
        self.say(message)
        self.saver.save(live, pending)
        if wait:
            self.wait_for_saving()

    def _saving_done(self) -> None:
        self.session_panel.show_saving(False)
        if self._closing_progress is not None:  # the window was closed while saving: close now
            self._closing_progress.close()
            self._closing_progress = None
            self.close()

    def wait_for_saving(self) -> None:
        """Block until every session file being written is written (their messages shown)."""
        self.saver.wait()

    @property
    def saving(self) -> bool:
        """True while a stopped recording's session file is being written."""
        return self.saver.saving

    def _recording_saved(self, live: LiveSession, result) -> None:
        live.last_recording = result
        self.last_recording = result
        samples = sum(result.samples.values())
        if result.session_path is not None:
            message = f"Saved {samples} samples to {display_path(result.session_path)}"
            if result.message:
                message += f" ({result.message})"
            if samples == 0:
                message += ": no data arrived from the source, nothing to export"
            else:
                self._unreviewed = Path(result.session_path)
                message += "; Review (Ctrl+2) shows it"
        else:
            message = result.message
            log.warning("session file not written: %s", message)
        if self.live is not None and not self.live.recording:
            self.session_panel.show_info(None, message)
        self.say(message)
        self._update_review_actions()
        if self.library_view is not None and result.session_path is not None:
            self.library_view.refresh()
        self.recording_saved.emit(result)

    def _recording_not_saved(self, message: str) -> None:
        self.session_panel.show_info(None, message)
        self.say(message)
        QtWidgets.QMessageBox.critical(self, "Recording not saved", message)

    def add_marker(self, label: str = "") -> None:
        if self.live is None:
            return
        try:
            self.live.add_marker(label or "marker")
        except OSError as error:
            QtWidgets.QMessageBox.critical(self, "Marker", str(error))

    def _height_changed(self, value: float) -> None:
        if self.live is not None and not self.live.recording:
            self.live.set_height(value)
            self.scene_view.set_figure(self.live.builder)

    # -- user actions: view ------------------------------------------------------------------
    def set_camera_preset(self, name: str) -> None:
        """Camera preset ``name`` for the live and the Review 3D views."""
        self.scene_view.set_camera_preset(name)
        if self.review.view is not None:
            self.review.view.set_camera_preset(name)
        self.camera_actions[name].setChecked(True)

    def set_display_mode(self, mode: str) -> None:
        """The figure in the world or the body frame, live and in Review."""
        if self.live is not None:
            self.live.set_display_mode(mode)
        if self.review.view is not None:
            self.review.view.set_display_mode(mode)
        self.display_actions[mode].setChecked(True)
        self.scene_view.set_camera_preset(self.scene_view.camera_preset)

    def toggle_display_mode(self) -> None:
        current = next(k for k, a in self.display_actions.items() if a.isChecked())
        self.set_display_mode("body" if current == "world" else "world")

    def _update_stage(self) -> None:
        self.scene_view.set_stage_visible(self.action_floor.isChecked(), self.action_axes.isChecked())
        if self.review.view is not None:
            self.review.view.scene_view.set_stage_visible(self.action_floor.isChecked(), self.action_axes.isChecked())

    # -- review, export, wizards, about ----------------------------------------------------------
    def ask_open_session(self) -> None:
        path, _ = QtWidgets.QFileDialog.getOpenFileName(
            self, "Open Session", str(self._folder_to_browse()),
            "Sessions and recordings to import (*.h5 *.mvnx *.sto);;MimuCap sessions (*.h5);;"
            "Xsens MVNX (*.mvnx);;OpenSense orientation tables (*.sto)")
        if path and Path(path).suffix.lower() in IMPORT_SUFFIXES:
            path = self.import_recording(path)
        if path:
            self.open_review(path)

    def import_recording(self, path: str | Path) -> Path | None:
        """Turn an Xsens MVNX file or an OpenSense table into a session file (asking where to save
        it) and return its path; ``None`` when the user cancels or the file cannot be read (said)."""
        default = self._folder_to_browse() / (Path(path).stem + ".h5")
        out, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save Imported Session As", str(default), "MimuCap sessions (*.h5)")
        if not out:
            return None
        QtWidgets.QApplication.setOverrideCursor(QtCore.Qt.WaitCursor)
        try:
            import_recording(path, out)
        except (ValueError, OSError) as error:
            QtWidgets.QApplication.restoreOverrideCursor()
            QtWidgets.QMessageBox.warning(self, "Import", f"Cannot import {Path(path).name}:\n{error}")
            return None
        QtWidgets.QApplication.restoreOverrideCursor()
        self.say(f"Imported {Path(path).name} as {out}", 5000)
        return Path(out)

    def open_review(self, path: str | Path):
        """Show session file ``path`` in the Review workspace (loaded off the GUI thread; the
        recording shown before is let go), with this window's camera, display mode, stage and
        truth; returns its :class:`~mimucap.gui.review_view.ReviewView`."""
        self._unreviewed = None  # the user chose what to review
        view = self.review.open(path)
        view.set_camera_preset(self.scene_view.camera_preset)
        view.set_display_mode(next(k for k, a in self.display_actions.items() if a.isChecked()))
        view.scene_view.set_stage_visible(self.action_floor.isChecked(), self.action_axes.isChecked())
        view.set_show_truth(self.action_truth.isChecked())
        self.show_workspace("review")
        return view

    def open_analysis(self, path: str | Path):
        """Open session file ``path`` in Review and show its analysis once it is loaded."""
        view = self.open_review(path)
        self._review_then_analyse = True
        self.show_workspace("analysis")  # says that the analysis follows the loading
        return view

    def open_library(self):
        """Show the Library workspace (its view made the first time, kept while this window lives)."""
        self.show_workspace("library")
        return self.library_view

    def _show_library(self) -> None:
        from mimucap.gui.library_view import LibraryView

        folder = self.library_folder()  # as configured, even out of reach: the view then says so
        if self.library_view is None:
            self.library_view = LibraryView(folder, open_review=self.open_review, new_session=self.new_session_for,
                                            parent=self.library_page, open_analysis=self.open_analysis)
            self.library_page.layout().addWidget(self.library_view)
        elif self.library_view.folder != folder:
            self.library_view.set_folder(folder)
        else:
            self.library_view.refresh()

    def new_session_for(self, subject_id: str, height_m: float | None, dominance: str, notes: str) -> None:
        """Make the next recording one of this subject: its record in the session panel, this window in front."""
        if self.live is not None and self.live.recording:
            QtWidgets.QMessageBox.warning(self, "Recording", "Stop the recording before starting another subject's.")
            return
        self.session_panel.set_subject(subject_id, height_m, dominance, notes)
        self.show_workspace("capture")
        self.say(f"Next recording: subject {subject_id} (● Record, or Ctrl+R)", 8000)

    def export_recording(self):
        """The export dialog of the recording in Review; with none there, the last recording is
        opened in Review and exported once loaded. Returns the dialog, or the loading view."""
        view = self.review.view
        if view is not None and view.ready:
            self.show_workspace("review")
            return view.open_export()
        if self.last_recording is None or self.last_recording.session_path is None:
            return None
        view = self.open_review(self.last_recording.session_path)
        view.export_when_loaded = True
        return view

    def open_wizard(self, name: str) -> None:
        """Open calibration wizard ``name`` on the live session (one at a time)."""
        if self.live is None:
            return
        self._close_wizard("another wizard was opened")
        wizard = wizard_class(name)(self, self.live)
        self._wizard = wizard
        wizard.show()

    def _close_wizard(self, why: str) -> None:
        """Close the open calibration wizard, if any: it reads the live session, which is
        about to change (nothing it had not applied yet is applied)."""
        wizard, self._wizard = self._wizard, None
        if wizard is not None and wizard.isVisible():
            discard = getattr(wizard, "discard_assignment", None)
            if callable(discard):  # its sensor mapping was for the session that goes away
                discard()
            wizard.close()
            self.say(f"The calibration wizard was closed: {why}.", 8000)

    def _show_closing_progress(self) -> None:
        if self._closing_progress is not None:
            return
        self._closing_progress = self.saver.closing_dialog(self)
        self._closing_progress.show()
        self.say("Writing the session file before closing…")

    def show_user_guide(self) -> None:
        """Open the user guide (shipped with the program, read offline) in its own window."""
        from mimucap.gui.user_guide import UserGuideWindow

        if self._guide is None:
            self._guide = UserGuideWindow(self)
        self._guide.show()
        self._guide.raise_()

    def show_about(self) -> None:
        QtWidgets.QMessageBox.about(self, "About MimuCap", ABOUT_TEXT.format(version=__version__))

    def save_screenshot(self, path: str | Path) -> Path:
        """Write the window (3D view included) to ``path`` as PNG."""
        return save_screenshot(self, path)

    def resizeEvent(self, event: QtGui.QResizeEvent) -> None:  # noqa: N802 (Qt API)
        """Give the docks back the size they had before the window was made too small for it, at
        most :data:`DOCK_MOST_SHARE` of the window (Qt gives all of a growing window to the 3D view and plots: a window shrunk and grown
        again left the sensor table 1.5 rows tall and the session panel cut)."""
        super().resizeEvent(event)
        for dock, (size, orientation) in self._dock_sizes.items():
            window = event.size().height() if orientation == QtCore.Qt.Vertical else event.size().width()
            self.resizeDocks([dock], [min(size, int(DOCK_MOST_SHARE * window))], orientation)

    def eventFilter(self, watched: QtCore.QObject, event: QtCore.QEvent) -> bool:  # noqa: N802 (Qt API)
        """The dock sizes to keep are the ones the user leaves after dragging a separator (mouse
        events on the window itself, between its docks)."""
        if watched is self and event.type() == QtCore.QEvent.MouseButtonRelease and self.workspace == "capture":
            QtCore.QTimer.singleShot(0, self._remember_dock_sizes)
        return super().eventFilter(watched, event)

    def _remember_dock_sizes(self) -> None:
        self._dock_sizes = {dock: ((dock.height() if orientation == QtCore.Qt.Vertical else dock.width()), orientation)
                            for dock, (_size, orientation) in self._dock_sizes.items()}

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802 (Qt API)
        if self.live is not None and self.live.recording:
            answer = QtWidgets.QMessageBox.question(
                self, "Recording in progress",
                "A recording is in progress. Stop it, save the file and quit?",
                QtWidgets.QMessageBox.Yes | QtWidgets.QMessageBox.No, QtWidgets.QMessageBox.No)
            if answer != QtWidgets.QMessageBox.Yes:
                event.ignore()
                return
            self._finish_recording()
        if self.saving:
            # The file is written in its thread while the window keeps running: it closes
            # when the writing is done (:meth:`_saving_done`), with a progress dialog until then.
            event.ignore()
            self._show_closing_progress()
            return
        if self._warm_up is not None and self._warm_up.isRunning():
            self._warm_up.succeeded.disconnect()
            self._warm_up.failed.disconnect()
            self._preparation.cancel()  # stops the compiling child; what it cached is kept
            self._warm_up.wait()
        self._pump.stop()
        self.scene_view.shutdown()
        self._stop_live()
        self.analysis.clear(wait_ms=30000)
        self.review.close_recording(wait_ms=10000)
        if self.library_view is not None:
            self.library_view.shutdown()
        super().closeEvent(event)
