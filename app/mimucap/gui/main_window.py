"""The main window: the 3D skeleton view, menus and status bar around a live pipeline.

The window holds no data: it shows what its :class:`~mimucap.session.live.LivePipeline`
has, and forwards what the user asks. One ``QTimer`` pumps the pipeline
(:data:`PUMP_INTERVAL_MS`); the 3D view renders from its own timer, once per frame.
"""

from __future__ import annotations

import logging
from pathlib import Path

from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap import __version__
from mimucap.gui.capture import save_window_png
from mimucap.gui.scene.view import SceneView
from mimucap.session.camera import CAMERA_PRESETS
from mimucap.session.figure import DISPLAY_MODES
from mimucap.session.live import LivePipeline

log = logging.getLogger(__name__)

#: How often the live pipeline is pumped (ms): 100 Hz, so a sample waits at most 10 ms.
PUMP_INTERVAL_MS = 10
#: How often the status bar is refreshed (ms).
STATUS_INTERVAL_MS = 500

ABOUT_TEXT = (
    "<h3>MimuCap {version}</h3>"
    "<p>Human motion capture with magnetic-inertial sensors: live skeleton, joint angles, "
    "recording, review and export.</p>"
    "<p>Built with PyQt5, VTK, pyqtgraph, NumPy and SciPy.</p>"
)


class MainWindow(QtWidgets.QMainWindow):
    """MimuCap's main window.

    Args:
        pipeline: the live pipeline to show.
        source_label: how the status bar names the source (e.g. ``"simulated:demo"``).
    """

    def __init__(self, pipeline: LivePipeline, source_label: str = "simulated") -> None:
        super().__init__()
        self.setObjectName("mainWindow")
        self.setWindowTitle("MimuCap")
        self.resize(1280, 800)
        self.pipeline = pipeline
        self.source_label = source_label

        self.scene_view = SceneView(self)
        self.scene_view.set_figure(pipeline.builder)
        self.scene_view.set_frame_provider(pipeline.frame)
        self.scene_view.set_tint_provider(pipeline.segment_states)
        self.setCentralWidget(self.scene_view)

        self._build_menus()
        self._build_status_bar()

        self._pump = QtCore.QTimer(self)
        self._pump.setTimerType(QtCore.Qt.PreciseTimer)
        self._pump.setInterval(PUMP_INTERVAL_MS)
        self._pump.timeout.connect(self._pump_pipeline)
        self._status_timer = QtCore.QTimer(self)
        self._status_timer.setInterval(STATUS_INTERVAL_MS)
        self._status_timer.timeout.connect(self.refresh_status)
        self._closed = False

    # -- construction ------------------------------------------------------------------------
    def _build_menus(self) -> None:
        bar = self.menuBar()
        file_menu = bar.addMenu("&File")
        self.action_save_screenshot = file_menu.addAction("Save &Screenshot…", self._ask_screenshot)
        self.action_save_screenshot.setShortcut(QtGui.QKeySequence("Ctrl+Shift+S"))
        file_menu.addSeparator()
        self.action_quit = file_menu.addAction("&Quit", self.close)
        self.action_quit.setShortcut(QtGui.QKeySequence.Quit)

        view_menu = bar.addMenu("&View")
        camera_menu = view_menu.addMenu("&Camera")
        self.camera_group = QtWidgets.QActionGroup(self)
        self.camera_actions: dict[str, QtWidgets.QAction] = {}
        for index, name in enumerate(CAMERA_PRESETS, start=1):
            action = camera_menu.addAction(name.capitalize())
            action.setCheckable(True)
            action.setShortcut(QtGui.QKeySequence(f"Ctrl+{index}"))
            action.triggered.connect(lambda _checked, n=name: self.set_camera_preset(n))
            self.camera_group.addAction(action)
            self.camera_actions[name] = action
        self.camera_actions[self.scene_view.camera_preset].setChecked(True)

        display_menu = view_menu.addMenu("&Display Mode")
        self.display_group = QtWidgets.QActionGroup(self)
        self.display_actions: dict[str, QtWidgets.QAction] = {}
        for name in DISPLAY_MODES:
            action = display_menu.addAction(f"{name.capitalize()} Mode")
            action.setCheckable(True)
            action.triggered.connect(lambda _checked, n=name: self.set_display_mode(n))
            self.display_group.addAction(action)
            self.display_actions[name] = action
        self.display_actions[self.pipeline.display_mode].setChecked(True)
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

        help_menu = bar.addMenu("&Help")
        self.action_about = help_menu.addAction("&About MimuCap", self.show_about)

    def _build_status_bar(self) -> None:
        status = self.statusBar()
        self.source_status = QtWidgets.QLabel(self)
        self.pose_status = QtWidgets.QLabel(self)
        self.time_status = QtWidgets.QLabel(self)
        self.fps_status = QtWidgets.QLabel(self)
        for label in (self.source_status, self.pose_status, self.time_status, self.fps_status):
            status.addPermanentWidget(label)
        self.refresh_status()

    # -- running -----------------------------------------------------------------------------
    def start(self) -> None:
        """Start pumping the pipeline and rendering (call after ``show()``)."""
        self._pump.start()
        self._status_timer.start()
        self.scene_view.start()

    def _pump_pipeline(self) -> None:
        try:
            self.pipeline.step()
        except Exception as error:  # shown, logged, and the pump stops: no endless error loop
            log.exception("live pipeline failed")
            self._pump.stop()
            self.statusBar().showMessage(f"Live data stopped: {error}. Restart the source to continue.")

    def refresh_status(self) -> None:
        """Update the permanent status-bar fields from the pipeline and the view."""
        self.source_status.setText(f"Source: {self.source_label}")
        self.pose_status.setText(f"Pose: {self.pipeline.pose_source}")
        t = self.pipeline.time_s
        self.time_status.setText("t = –" if t != t else f"t = {t:7.2f} s")
        times = self.scene_view.render_times[-61:]
        if len(times) >= 2 and times[-1] > times[0]:
            self.fps_status.setText(f"{(len(times) - 1) / (times[-1] - times[0]):4.0f} fps")
        else:
            self.fps_status.setText("– fps")

    # -- user actions --------------------------------------------------------------------------
    def set_camera_preset(self, name: str) -> None:
        self.scene_view.set_camera_preset(name)
        self.camera_actions[name].setChecked(True)

    def set_display_mode(self, mode: str) -> None:
        self.pipeline.set_display_mode(mode)
        self.display_actions[mode].setChecked(True)
        self.scene_view.set_camera_preset(self.scene_view.camera_preset)

    def toggle_display_mode(self) -> None:
        self.set_display_mode("body" if self.pipeline.display_mode == "world" else "world")

    def _update_stage(self) -> None:
        self.scene_view.set_stage_visible(self.action_floor.isChecked(), self.action_axes.isChecked())

    def show_about(self) -> None:
        QtWidgets.QMessageBox.about(self, "About MimuCap", ABOUT_TEXT.format(version=__version__))

    def _ask_screenshot(self) -> None:
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save Screenshot", "mimucap.png", "PNG images (*.png)")
        if path:
            self.save_screenshot(path)

    def save_screenshot(self, path: str | Path) -> Path:
        """Write the window (3D view included) to ``path`` as PNG."""
        written = save_window_png(self, path)
        self.statusBar().showMessage(f"Screenshot saved to {written}", 5000)
        return written

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802 (Qt API)
        self._pump.stop()
        self._status_timer.stop()
        self.scene_view.shutdown()
        self._closed = True
        super().closeEvent(event)
