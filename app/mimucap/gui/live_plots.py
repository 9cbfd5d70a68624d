"""Scrolling plots (pyqtgraph) of the selected sensor's accelerometer, gyroscope and magnetometer
and of the selected joint's three angles.

The data comes from a *plot source* (the live session, or the review player), which offers
``sensor_ids``, ``joint_names``, ``joint_columns(joint)``, ``series(sensor_id, window_s)`` →
``(t_s, acc, gyr, mag_uT)`` and ``joint_series(joint, window_s)`` → ``(t_s, angles_deg (N,3))``,
and ``cursor_s`` (the time the 3D view shows). Curves are created once; one ``QTimer``
(:data:`REFRESH_HZ`) calls ``setData`` on them; nothing is plotted while paused.
"""

from __future__ import annotations

import time

import numpy as np
import pyqtgraph as pg
from PyQt5 import QtCore, QtWidgets

#: Plot refresh rate (Hz).
REFRESH_HZ = 30.0
#: Selectable scrolling window lengths (s).
WINDOW_CHOICES_S = (5.0, 10.0, 20.0, 30.0)
AXIS_PENS = ("#d62728", "#2ca02c", "#1f77b4")
AXIS_NAMES = ("x", "y", "z")
#: (key, title, unit, smallest y range shown so that noise is not blown up to full height).
PLOT_SPECS = (
    ("acc", "Accelerometer", "m/s²", 2.0),
    ("gyr", "Gyroscope", "rad/s", 0.5),
    ("mag", "Magnetometer", "µT", 10.0),
    ("angles", "Joint angles", "deg", 10.0),
)

pg.setConfigOptions(antialias=False, background="w", foreground="k")


class LivePlots(QtWidgets.QWidget):
    """Four stacked plots with sensor/joint/window selectors and a pause button.

    Signals:
        refreshed(float): after each refresh that drew new data (``time.perf_counter()``).
    """

    refreshed = QtCore.pyqtSignal(float)

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("livePlots")
        self.source = None
        self.sensor_combo = QtWidgets.QComboBox(self)
        self.sensor_combo.setObjectName("plotSensor")
        self.joint_combo = QtWidgets.QComboBox(self)
        self.joint_combo.setObjectName("plotJoint")
        self.window_combo = QtWidgets.QComboBox(self)
        self.window_combo.setObjectName("plotWindow")
        for seconds in WINDOW_CHOICES_S:
            self.window_combo.addItem(f"{seconds:.0f} s", seconds)
        self.window_combo.setCurrentIndex(1)
        self.pause_button = QtWidgets.QPushButton("Pause", self)
        self.pause_button.setObjectName("plotPause")
        self.pause_button.setCheckable(True)
        self.pause_button.setShortcut("Space")
        self.pause_button.toggled.connect(self._paused_changed)

        bar = QtWidgets.QHBoxLayout()
        for text, widget in (("Sensor", self.sensor_combo), ("Joint", self.joint_combo), ("Window", self.window_combo)):
            label = QtWidgets.QLabel(text, self)
            label.setBuddy(widget)
            bar.addWidget(label)
            bar.addWidget(widget)
        bar.addStretch(1)
        bar.addWidget(self.pause_button)

        self.layout_widget = pg.GraphicsLayoutWidget(self)
        self.plots: dict[str, pg.PlotItem] = {}
        self.curves: dict[str, list[pg.PlotDataItem]] = {}
        self.cursors: list[pg.InfiniteLine] = []
        for row, (key, title, unit, min_range) in enumerate(PLOT_SPECS):
            plot = self.layout_widget.addPlot(row=row, col=0)
            plot.setTitle(title, size="9pt")
            left = plot.getAxis("left")
            left.enableAutoSIPrefix(False)
            left.setLabel(unit)
            left.setWidth(48)
            plot.getAxis("bottom").enableAutoSIPrefix(False)
            if row == len(PLOT_SPECS) - 1:
                plot.setLabel("bottom", "time (s)")
            else:
                # The plots share one x range: one time axis (the last) is enough, and a
                # scrolling axis is the costliest item to repaint (bench/bench_gui.py).
                plot.hideAxis("bottom")
            plot.getViewBox().setLimits(minYRange=min_range)
            plot.showGrid(x=True, y=True, alpha=0.25)
            plot.setClipToView(True)
            plot.setDownsampling(auto=True, mode="peak")
            plot.addLegend(offset=(-5, 5), labelTextSize="8pt")
            curves = []
            for axis in range(3):
                curve = plot.plot(pen=pg.mkPen(AXIS_PENS[axis], width=1), name=AXIS_NAMES[axis])
                curves.append(curve)
            cursor = pg.InfiniteLine(angle=90, movable=False, pen=pg.mkPen("#444", width=1, style=QtCore.Qt.DashLine))
            plot.addItem(cursor, ignoreBounds=True)
            self.cursors.append(cursor)
            self.plots[key] = plot
            self.curves[key] = curves
        for key in ("gyr", "mag", "angles"):
            self.plots[key].setXLink(self.plots["acc"])

        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(bar)
        layout.addWidget(self.layout_widget, 1)

        self.joint_combo.currentIndexChanged.connect(self._joint_changed)
        self._timer = QtCore.QTimer(self)
        self._timer.setInterval(int(round(1000.0 / REFRESH_HZ)))
        self._timer.timeout.connect(self.refresh)
        self.refresh_count = 0
        self._titled_sensor = ""
        self.refresh_times: list[float] = []

    # -- wiring ------------------------------------------------------------------------------
    def set_source(self, source) -> None:
        """Show data of ``source`` (a live session or a review player)."""
        self.source = source
        self.update_choices()

    def update_choices(self) -> None:
        """Refresh the sensor and joint lists from the source (keeps the selection)."""
        if self.source is None:
            return
        current_sensor = self.sensor_combo.currentText()
        sensors = list(self.source.sensor_ids)
        if [self.sensor_combo.itemText(i) for i in range(self.sensor_combo.count())] != sensors:
            self.sensor_combo.blockSignals(True)
            self.sensor_combo.clear()
            self.sensor_combo.addItems(sensors)
            if current_sensor in sensors:
                self.sensor_combo.setCurrentText(current_sensor)
            self.sensor_combo.blockSignals(False)
        joints = list(self.source.joint_names)
        if [self.joint_combo.itemText(i) for i in range(self.joint_combo.count())] != joints:
            current_joint = self.joint_combo.currentText()
            self.joint_combo.blockSignals(True)
            self.joint_combo.clear()
            self.joint_combo.addItems(joints)
            if current_joint in joints:
                self.joint_combo.setCurrentText(current_joint)
            elif "knee_r" in joints:
                self.joint_combo.setCurrentText("knee_r")
            self.joint_combo.blockSignals(False)
            self._joint_changed()

    def _joint_changed(self) -> None:
        joint = self.joint_combo.currentText()
        plot = self.plots["angles"]
        if not joint or self.source is None:
            return
        columns = self.source.joint_columns(joint)
        plot.setTitle(f"Joint angles: {joint}", size="9pt")
        legend = plot.legend
        for curve, column in zip(self.curves["angles"], columns):
            legend.removeItem(curve)
            label = column[len(joint) + 1:] if column.startswith(joint + "_") else column
            curve.opts["name"] = label.replace("_deg", " (deg)").replace("_", " ")
            legend.addItem(curve, curve.opts["name"])

    def start(self) -> None:
        self._timer.start()

    def stop(self) -> None:
        self._timer.stop()

    @property
    def paused(self) -> bool:
        return self.pause_button.isChecked()

    def _paused_changed(self, paused: bool) -> None:
        self.pause_button.setText("Resume" if paused else "Pause")

    @property
    def window_s(self) -> float:
        return float(self.window_combo.currentData())

    # -- drawing -----------------------------------------------------------------------------
    def refresh(self) -> None:
        """Pull the newest window from the source into the curves (skipped while paused)."""
        if self.paused or self.source is None:
            return
        if self.sensor_combo.count() == 0 or self.joint_combo.count() == 0:
            self.update_choices()
        window = self.window_s
        sensor = self.sensor_combo.currentText()
        drew = False
        if sensor and sensor != self._titled_sensor:
            for key, title, _unit, _r in PLOT_SPECS[:3]:
                self.plots[key].setTitle(f"{title}: {sensor}", size="9pt")
            self._titled_sensor = sensor
        if sensor:
            t, acc, gyr, mag = self.source.series(sensor, window)
            for key, values in (("acc", acc), ("gyr", gyr), ("mag", mag)):
                for axis, curve in enumerate(self.curves[key]):
                    curve.setData(t, values[:, axis], connect="finite")
            drew = drew or len(t) > 0
        joint = self.joint_combo.currentText()
        if joint:
            t, angles = self.source.joint_series(joint, window)
            for axis, curve in enumerate(self.curves["angles"]):
                curve.setData(t, angles[:, axis], connect="finite")
            drew = drew or len(t) > 0
        cursor = self.source.cursor_s
        if np.isfinite(cursor):
            for line in self.cursors:
                line.setValue(cursor)
            self.plots["acc"].setXRange(cursor - window, cursor, padding=0)
        if drew:
            self.refresh_count += 1
            now = time.perf_counter()
            self.refresh_times.append(now)
            if len(self.refresh_times) > 600:
                del self.refresh_times[:300]
            self.refreshed.emit(now)

    def curve_data(self, key: str, axis: int) -> tuple[np.ndarray, np.ndarray]:
        """What curve ``axis`` of plot ``key`` (``acc``, ``gyr``, ``mag``, ``angles``) shows."""
        x, y = self.curves[key][axis].getData()
        return (np.zeros(0), np.zeros(0)) if x is None else (x, y)
