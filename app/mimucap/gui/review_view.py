"""The review of one recorded session (the page of the main window's Review workspace): its
skeleton and plots following a play head, a timeline with the markers, play/pause, speed, the
result shown, and the export dialog. The spans where a joint's angles are doubtful are shaded
on the timeline and in the joint plots, and the review's status line says which joints are
doubtful at the play head, and why.

The session is loaded and its poses computed off the GUI thread
(:func:`mimucap.session.recorded.review.load_review` in a :class:`BackgroundTask`), with progress. The
play timer is the review's clock: it moves the player's play head, and the 3D view and the
plots follow the player's events (``frame``, ``data``).
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

import pyqtgraph as pg
from PyQt5 import QtCore, QtWidgets

from mimucap.core.analysis.rom import marker_words
from mimucap.gui.background_task import BackgroundTask
from mimucap.gui.export_dialog import ExportDialog
from mimucap.gui.live_plots import DOUBT_BRUSH, LivePlots
from mimucap.gui.scene.view import SceneView
from mimucap.gui.session_panel import display_path
from mimucap.gui.status_line import page_layout, progress_bar, status_line
from mimucap.core.pipeline.settings import RESULT_LIVE, RESULT_REPROCESSED, RESULT_TITLES
from mimucap.session.recorded.analysis import NEEDS_BODY_CALIBRATION
from mimucap.session.angle_accuracy import accuracy_phrase
from mimucap.session.recorded.review import SPEEDS, ReviewData, ReviewPlayer, load_review

log = logging.getLogger(__name__)

#: Play timer interval (ms).
PLAY_INTERVAL_MS = 33
#: Slider steps per second of recording.
SLIDER_STEPS_PER_S = 100
#: How near (pixels) a click on the timeline must be to a marker to jump to it.
MARKER_CLICK_PX = 6.0
#: Heights of successive marker labels on the timeline (fraction of its height): neighbours
#: alternate, so that two close markers' labels do not overlap.
MARKER_LABEL_HEIGHTS = (0.75, 0.3)
#: What the arrow keys (a tenth of a second) and Page Up/Down (a second) move the slider by (s).
SLIDER_ARROW_STEP_S, SLIDER_PAGE_STEP_S = 0.1, 1.0


class _JumpToClickStyle(QtWidgets.QProxyStyle):
    """The application's style, except that a left click on a slider's groove puts the handle
    there (instead of moving it one page step towards the click, which barely moves a long
    recording's play head)."""

    def styleHint(self, hint, option=None, widget=None, return_data=None):  # noqa: N802 (Qt API)
        if hint == QtWidgets.QStyle.SH_Slider_AbsoluteSetButtons:
            return int(QtCore.Qt.LeftButton)
        return super().styleHint(hint, option, widget, return_data)


class ReviewView(QtWidgets.QWidget):
    """Review of session file ``path``; call :meth:`load` once shown.

    Signals:
        loaded(): the session (or another result of it) is shown.
        failed(str): the session cannot be reviewed (why); the view has nothing to show.
        busy(): the view is loading another result (nothing to export until ``loaded``).
    """

    loaded = QtCore.pyqtSignal()
    failed = QtCore.pyqtSignal(str)
    busy = QtCore.pyqtSignal()

    def __init__(self, path: str | Path, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.path = Path(path)
        self.setObjectName("reviewView")
        self.player: ReviewPlayer | None = None
        self.export_dialog: ExportDialog | None = None
        self._display_mode = "world"
        self._show_truth = False
        self._cursor_to_keep: float | None = None  # the play head kept across a change of result
        self.export_when_loaded = False
        self.load_error: str | None = None
        self._task: BackgroundTask | None = None
        self._last_tick = time.perf_counter()

        self.scene_view = SceneView(self)
        self.plots = LivePlots(self)
        splitter = QtWidgets.QSplitter(QtCore.Qt.Horizontal, self)
        splitter.addWidget(self.scene_view)
        splitter.addWidget(self.plots)
        splitter.setSizes([760, 520])

        self.play_button = QtWidgets.QPushButton("▶ Play", self)
        self.play_button.setObjectName("playButton")
        self.play_button.setCheckable(True)
        self.play_button.toggled.connect(self._play_toggled)
        self.slider = QtWidgets.QSlider(QtCore.Qt.Horizontal, self)
        self.slider.setObjectName("timelineSlider")
        self._slider_style = _JumpToClickStyle()  # kept: the slider does not own its style
        self.slider.setStyle(self._slider_style)
        self.slider.setSingleStep(int(round(SLIDER_ARROW_STEP_S * SLIDER_STEPS_PER_S)))
        self.slider.setPageStep(int(round(SLIDER_PAGE_STEP_S * SLIDER_STEPS_PER_S)))
        self.slider.valueChanged.connect(self._slider_moved)
        self.time_label = QtWidgets.QLabel("–", self)
        self.time_label.setMinimumWidth(150)
        self.speed_combo = QtWidgets.QComboBox(self)
        for speed in SPEEDS:
            self.speed_combo.addItem(f"{speed:g}×", speed)
        self.speed_combo.setCurrentIndex(SPEEDS.index(1.0))
        self.speed_combo.currentIndexChanged.connect(self._speed_changed)
        self.result_combo = QtWidgets.QComboBox(self)
        self.result_combo.setObjectName("resultChoice")
        for result in (RESULT_REPROCESSED, RESULT_LIVE):
            self.result_combo.addItem(RESULT_TITLES[result], result)
        self.result_combo.setToolTip("Reprocessed: the orientation filter smoothed with past and future data "
                                     "(the default for export).\nAs seen live: the forward filter, as the live "
                                     "view showed it.")
        self.result_combo.currentIndexChanged.connect(lambda _i: self.set_result(self.result_combo.currentData()))
        self._marker_lines: list = []
        self.markers_list = QtWidgets.QListWidget(self)
        self.markers_list.setObjectName("reviewMarkers")
        self.markers_list.setMaximumWidth(260)
        # As tall as the timeline and its controls beside it, never taller (it scrolls).
        self.markers_list.setSizePolicy(QtWidgets.QSizePolicy.Preferred, QtWidgets.QSizePolicy.Ignored)
        self.markers_list.itemActivated.connect(lambda item: self.seek_marker(self.markers_list.row(item)))
        self.markers_list.itemClicked.connect(lambda item: self.seek_marker(self.markers_list.row(item)))
        self.timeline = pg.PlotWidget(self)
        self.timeline.setObjectName("timelinePlot")
        self.timeline.setMaximumHeight(80)
        self.timeline.hideAxis("left")
        self.timeline.setMouseEnabled(x=False, y=False)
        self.timeline.setMenuEnabled(False)
        self.timeline.hideButtons()  # no auto-range button: the timeline always shows the whole session
        self.timeline.scene().sigMouseClicked.connect(self._timeline_clicked)
        self.timeline.setLabel("bottom", "time (s)")
        self.timeline_cursor = pg.InfiniteLine(angle=90, movable=True, pen=pg.mkPen("#c0392b", width=2))
        self.timeline_cursor.sigPositionChanged.connect(lambda line: self.seek(line.value()))
        self.timeline.addItem(self.timeline_cursor)

        controls = QtWidgets.QHBoxLayout()
        controls.addWidget(self.play_button)
        controls.addWidget(self.slider, 1)
        controls.addWidget(self.time_label)
        controls.addWidget(QtWidgets.QLabel("Speed"))
        controls.addWidget(self.speed_combo)
        controls.addWidget(QtWidgets.QLabel("Result"))
        controls.addWidget(self.result_combo)
        timeline_box = QtWidgets.QVBoxLayout()
        timeline_box.addWidget(self.timeline)
        timeline_box.addLayout(controls)
        bottom = QtWidgets.QHBoxLayout()
        bottom.addLayout(timeline_box, 1)
        bottom.addWidget(self.markers_list)
        layout = page_layout(self)
        layout.addWidget(splitter, 1)
        layout.addLayout(bottom)
        self._status = status_line(self, layout)
        self.progress = progress_bar(self._status)
        self.pose_status = QtWidgets.QLabel(self)
        self.statusBar().addPermanentWidget(self.pose_status)
        self.doubt_status = QtWidgets.QLabel(self)
        self.doubt_status.setObjectName("doubtStatus")
        self.doubt_status.setStyleSheet("QLabel { color: #c05800; }")
        self.doubt_status.setWordWrap(True)
        self.doubt_status.setVisible(False)
        self.statusBar().addWidget(self.doubt_status, 1)
        self._doubt_regions: list = []
        self._timer = QtCore.QTimer(self)
        self._timer.setInterval(PLAY_INTERVAL_MS)
        self._timer.timeout.connect(self._tick)

    def statusBar(self) -> QtWidgets.QStatusBar:  # noqa: N802 (as QMainWindow's)
        """The review's status line (the file, the pose source, doubts at the play head)."""
        return self._status

    # -- loading -----------------------------------------------------------------------------
    def load(self) -> None:
        """Load the session in the background; :attr:`loaded` is emitted when it is shown."""
        self.statusBar().showMessage(f"Opening {display_path(self.path)}…")
        result = self.result_combo.currentData()
        if self._task is not None:
            self._task.let_go()  # the result asked before is not wanted any more
        self._task = BackgroundTask(lambda progress: load_review(self.path, progress, result=result), self)
        self._task.progress.connect(lambda f: self.progress.setValue(int(round(100 * f))))
        self._task.succeeded.connect(self._loaded)
        self._task.failed.connect(self._load_failed)
        self._task.start()

    @property
    def result(self) -> str:
        """Which result the review shows (:data:`~mimucap.core.pipeline.settings.RESULTS`)."""
        return self.result_combo.currentData()

    def set_result(self, result: str) -> None:
        """Show ``result`` (as seen live, or reprocessed): the session is processed again."""
        index = self.result_combo.findData(result)
        if index < 0:
            raise ValueError(f"unknown result {result!r}")
        if index != self.result_combo.currentIndex():
            self.result_combo.setCurrentIndex(index)  # comes back here
            return
        if self.player is None or self.player.data.result == result:
            return
        self._cursor_to_keep = self.player.cursor_s
        self._timer.stop()
        self.progress.setValue(0)
        self.progress.show()
        self.busy.emit()
        self.load()

    def _loaded(self, data: ReviewData) -> None:
        keep, self._cursor_to_keep = self._cursor_to_keep, None
        for line in self._marker_lines + self._doubt_regions:
            self.timeline.removeItem(line)
        self._marker_lines.clear()
        self._doubt_regions.clear()
        self.markers_list.clear()
        self.player = ReviewPlayer(data)
        self.progress.hide()
        self.scene_view.set_figure(self.player.builder)
        self.scene_view.set_model(self.player)
        self.player.set_display_mode(self._display_mode)
        self.set_show_truth(self._show_truth)
        self.scene_view.set_tints({s: "ok" for s in data.model.segment_names})
        self.plots.joint_angles_refused = "" if data.body_calibration is not None else NEEDS_BODY_CALIBRATION
        self.plots.set_source(self.player)
        self.slider.setRange(int(round(data.start_s * SLIDER_STEPS_PER_S)), int(round(data.end_s * SLIDER_STEPS_PER_S)))
        self.timeline.setXRange(data.start_s, data.end_s, padding=0.01)
        self.timeline.setYRange(0, 1)
        for start, end in self.player.doubtful_spans():
            region = pg.LinearRegionItem((start, end), movable=False, brush=pg.mkBrush(*DOUBT_BRUSH), pen=pg.mkPen(None))
            region.setZValue(-10)
            self.timeline.addItem(region)
            self._doubt_regions.append(region)
        for index, marker in enumerate(data.markers):
            line = pg.InfiniteLine(marker.t_s, angle=90, movable=False, pen=pg.mkPen("#2c3e50", width=1),
                                   label=marker_words(marker.label),
                                   labelOpts={"position": MARKER_LABEL_HEIGHTS[index % len(MARKER_LABEL_HEIGHTS)],
                                              "color": "#2c3e50"})
            self.timeline.addItem(line)
            self._marker_lines.append(line)
            self.markers_list.addItem(f"{marker.t_s:8.2f} s  {marker_words(marker.label)}")
        self.pose_status.setText(f"Pose: {data.pose_source}; {RESULT_TITLES[data.result].lower()}"
                                 + (accuracy_phrase(data.truth_errors()) if data.body_calibration is not None else ""))
        message = (f"{display_path(self.path)}: {data.end_s - data.start_s:.1f} s, {len(data.session.sensors)} sensors, "
                   f"{len(data.markers)} markers")
        if data.missing:
            message += " — " + "; ".join(data.missing)
        self.statusBar().showMessage(message, 15000)
        self.seek(data.start_s if keep is None else keep)
        self.scene_view.start()
        self._timer.start()
        self.loaded.emit()
        if self.export_when_loaded:
            self.export_when_loaded = False  # once: another result loaded later is not a request to export
            self.open_export()
        elif self.export_dialog is not None and self.export_dialog.isVisible():
            self.export_dialog.set_data(data)  # the result switched: its choices stay

    def _load_failed(self, message: str) -> None:
        """The file cannot be reviewed: ``failed`` says why (the workspace tells the user and
        lets the view go: a review without a session has nothing to play)."""
        self.load_error = message
        self.progress.hide()
        log.warning("cannot review %s: %s", self.path, message)
        self.failed.emit(message)

    # -- play head ---------------------------------------------------------------------------
    def seek(self, t_s: float) -> None:
        if self.player is None:
            return
        t = self.player.seek(t_s)
        self._show_cursor(t)

    def _timeline_clicked(self, event) -> None:
        """A click on the timeline jumps there; on (or within a few pixels of) a marker, to the marker."""
        if self.player is None or event.button() != QtCore.Qt.LeftButton:
            return
        view = self.timeline.getPlotItem().vb
        if not view.sceneBoundingRect().contains(event.scenePos()):
            return
        t = view.mapSceneToView(event.scenePos()).x()
        pixel_s = view.viewPixelSize()[0]
        markers = self.player.data.markers
        if markers:
            index = min(range(len(markers)), key=lambda k: abs(markers[k].t_s - t))
            if abs(markers[index].t_s - t) <= MARKER_CLICK_PX * pixel_s:
                self.seek_marker(index)
                return
        self.seek(t)

    def seek_marker(self, index: int) -> None:
        if self.player is None:
            return
        self._show_cursor(self.player.seek_marker(index))

    def _show_cursor(self, t: float) -> None:
        for widget, value in ((self.slider, int(round(t * SLIDER_STEPS_PER_S))), (self.timeline_cursor, t)):
            widget.blockSignals(True)
            widget.setValue(value)
            widget.blockSignals(False)
        self.time_label.setText(f"{t:7.2f} / {self.player.data.end_s:.2f} s")
        here = self.player.doubt_here()
        text = f"Doubtful here — {here}" if here else ""
        if self.doubt_status.text() != text:
            self.doubt_status.setText(text)
            self.doubt_status.setToolTip(text)
            if text:
                # A message over the status line hides its doubts (Qt shows the message over
                # them): the doubt at the play head is what the line must say.
                self.statusBar().clearMessage()
            self.doubt_status.setVisible(bool(text))

    def _slider_moved(self, value: int) -> None:
        self.seek(value / SLIDER_STEPS_PER_S)

    def _play_toggled(self, on: bool) -> None:
        if self.player is None:
            return
        if on:
            self.player.play()
            self._last_tick = time.perf_counter()
        else:
            self.player.pause()
        self.play_button.setText("❚❚ Pause" if on else "▶ Play")

    def _speed_changed(self) -> None:
        if self.player is not None:
            self.player.set_speed(float(self.speed_combo.currentData()))

    def _tick(self) -> None:
        now = time.perf_counter()
        elapsed, self._last_tick = now - self._last_tick, now
        if self.player is None or not self.player.playing:
            if self.play_button.isChecked() and self.player is not None:
                self.play_button.setChecked(False)
            return
        self._show_cursor(self.player.advance(elapsed))

    def set_camera_preset(self, name: str) -> None:
        """Move the 3D view's camera to preset ``name`` (one of ``CAMERA_PRESETS``)."""
        self.scene_view.set_camera_preset(name)

    @property
    def has_truth(self) -> bool:
        """Whether the recording holds the simulator's truth (a simulated session)."""
        return self.player is not None and self.player.data.truth is not None

    def set_show_truth(self, on: bool) -> None:
        """Show the simulator's truth as a ghost figure and dashed curves when ``on`` and the
        recording has it."""
        self._show_truth = on
        self.scene_view.set_ghost_visible(on)
        self.plots.set_show_truth(on)

    def set_display_mode(self, mode: str) -> None:
        """Show the figure in the world or in the body frame (``DISPLAY_MODES``)."""
        self._display_mode = mode
        if self.player is not None:
            self.player.set_display_mode(mode)

    @property
    def ready(self) -> bool:
        """Whether a result of the session is shown (and none other is being loaded)."""
        return self.player is not None and not (self._task is not None and self._task.isRunning())

    # -- export, shut down ------------------------------------------------------------
    def open_export(self) -> ExportDialog | None:
        if self.player is None:
            return None
        self.export_dialog = ExportDialog(self, self.player.data)
        self.export_dialog.show()
        return self.export_dialog

    def shutdown(self, wait_ms: int = 0) -> None:
        """Let the session go: the loader's result is no longer shown (given ``wait_ms`` to
        finish: the program closing), a running export is finished, the clock and the 3D view
        stop."""
        if self._task is not None:
            self._task.let_go(wait_ms)  # a closed review shows nothing the loader finds later
        if self.export_dialog is not None and self.export_dialog.busy:
            self.export_dialog._task.wait(30000)
        if self.export_dialog is not None:
            self.export_dialog.close()
        self._timer.stop()
        self.plots.set_source(None)
        self.scene_view.shutdown()
