"""Scrolling plots (pyqtgraph) of the selected sensor's accelerometer, gyroscope and magnetometer
and of the selected joints' three angles.

The data comes from a *plot source* (the live session, or the review player), which offers
``sensor_ids``, ``joint_names``, ``joint_columns(joint)``, ``series(sensor_id, window_s)`` →
``(t_s, acc, gyr, mag_uT)`` and ``joint_series(joint, window_s)`` → ``(t_s, angles_deg (N,3))``,
``cursor_s`` (the time the 3D view shows), when it knows them, ``sensor_segments`` (sensor
id → segment), ``doubt_spans(joint, window_s)`` → ``[(start_s, end_s), …]`` where the joint's
angles are doubtful (shaded in its plot; :mod:`mimucap.core.pipeline.doubt_reasons`), and ``events`` (:class:`~mimucap.session.events.EmitterGroup`): ``data`` (new
data, or the play head moved) and, when the choices can change, ``sensors`` and
``assignment``. Sensors, joints and angle axes are shown by their clinical names
(:mod:`mimucap.core.clinical_names`: "Pelvis sensor (S01)", "Right knee", "flexion").

The plots subscribe to the source's events (:meth:`LivePlots.set_source`) and never ask it on a
timer: a ``data`` event marks them out of date and asks for one redraw, which a single-shot
timer runs about :data:`REFRESH_HZ` times a second (the events of the 62.5 Hz pipeline in
between are coalesced; a screen shows no more). Curves are created once per plot and only get
``setData``; nothing is plotted while paused (the events are ignored; the newest window is drawn
on resuming).

Live, the time axis is fixed and reads seconds before the pose shown (``-10 … 0``), so the
axes and grid never need redrawing; in review it reads session time around the play head.
The vertical ranges follow the data with hysteresis (:class:`SteadyRange`) instead of
pyqtgraph's auto-range, which re-laid out every axis on every refresh (``bench/bench_gui.py``).
"""

from __future__ import annotations

import time

import numpy as np
import pyqtgraph as pg
from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap.core.clinical_names import axis_short_name, joint_name, segment_name, sensor_name, split_angle_column
from mimucap.core.pipeline.recording import POSE_BODY_CALIBRATION
from mimucap.gui.scrolling import scrolling
from mimucap.gui.throttle import RepaintThrottle
from mimucap.session.views.plot_scaling import MAX_POINTS, SteadyRange, column_bounds, nice_ticks, peak_decimate

#: Plot refreshes a second (Hz): at most this, less :data:`REFRESH_SLACK`.
REFRESH_HZ = 30.0
#: Share of the refresh interval the schedule may run ahead (:class:`~mimucap.gui.throttle.RepaintThrottle`):
#: the data events arrive on the 16 ms pump and Qt's timers round to milliseconds.
REFRESH_SLACK = 0.05
#: Selectable scrolling window lengths (s).
WINDOW_CHOICES_S = (5.0, 10.0, 20.0, 30.0)
#: At most this many joints are plotted at once (one plot each).
MAX_JOINTS = 3
DEFAULT_JOINT = "knee_r"
AXIS_PENS = ("#d62728", "#2ca02c", "#1f77b4")
AXIS_NAMES = ("x", "y", "z")
#: (key, title, unit, smallest y range shown so that noise is not blown up to full height).
SENSOR_PLOTS = (
    ("acc", "Accelerometer", "m/s²", 2.0),
    ("gyr", "Gyroscope", "rad/s", 0.5),
    ("mag", "Magnetometer", "µT", 10.0),
)
ANGLE_UNIT, ANGLE_MIN_RANGE = "°", 10.0
#: Smallest height of one plot (px): below it the plots scroll instead of shrinking further.
MIN_PLOT_HEIGHT_PX = 90
#: Smallest distance between two labelled ticks of a vertical axis (px): fewer ticks on a
#: short plot instead of overlapping labels.
MIN_TICK_SPACING_PX = 26.0
#: Height of the time axis under the bottom plot (px).
TIME_AXIS_HEIGHT_PX = 40
#: Most ticks on a vertical axis.
MAX_TICKS = 4
#: Colour of the "no data" note in a plot's title.
NO_DATA_COLOUR = "#888888"
#: Shade of the spans where a joint's angles are doubtful.
DOUBT_BRUSH = (255, 160, 40, 60)

#: Font size of the plot titles.
TITLE_SIZE = "9pt"
#: Room beside a title in a plot (px): the left axis and the plot's margins.
TITLE_MARGIN_PX = 48 + 24

pg.setConfigOptions(antialias=False, background="w", foreground="k")


def _title_html(title: str, names: str) -> str:
    return f"<b>{title}</b>&nbsp;&nbsp;{names}"


def _legend(names) -> str:
    return " ".join(f'<span style="color:{pen}">&#9632;{name}</span>' for pen, name in zip(AXIS_PENS, names))


def _html_width_px(html: str) -> float:
    """Width (px) of one line of ``html`` in the plot titles' font."""
    document = QtGui.QTextDocument()
    font = document.defaultFont()
    font.setPointSizeF(float(TITLE_SIZE.removesuffix("pt")))
    document.setDefaultFont(font)
    document.setHtml(f"<span style='white-space:nowrap'>{html}</span>")
    return document.idealWidth()


class _Curve(pg.PlotCurveItem):
    """A curve told its data bounds with its data (found once per plot for all three axes),
    instead of searching them again each time Qt asks for its bounding rectangle, and told the
    size of a screen pixel in data units (found once per plot), instead of mapping its own
    pixel vectors through the item's transforms whenever its bounds changed (Qt asks after
    every refresh: 1.5 % of a core at 30 Hz)."""

    _known_bounds: tuple | None = None
    _pixel_size: tuple[float, float] | None = None

    def show_data(self, x: np.ndarray, y: np.ndarray, y_bounds: tuple[float | None, float | None],
                  all_finite: bool = False, pixel_size: tuple[float, float] | None = None) -> None:
        """Show ``y`` against sorted ``x``; ``y_bounds`` = ``(nanmin(y), nanmax(y))`` or
        ``(None, None)`` when ``y`` holds no finite value. ``all_finite`` (known by the caller)
        skips pyqtgraph's search for gaps, which costs as much as the drawing's path.
        ``pixel_size``: width and height of a screen pixel in data units (the bounding
        rectangle is padded by one, for the pen), or ``None`` to let pyqtgraph find it."""
        x_bounds = (float(x[0]), float(x[-1])) if len(x) else (None, None)
        self._known_bounds = (x_bounds, y_bounds)
        self._pixel_size = pixel_size
        if all_finite:
            self.setData(x, y, connect="all", skipFiniteCheck=True)
        else:
            self.setData(x, y, connect="finite", skipFiniteCheck=False)

    def dataBounds(self, ax, frac=1.0, orthoRange=None):  # noqa: N802 (pyqtgraph API)
        if self._known_bounds is not None and frac >= 1.0 and orthoRange is None:
            return self._known_bounds[ax]
        return super().dataBounds(ax, frac, orthoRange)

    def boundingRect(self) -> QtCore.QRectF:  # noqa: N802 (Qt API)
        if self._known_bounds is None or self._pixel_size is None:
            return super().boundingRect()
        (x_low, x_high), (y_low, y_high) = self._known_bounds
        if x_low is None or y_low is None:
            return QtCore.QRectF()
        pad_x, pad_y = self._pixel_size
        return QtCore.QRectF(x_low - pad_x, y_low - pad_y, x_high - x_low + 2 * pad_x, y_high - y_low + 2 * pad_y)


#: Why a live source's joint angles are not plotted before a body calibration.
JOINT_ANGLES_NEED_BODY_CALIBRATION = ("they appear once the body is calibrated (Calibrate → Body…); until then "
                                      "angles between the sensors' own axes would mean nothing")


def _joint_angles_refused(pose_source: str) -> str:
    """Why joint angles are not plotted while ``pose_source`` drives the figure ("" : they are)."""
    return "" if pose_source == POSE_BODY_CALIBRATION else JOINT_ANGLES_NEED_BODY_CALIBRATION


class LivePlots(QtWidgets.QWidget):
    """Stacked plots (sensor: acc, gyr, mag; one per selected joint) with sensor, joint and
    window selectors and a pause button.

    Attributes:
        relative_time: True (live) shows the time axis as seconds before the cursor;
            False (review) shows session time.

    Signals:
        refreshed(float): after each refresh that drew new data (``time.perf_counter()``).
    """

    refreshed = QtCore.pyqtSignal(float)

    def __init__(self, parent: QtWidgets.QWidget | None = None, relative_time: bool = False) -> None:
        super().__init__(parent)
        self.setObjectName("livePlots")
        self.source = None
        self.relative_time = bool(relative_time)
        self.sensor_combo = QtWidgets.QComboBox(self)
        self.sensor_combo.setObjectName("plotSensor")
        self.sensor_combo.setSizeAdjustPolicy(QtWidgets.QComboBox.AdjustToContents)
        self.joint_button = QtWidgets.QToolButton(self)
        self.joint_button.setObjectName("plotJoints")
        self.joint_button.setPopupMode(QtWidgets.QToolButton.InstantPopup)
        self.joint_button.setMinimumWidth(72)
        self.joint_button.setToolButtonStyle(QtCore.Qt.ToolButtonTextOnly)
        self.joint_menu = QtWidgets.QMenu(self.joint_button)
        self.joint_button.setMenu(self.joint_menu)
        self.joint_actions: dict[str, QtWidgets.QAction] = {}
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

        # Two rows: the selectors keep their whole texts ("Right upper arm (S04)", "Right
        # shoulder +2") in the narrow plot pane of a 1280-pixel window.
        bar = QtWidgets.QVBoxLayout()
        rows = (((("Sensor", self.sensor_combo),), self.pause_button),
                ((("Joints", self.joint_button), ("Window", self.window_combo)), None))
        for selectors, last in rows:
            row = QtWidgets.QHBoxLayout()
            for text, widget in selectors:
                label = QtWidgets.QLabel(text, self)
                label.setBuddy(widget)
                row.addWidget(label)
                row.addWidget(widget)
            row.addStretch(1)
            if last is not None:
                row.addWidget(last)
            bar.addLayout(row)

        self.layout_widget = pg.GraphicsLayoutWidget()
        # In a small window the plots keep a readable height and scroll.
        self.scroll_area = scrolling(self.layout_widget, self, horizontal=False)
        self.plots: dict[str, pg.PlotItem] = {}
        self.curves: dict[str, list[_Curve]] = {}
        #: joint plot key → dashed curves of the simulator's true angles (evaluation only)
        self.truth_curves: dict[str, list[pg.PlotCurveItem]] = {}
        #: whether the joint plots draw the simulator's truth beside the estimate (when the
        #: source has one: ``truth_joint_series``)
        self.show_truth = False
        #: joint plot key → shaded regions of its doubtful spans (reused, hidden when unused)
        self.doubt_regions: dict[str, list[pg.LinearRegionItem]] = {}
        self.cursors: dict[str, pg.InfiniteLine] = {}
        self._ranges: dict[str, SteadyRange] = {}
        self._titles: dict[str, str] = {}     # each plot's title, without the curve names
        self._no_data: dict[str, bool] = {}   # plots whose window held no finite value
        self.selected_joints: list[str] = []
        #: why joint angles are not plotted ("" when they are): without a body calibration the
        #: segments follow the sensors' own axes and the angles mean nothing
        self.joint_angles_refused = ""
        for key, title, unit, min_range in SENSOR_PLOTS:
            self._add_plot(key, title, unit, min_range, AXIS_NAMES)
        self._place_time_axis()

        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(bar)
        layout.addWidget(self.scroll_area, 1)

        self.window_combo.currentIndexChanged.connect(self._fix_x_range)
        self.window_combo.currentIndexChanged.connect(self._data_changed)
        self.sensor_combo.currentIndexChanged.connect(self._data_changed)
        # One redraw for the data events that arrived since the last one, at most REFRESH_HZ.
        self._redraw_timer = QtCore.QTimer(self)
        self._redraw_timer.setSingleShot(True)
        self._redraw_timer.setTimerType(QtCore.Qt.PreciseTimer)
        self._redraw_timer.timeout.connect(self._redraw)
        self._throttle = RepaintThrottle(REFRESH_HZ, REFRESH_SLACK)
        self.refresh_count = 0
        self._titled_sensor = ""
        self._origin = 0.0  # source time at x = 0 in the last refresh (s)
        self.refresh_times: list[float] = []
        self._fix_x_range()

    # -- plot rows ---------------------------------------------------------------------------
    def _add_plot(self, key: str, title: str, unit: str, min_range: float, names) -> None:
        plot = self.layout_widget.addPlot(row=len(self.plots), col=0)
        plot.setMenuEnabled(False)
        plot.hideButtons()
        left = plot.getAxis("left")
        left.enableAutoSIPrefix(False)
        left.setLabel(unit)
        left.setWidth(48)
        left.setStyle(hideOverlappingLabels=False)  # a tick near the top still gets its label
        plot.getAxis("bottom").enableAutoSIPrefix(False)
        plot.hideAxis("bottom")
        view = plot.getViewBox()
        view.disableAutoRange()
        view.setMouseEnabled(x=False, y=True)
        plot.showGrid(x=True, y=True, alpha=0.25)
        # Bare curve items: PlotDataItem's bookkeeping (clipping, downsampling, bounds) cost
        # twice the drawing itself at 30 Hz; the window is decimated here instead.
        curves = []
        for axis in range(3):
            curve = _Curve(pen=pg.mkPen(AXIS_PENS[axis], width=1), name=names[axis])
            plot.addItem(curve)
            curves.append(curve)
        # Axes and title change rarely: keep each as a pixmap instead of re-drawing
        # its text and ticks on every refresh.
        cached = QtWidgets.QGraphicsItem.DeviceCoordinateCache
        for item in (plot.getAxis("left"), plot.getAxis("bottom"), plot.titleLabel):
            item.setCacheMode(cached)
        cursor = pg.InfiniteLine(angle=90, movable=False, pen=pg.mkPen("#444", width=1, style=QtCore.Qt.DashLine))
        plot.addItem(cursor, ignoreBounds=True)
        if self.plots:
            plot.setXLink(next(iter(self.plots.values())))
        self.plots[key] = plot
        self.curves[key] = curves
        view.sigResized.connect(lambda _view, key=key: self._apply_range(key) if key in self.plots else None)
        self._set_title(key, title)
        self.cursors[key] = cursor
        self._ranges[key] = SteadyRange(min_range)
        self._apply_range(key)

    def _apply_range(self, key: str) -> None:
        """Show plot ``key``'s steady range with 3-5 round, labelled ticks (pyqtgraph's own
        choice labels only 0 for some ranges)."""
        steady = self._ranges[key]
        height_px = max(self.plots[key].getViewBox().height(), 60.0)
        ticks = nice_ticks(steady.low, steady.high, MAX_TICKS, most=int(height_px // MIN_TICK_SPACING_PX))
        low, high = steady.low, steady.high
        if ticks:  # room for the outer labels (pyqtgraph drops a label that sticks out)
            pad = 8.0 * (high - low) / (height_px - 16.0)
            low, high = min(low, ticks[0][0] - pad), max(high, ticks[-1][0] + pad)
        self.plots[key].setYRange(low, high, padding=0)
        self.plots[key].getAxis("left").setTicks([ticks, []])

    def _set_title(self, key: str, title: str) -> None:
        """Title ``key``'s plot; the curve names follow in their colours (a legend inside the
        short plots would hide the newest data), or "no data" while the window holds none
        (e.g. a source that does not send this sensor's gyroscope)."""
        self._titles[key] = title
        if self._no_data.get(key, False):
            names = f'<span style="color:{NO_DATA_COLOUR}">no data</span>'
        else:
            names = " ".join(f'<span style="color:{pen}">&#9632;{curve.opts["name"]}</span>'
                             for pen, curve in zip(AXIS_PENS, self.curves[key]))
        self.plots[key].setTitle(_title_html(title, names), size=TITLE_SIZE)

    def title_text(self, key: str) -> str:
        """The title shown above plot ``key`` (``acc``, ``gyr``, ``mag`` or ``joint:<name>``)."""
        return self.plots[key].titleLabel.text

    def _remove_plot(self, key: str) -> None:
        plot = self.plots.pop(key)
        del self.curves[key], self.cursors[key], self._ranges[key], self._titles[key]
        self._no_data.pop(key, None)
        self.truth_curves.pop(key, None)
        self.doubt_regions.pop(key, None)
        self.layout_widget.removeItem(plot)
        plot.deleteLater()

    def _place_time_axis(self) -> None:
        """Show the time axis (and vertical grid) on the bottom plot only: the plots share one
        time range, and a time axis is the costliest item to draw."""
        *upper, last = self.plots.values()
        for plot in upper:
            plot.hideAxis("bottom")
        last.setLabel("bottom", "time before the pose shown (s)" if self.relative_time else "time (s)")
        last.showAxis("bottom")
        self.layout_widget.setMinimumHeight(len(self.plots) * MIN_PLOT_HEIGHT_PX + TIME_AXIS_HEIGHT_PX)

    def _joint_key(self, joint: str) -> str:
        return f"joint:{joint}"

    def set_joints(self, joints) -> None:
        """Plot the angles of ``joints`` (at most :data:`MAX_JOINTS`, known to the source)."""
        joints = list(dict.fromkeys(joints))
        if len(joints) > MAX_JOINTS:
            raise ValueError(f"at most {MAX_JOINTS} joints can be plotted at once, got {len(joints)}")
        known = set(self.source.joint_names) if self.source is not None else set(joints)
        unknown = [j for j in joints if j not in known]
        if unknown:
            raise ValueError(f"unknown joint(s): {', '.join(unknown)}")
        for joint in self.selected_joints:
            self._remove_plot(self._joint_key(joint))
        for joint in joints:
            self._add_joint_plot(joint)
        self.selected_joints = joints
        self._place_time_axis()
        for joint, action in self.joint_actions.items():
            action.blockSignals(True)
            action.setChecked(joint in joints)
            action.setEnabled(joint in joints or len(joints) < MAX_JOINTS)
            action.blockSignals(False)
        first = joint_name(joints[0]) if joints else "(none)"
        text = first + (f" +{len(joints) - 1}" if len(joints) > 1 else "")
        self.joint_button.setText(text)
        # The text is centred and the menu arrow drawn in the right corner: room for the arrow on
        # both sides keeps the text clear of it.
        arrow = self.joint_button.style().pixelMetric(QtWidgets.QStyle.PM_MenuButtonIndicator, None, self.joint_button)
        self.joint_button.setMinimumWidth(max(72, self.joint_button.fontMetrics().horizontalAdvance(text) + 2 * arrow + 16))
        self.joint_button.setToolTip(f"Joints plotted (up to {MAX_JOINTS}): "
                                     f"{', '.join(joint_name(j) for j in joints) or 'none'}")
        self._fix_x_range()
        self.refresh()

    def _axis_names(self, joint: str) -> list[str]:
        """The legend of ``joint``'s plot: its three axes' clinical names."""
        names = []
        columns = (self.source.joint_columns(joint) if self.source is not None
                   else [f"{joint}_{axis}_deg" for axis in ("flexion", "adduction", "rotation")])
        for column in columns:
            try:
                names.append(axis_short_name(*split_angle_column(column)))
            except ValueError:  # a column named otherwise keeps its name
                names.append(column.removesuffix("_deg").replace("_", " "))
        return names

    def _add_joint_plot(self, joint: str) -> None:
        key = self._joint_key(joint)
        self._add_plot(key, joint_name(joint), ANGLE_UNIT, ANGLE_MIN_RANGE, self._axis_names(joint))
        truth = []
        for axis in range(3):
            curve = pg.PlotCurveItem(pen=pg.mkPen(AXIS_PENS[axis], width=1, style=QtCore.Qt.DashLine))
            self.plots[key].addItem(curve)
            truth.append(curve)
        self.truth_curves[key] = truth

    def _fit_titles(self) -> None:
        """Keep the plots wide enough for the longest title any choice of the source can give
        (every sensor, every joint): a title is never cut, and the pane does not change width
        when another sensor or joint is chosen."""
        titles = [_title_html(f"{title}, {self._sensor_title(sid)}", _legend(AXIS_NAMES))
                  for sid in self.source.sensor_ids for _key, title, _unit, _range in SENSOR_PLOTS]
        titles += [_title_html(joint_name(joint), _legend(self._axis_names(joint))) for joint in self.source.joint_names]
        widest = max((_html_width_px(html) for html in titles), default=0.0)
        self.scroll_area.setMinimumWidth(int(widest + TITLE_MARGIN_PX))

    def _sensor_title(self, sensor_id: str) -> str:
        segment = (getattr(self.source, "sensor_segments", None) or {}).get(sensor_id)
        return sensor_name(segment, sensor_id)

    def _joint_toggled(self, joint: str, on: bool) -> None:
        joints = [j for j in self.selected_joints if j != joint]
        if on:
            joints.append(joint)
        self.set_joints(joints[:MAX_JOINTS])

    # -- wiring ------------------------------------------------------------------------------
    def set_source(self, source) -> None:
        """Show data of ``source`` (a live session or a review player; ``None``: none), following
        its events; the previous source is let go (unsubscribed) and nothing of it stays on screen."""
        previous, self.source = self.source, source
        if previous is not None:
            self._subscribe(previous, False)
        self._redraw_timer.stop()
        empty = np.zeros(0)
        for key, title, _unit, _min_range in SENSOR_PLOTS:
            for curve in self.curves[key]:
                curve.show_data(empty, empty, (None, None), all_finite=True)
            self._no_data[key] = False
            self._set_title(key, title)
        self._titled_sensor = ""
        for joint in self.selected_joints:
            self._remove_plot(self._joint_key(joint))
        self.selected_joints = []
        self.joint_menu.clear()
        self.joint_actions = {}
        if source is None:
            return
        if "pose_source" in source.events.names:
            self.joint_angles_refused = _joint_angles_refused(source.pose_source)
        self._subscribe(source, True)
        self.update_choices()
        self._data_changed()

    def _subscribe(self, source, on: bool) -> None:
        """Connect to (``on``) or disconnect from ``source``'s events."""
        names = source.events.names
        for name, callback in (("data", self._data_changed), ("sensors", self._choices_changed),
                               ("assignment", self._choices_changed), ("pose_source", self._pose_source_changed)):
            if name not in names:
                continue
            emitter = getattr(source.events, name)
            if on:
                emitter.connect(callback)
            else:
                emitter.disconnect(callback)

    def _pose_source_changed(self, pose_source: str) -> None:
        """What drives the figure changed: joint angles are plotted only through a body calibration."""
        refused = _joint_angles_refused(pose_source)
        if refused != self.joint_angles_refused:
            self.refuse_joint_angles(refused)

    def _choices_changed(self, *_args) -> None:
        """The source's sensors or their segments changed: the selectors and titles follow."""
        self.update_choices()
        self._data_changed()

    def _data_changed(self, *_args) -> None:
        """New data (or a moved play head): one redraw soon, none while paused."""
        if self.paused or self.source is None or self._redraw_timer.isActive():
            return
        self._redraw_timer.start(RepaintThrottle.timer_ms(self._throttle.wait_s(time.perf_counter())))

    def _redraw(self) -> None:
        self._throttle.painted(time.perf_counter())
        self.refresh()

    def update_choices(self) -> None:
        """Refresh the sensor and joint lists from the source (keeps the selection)."""
        if self.source is None:
            return
        current_sensor = self.sensor_id
        segments = getattr(self.source, "sensor_segments", None) or {}
        # "Pelvis (S01)" next to the word "Sensor"; the plot titles say "Pelvis sensor (S01)"
        entries = [(f"{segment_name(segments[sid])} ({sid})" if segments.get(sid) else sid, sid)
                   for sid in self.source.sensor_ids]
        shown = [(self.sensor_combo.itemText(i), self.sensor_combo.itemData(i)) for i in range(self.sensor_combo.count())]
        if shown != entries:
            self.sensor_combo.blockSignals(True)
            self.sensor_combo.clear()
            for text, sid in entries:
                self.sensor_combo.addItem(text, sid)
            index = self.sensor_combo.findData(current_sensor)
            if index >= 0:
                self.sensor_combo.setCurrentIndex(index)
            self.sensor_combo.blockSignals(False)
            self._titled_sensor = ""  # the sensor's name may have changed with its segment
            self._fit_titles()
        joints = [] if self.joint_angles_refused else list(self.source.joint_names)
        self.joint_button.setEnabled(not self.joint_angles_refused)
        if list(self.joint_actions) != joints or (not joints and self.selected_joints):
            self.joint_menu.clear()
            self.joint_actions = {}
            for joint in joints:
                action = self.joint_menu.addAction(joint_name(joint))
                action.setCheckable(True)
                action.toggled.connect(lambda on, j=joint: self._joint_toggled(j, on))
                self.joint_actions[joint] = action
            kept = [j for j in self.selected_joints if j in joints]
            if not kept and joints:
                kept = [DEFAULT_JOINT if DEFAULT_JOINT in joints else joints[0]]
            self.set_joints(kept)
            self._fit_titles()
        if self.joint_angles_refused:
            self.joint_button.setText("(none)")
            self.joint_button.setToolTip(f"Joint angles: {self.joint_angles_refused}")

    def refuse_joint_angles(self, reason: str) -> None:
        """Plot no joint angles, saying ``reason`` on the joint selector ("": plot them again)."""
        self.joint_angles_refused = reason
        self.update_choices()
        self._data_changed()

    @property
    def sensor_id(self) -> str:
        """The id of the sensor plotted ("" when none)."""
        data = self.sensor_combo.currentData()
        return "" if data is None else str(data)

    @property
    def paused(self) -> bool:
        return self.pause_button.isChecked()

    def _paused_changed(self, paused: bool) -> None:
        self.pause_button.setText("Resume" if paused else "Pause")
        if paused:
            self._redraw_timer.stop()
        else:
            self._data_changed()

    @property
    def window_s(self) -> float:
        return float(self.window_combo.currentData())

    def _fix_x_range(self) -> None:
        if self.relative_time and self.plots:
            next(iter(self.plots.values())).setXRange(-self.window_s, 0.0, padding=0)

    # -- drawing -----------------------------------------------------------------------------
    def _show(self, key: str, t: np.ndarray, values: np.ndarray, origin: float, now_s: float) -> None:
        x, shown = peak_decimate(t - origin, values, MAX_POINTS)
        low, high = column_bounds(shown)
        finite_low = [v for v in low if v is not None]
        finite_high = [v for v in high if v is not None]
        if (not finite_low) != self._no_data.get(key, False):
            self._no_data[key] = not finite_low
            self._set_title(key, self._titles[key])
        if finite_low and self._ranges[key].update(min(finite_low), max(finite_high), now_s):
            self._apply_range(key)
        # the pixel's size in the range the curves are shown in (set just above)
        pixel = self.plots[key].getViewBox().viewPixelSize()
        pixel_size = (abs(pixel[0]), abs(pixel[1])) if all(map(np.isfinite, pixel)) else None
        all_finite = bool(np.isfinite(shown).all())
        for axis, curve in enumerate(self.curves[key]):
            curve.show_data(x, shown[:, axis], (low[axis], high[axis]), all_finite, pixel_size)

    def refresh(self) -> None:
        """Pull the newest window from the source into the curves (skipped while paused)."""
        if self.paused or self.source is None:
            return
        if self.sensor_combo.count() == 0 or not self.joint_actions:
            self.update_choices()
        window = self.window_s
        cursor = self.source.cursor_s
        origin = cursor if self.relative_time and np.isfinite(cursor) else 0.0
        self._origin = origin
        now = time.perf_counter()
        sensor = self.sensor_id
        drew = False
        if sensor and sensor != self._titled_sensor:
            for key, title, _unit, _r in SENSOR_PLOTS:
                self._set_title(key, f"{title}, {self._sensor_title(sensor)}")
            self._titled_sensor = sensor
        if sensor:
            t, acc, gyr, mag = self.source.series(sensor, window)
            for key, values in (("acc", acc), ("gyr", gyr), ("mag", mag)):
                self._show(key, t, values, origin, now)
            drew = drew or len(t) > 0
        truth_of = getattr(self.source, "truth_joint_series", None) if self.show_truth else None
        doubt_of = getattr(self.source, "doubt_spans", None)
        for joint in self.selected_joints:
            t, angles = self.source.joint_series(joint, window)
            self._show(self._joint_key(joint), t, angles, origin, now)
            if doubt_of is not None:
                self._show_doubt(self._joint_key(joint), doubt_of(joint, window), origin)
            drew = drew or len(t) > 0
            if truth_of is not None:
                self._show_truth(self._joint_key(joint), joint, truth_of, window, origin)
        if np.isfinite(cursor):
            for line in self.cursors.values():
                line.setValue(cursor - origin)
            if not self.relative_time:
                next(iter(self.plots.values())).setXRange(cursor - window, cursor, padding=0)
        if drew:
            self.refresh_count += 1
            self.refresh_times.append(now)
            if len(self.refresh_times) > 600:
                del self.refresh_times[:300]
            self.refreshed.emit(now)

    def _show_doubt(self, key: str, spans, origin: float) -> None:
        """Shade ``spans`` ``(start_s, end_s)`` of plot ``key`` (source time)."""
        regions = self.doubt_regions.setdefault(key, [])
        while len(regions) < len(spans):
            region = pg.LinearRegionItem(movable=False, brush=pg.mkBrush(*DOUBT_BRUSH), pen=pg.mkPen(None))
            region.setZValue(-10)
            self.plots[key].addItem(region)
            regions.append(region)
        for index, region in enumerate(regions):
            if index < len(spans):
                start, end = spans[index]
                region.setRegion((start - origin, end - origin))
                region.setVisible(True)
            elif region.isVisible():
                region.setVisible(False)

    def doubt_shown(self, joint: str) -> list[tuple[float, float]]:
        """The doubtful spans shaded in ``joint``'s plot, in source time (s)."""
        return [tuple(v + self._origin for v in region.getRegion())
                for region in self.doubt_regions.get(self._joint_key(joint), []) if region.isVisible()]

    def set_show_truth(self, on: bool) -> None:
        """Draw the simulator's true angles beside the estimate (when the source has them) or
        not (the dashed curves are cleared once)."""
        self.show_truth = bool(on)
        if not on:
            for curves in self.truth_curves.values():
                for curve in curves:
                    curve.setData([], [])
        self._data_changed()

    def _show_truth(self, key: str, joint: str, truth_of, window: float, origin: float) -> None:
        """The simulator's true angles as dashed curves beside the estimate."""
        t, angles = truth_of(joint, window)
        x, shown = peak_decimate(t - origin, angles, MAX_POINTS) if len(t) else (t, angles)
        for axis, curve in enumerate(self.truth_curves.get(key, ())):
            curve.setData(x, shown[:, axis] if len(x) else x)

    def curve_data(self, key: str, axis: int) -> tuple[np.ndarray, np.ndarray]:
        """What curve ``axis`` of plot ``key`` shows, in source time (s): ``acc``, ``gyr``,
        ``mag``, ``angles`` (the first selected joint) or a joint name."""
        if key == "angles":
            key = self.selected_joints[0] if self.selected_joints else ""
        if key not in self.curves:
            key = self._joint_key(key)
        x, y = self.curves[key][axis].getData()
        if x is None:
            return np.zeros(0), np.zeros(0)
        return x + self._origin, y
