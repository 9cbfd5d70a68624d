"""The live plots: what the curves show (time base, decimation), steady vertical ranges, the
selection of several joints, and the source's events that make them redraw (and nothing else)."""

from __future__ import annotations

import time

import numpy as np
import pytest
from PyQt5 import QtWidgets

from mimucap.gui.live_plots import MAX_JOINTS, REFRESH_HZ, REFRESH_SLACK, LivePlots
from mimucap.session.views import plot_scaling
from mimucap.session.events import EmitterGroup


class FakeSource:
    """A plot source with known signals: sample k at t = k / 100 s, acc x = sin, the angle
    columns of joint j = (j, 2 j, 3 j) + t."""

    def __init__(self, duration_s: float = 30.0, cursor_s: float | None = None) -> None:
        self.t = np.arange(int(duration_s * 100)) / 100.0
        self.cursor_s = self.t[-1] if cursor_s is None else cursor_s
        self.sensor_ids = ("S01", "S02")
        self.joint_names = ("hip_r", "knee_r", "ankle_r", "elbow_l")
        self.events = EmitterGroup("data", "sensors")

    def joint_columns(self, joint):
        return tuple(f"{joint}_{name}_deg" for name in ("flexion", "adduction", "rotation"))

    def _window(self, window_s):
        keep = (self.t >= self.cursor_s - window_s) & (self.t <= self.cursor_s)
        return self.t[keep]

    def series(self, sensor_id, window_s):
        t = self._window(window_s)
        acc = np.stack([np.sin(t), np.zeros_like(t), np.full_like(t, 9.81)], axis=1)
        gyr = np.zeros((len(t), 3))
        mag = np.tile([20.0, 0.0, -40.0], (len(t), 1))
        return t, acc, gyr, mag

    def joint_series(self, joint, window_s):
        t = self._window(window_s)
        j = self.joint_names.index(joint) + 1
        return t, np.stack([j + t, 2 * j + t, 3 * j + t], axis=1)


@pytest.fixture
def plots(qtbot):
    widget = LivePlots(relative_time=True)
    qtbot.addWidget(widget)
    widget.set_source(FakeSource())
    widget.show()
    return widget


def test_live_time_axis_is_relative_but_curve_data_is_in_source_time(plots):
    plots.refresh()
    x, y = plots.curve_data("acc", 0)
    assert x[-1] == pytest.approx(plots.source.cursor_s)
    assert x[0] == pytest.approx(plots.source.cursor_s - plots.window_s, abs=0.011)
    np.testing.assert_allclose(y, np.sin(x), atol=1e-12)
    drawn_x, _ = plots.curves["acc"][0].getData()
    assert drawn_x[-1] == pytest.approx(0.0) and drawn_x[0] < -9.9
    view_range = plots.plots["acc"].getViewBox().viewRange()[0]
    assert view_range == pytest.approx([-10.0, 0.0])


def test_review_plots_show_session_time_around_the_cursor(qtbot):
    widget = LivePlots(relative_time=False)
    qtbot.addWidget(widget)
    widget.set_source(FakeSource(cursor_s=12.5))
    widget.show()
    widget.refresh()
    drawn_x, _ = widget.curves["gyr"][1].getData()
    assert drawn_x[-1] == pytest.approx(12.5)
    assert widget.plots["acc"].getViewBox().viewRange()[0] == pytest.approx([2.5, 12.5])
    assert widget.cursors["mag"].value() == pytest.approx(12.5)


def test_default_joint_and_several_joints_each_with_its_plot(plots):
    assert plots.selected_joints == ["knee_r"]
    plots.set_joints(["hip_r", "ankle_r"])
    plots.refresh()
    assert list(plots.plots) == ["acc", "gyr", "mag", "joint:hip_r", "joint:ankle_r"]
    _, flexion = plots.curve_data("hip_r", 0)
    x, rotation = plots.curve_data("ankle_r", 2)
    np.testing.assert_allclose(flexion, 1 + x)
    np.testing.assert_allclose(rotation, 9 + x)
    assert "flexion" in plots.title_text("joint:hip_r") and "rotation" in plots.title_text("joint:ankle_r")
    # "angles" means the first selected joint (the plot the single-joint layout had).
    np.testing.assert_allclose(plots.curve_data("angles", 0)[1], flexion)
    # Only the bottom plot carries the time axis.
    assert plots.plots["joint:ankle_r"].getAxis("bottom").isVisible()
    assert not any(plots.plots[k].getAxis("bottom").isVisible() for k in ("acc", "gyr", "mag", "joint:hip_r"))
    # The menu follows, and a fourth joint cannot be ticked.
    plots.set_joints(["hip_r", "ankle_r", "elbow_l"])
    assert [j for j, a in plots.joint_actions.items() if a.isChecked()] == ["hip_r", "ankle_r", "elbow_l"]
    assert not plots.joint_actions["knee_r"].isEnabled()
    assert plots.joint_button.text() == "Right hip +2"
    # The centred text stays clear of the menu arrow in the button's right corner.
    button = plots.joint_button
    plots.show()
    QtWidgets.QApplication.processEvents()
    arrow = button.style().pixelMetric(QtWidgets.QStyle.PM_MenuButtonIndicator, None, button)
    assert (button.width() - button.fontMetrics().horizontalAdvance(button.text())) / 2 >= arrow + 4
    plots.joint_actions["ankle_r"].setChecked(False)  # as the user would, in the menu
    assert plots.selected_joints == ["hip_r", "elbow_l"]
    assert "joint:ankle_r" not in plots.plots and plots.joint_actions["knee_r"].isEnabled()


def test_joint_selection_is_checked(plots):
    with pytest.raises(ValueError, match="at most"):
        plots.set_joints(["hip_r", "knee_r", "ankle_r", "elbow_l"][: MAX_JOINTS + 1])
    with pytest.raises(ValueError, match="unknown joint"):
        plots.set_joints(["neck"])
    assert plots.selected_joints == ["knee_r"]


def test_long_windows_are_decimated_to_their_extremes(plots):
    plots.window_combo.setCurrentIndex(plots.window_combo.findData(30.0))
    plots.refresh()
    x, y = plots.curve_data("acc", 0)
    assert len(x) <= plot_scaling.MAX_POINTS
    assert y.max() == pytest.approx(1.0, abs=1e-3) and y.min() == pytest.approx(-1.0, abs=1e-3)


def test_curves_know_their_bounds_and_the_range_holds_the_data(plots):
    plots.refresh()
    curve = plots.curves["acc"][0]
    x, y = curve.getData()
    assert curve.dataBounds(0) == (x[0], x[-1])
    assert curve.dataBounds(1) == pytest.approx((np.min(y), np.max(y)))
    low, high = plots.plots["acc"].getViewBox().viewRange()[1]
    assert low <= np.min(y) and high >= 9.81  # the z axis column (gravity) is inside too
    assert plots.curves["gyr"][0].dataBounds(1) == pytest.approx((0.0, 0.0))


def test_bounding_rectangles_hold_the_data_and_a_pixel_for_the_pen(plots, qtbot):
    plots.resize(700, 600)
    qtbot.waitUntil(lambda: plots.plots["acc"].getViewBox().width() > 100)
    plots.refresh()
    view = plots.plots["gyr"].getViewBox()
    pixel_w, pixel_h = view.viewPixelSize()
    flat = plots.curves["gyr"][0].boundingRect()  # a flat zero line still has a height
    assert flat.top() == pytest.approx(-pixel_h) and flat.height() == pytest.approx(2 * pixel_h)
    x, _y = plots.curves["gyr"][0].getData()
    assert flat.left() == pytest.approx(x[0] - pixel_w) and flat.right() == pytest.approx(x[-1] + pixel_w)
    # what pyqtgraph's own bounds (mapping the item's pixel vectors) give, within rounding
    curve = plots.curves["acc"][0]
    own = super(type(curve), curve)
    curve.invalidateBounds()
    expected = own.boundingRect()
    got = curve.boundingRect()
    assert got.top() <= expected.top() + 1e-9 and got.bottom() >= expected.bottom() - 1e-9
    assert got.height() == pytest.approx(expected.height(), rel=0.05)
    # data that outgrow the range: the padding is a pixel of the range the curve is shown in
    series = plots.source.series
    plots.source.series = lambda sensor, window: (lambda t, acc, gyr, mag: (t, 50.0 * acc, gyr, mag))(
        *series(sensor, window))
    low_before = plots.plots["acc"].getViewBox().viewRange()[1][0]
    plots.refresh()
    view = plots.plots["acc"].getViewBox()
    assert view.viewRange()[1][0] < low_before  # the range grew in this refresh
    x, y = curve.getData()
    rect = curve.boundingRect()
    assert rect.top() == pytest.approx(np.min(y) - view.viewPixelSize()[1])


def test_pause_freezes_the_curves(plots):
    plots.refresh()
    before = plots.curves["acc"][0].getData()[1].copy()
    plots.pause_button.setChecked(True)
    assert plots.pause_button.text() == "Resume"
    plots.source.cursor_s -= 1.0
    plots.refresh()
    np.testing.assert_array_equal(plots.curves["acc"][0].getData()[1], before)
    plots.pause_button.setChecked(False)
    plots.refresh()
    assert len(plots.curves["acc"][0].getData()[1]) == len(before)
    assert not np.array_equal(plots.curves["acc"][0].getData()[1], before)


def _subpaths(curve) -> int:
    path = curve.getPath()
    return sum(path.elementAt(i).isMoveTo() for i in range(path.elementCount()))


def test_a_gap_in_the_data_stays_a_gap_in_the_curve(plots):
    class Gappy(FakeSource):
        def series(self, sensor_id, window_s):
            t, acc, gyr, mag = super().series(sensor_id, window_s)
            mag = mag.copy()
            mag[len(t) // 2: len(t) // 2 + 20] = np.nan  # the magnetometer dropped out for 0.2 s
            return t, acc, gyr, mag

    plots.source = Gappy()
    plots.refresh()
    assert _subpaths(plots.curves["mag"][0]) == 2  # before and after the gap
    assert _subpaths(plots.curves["acc"][0]) == 1  # continuous data, one line
    x, y = plots.curve_data("mag", 0)
    assert np.isnan(y).sum() == 20 and np.isfinite(y).sum() == len(y) - 20


def test_a_plot_whose_window_holds_no_data_says_so_in_its_title(plots):
    """A source that sends no gyroscope (e.g. an Xsens export with accelerations and
    orientations only) leaves that plot empty: its title says "no data" instead of naming
    curves that are not there, and names them again once data comes."""

    class NoGyroscope(FakeSource):
        sends_gyroscope = False

        def series(self, sensor_id, window_s):
            t, acc, gyr, mag = super().series(sensor_id, window_s)
            return t, acc, np.full_like(gyr, np.nan) if not self.sends_gyroscope else gyr, mag

    source = NoGyroscope()
    plots.source = source
    plots.refresh()
    assert "no data" in plots.title_text("gyr") and "Gyroscope, Sensor S01" in plots.title_text("gyr")
    assert "no data" not in plots.title_text("acc") and "&#9632;x" in plots.title_text("acc")
    source.sends_gyroscope = True
    plots.refresh()
    assert "no data" not in plots.title_text("gyr") and "&#9632;x" in plots.title_text("gyr")


def test_plots_name_sensors_joints_and_axes_clinically(plots):
    """Menus, selectors and titles read "Pelvis sensor (S01)", "Right knee", "flexion"; the
    machine names stay the keys (the plotted sensor id, the joint keys)."""
    plots.source.sensor_segments = {"S01": "pelvis", "S02": "thigh_r"}
    plots.update_choices()
    texts = [plots.sensor_combo.itemText(i) for i in range(plots.sensor_combo.count())]
    assert texts == ["Pelvis (S01)", "Right thigh (S02)"]
    plots.sensor_combo.setCurrentIndex(1)
    assert plots.sensor_id == "S02"
    plots.refresh()
    assert "Accelerometer, Right thigh sensor (S02)" in plots.title_text("acc")
    assert [a.text() for a in plots.joint_actions.values()] == ["Right hip", "Right knee", "Right ankle", "Left elbow"]
    title = plots.title_text("joint:knee_r")
    assert "Right knee" in title and "internal rotation" in title and "_" not in title
    assert plots.plots["joint:knee_r"].getAxis("left").labelText == "°"


def _settled(plots, qtbot) -> int:
    """The plots' refresh count once the redraw they asked for is done."""
    qtbot.waitUntil(lambda: not plots._redraw_timer.isActive(), timeout=1000)
    return plots.refresh_count


def test_the_plots_redraw_on_the_data_event_and_not_without_it(plots, qtbot):
    base = _settled(plots, qtbot)  # the new source's window is drawn
    assert base >= 1
    source = plots.source
    qtbot.wait(150)
    assert plots.refresh_count == base  # nothing new, nothing drawn
    source.cursor_s = 20.0
    source.events.data.emit(source.cursor_s)
    qtbot.waitUntil(lambda: plots.refresh_count == base + 1, timeout=1000)
    assert plots.curve_data("acc", 0)[0][-1] == pytest.approx(20.0)


def test_data_events_faster_than_the_screen_are_coalesced(plots, qtbot):
    base = _settled(plots, qtbot)
    source = plots.source
    start = time.perf_counter()
    while time.perf_counter() - start < 0.5:  # an event every 2 ms
        source.events.data.emit(source.cursor_s)
        qtbot.wait(2)
    qtbot.wait(60)
    drawn = plots.refresh_count - base
    assert 5 <= drawn <= (time.perf_counter() - start) * REFRESH_HZ / (1.0 - REFRESH_SLACK) + 2, drawn


def test_nothing_is_drawn_while_paused_and_the_newest_window_on_resuming(plots, qtbot):
    base = _settled(plots, qtbot)
    source = plots.source
    plots.pause_button.setChecked(True)
    source.cursor_s = 25.0
    for _ in range(5):
        source.events.data.emit(source.cursor_s)
        qtbot.wait(40)
    assert plots.refresh_count == base
    plots.pause_button.setChecked(False)
    qtbot.waitUntil(lambda: plots.refresh_count == base + 1, timeout=1000)
    assert plots.curve_data("acc", 0)[0][-1] == pytest.approx(25.0)


def test_the_plots_let_their_source_go(plots, qtbot):
    old = plots.source
    assert old.events.data.callbacks and old.events.sensors.callbacks
    new = FakeSource()
    plots.set_source(new)
    assert not old.events.data.callbacks and not old.events.sensors.callbacks
    assert new.events.data.callbacks
    plots.set_source(None)
    assert not new.events.data.callbacks and not new.events.sensors.callbacks
    new.events.data.emit(1.0)  # nothing left to draw it
    qtbot.wait(60)


def test_the_sensor_choice_follows_the_sensors_event(plots, qtbot):
    source = plots.source
    source.sensor_ids = ("S01", "S02", "S03")
    assert plots.sensor_combo.count() == 2  # not asked again
    source.events.sensors.emit(source.sensor_ids)
    assert plots.sensor_combo.count() == 3
