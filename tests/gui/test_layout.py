"""The windows stay usable at small sizes and give the room back when they grow: the main
window shrinks to 800 × 500 (docks and plots scroll instead of holding it wide), its docks get
their size back afterwards, and a short plot labels fewer ticks instead of overlapping ones."""

from __future__ import annotations

import numpy as np
from PyQt5 import QtWidgets

from mimucap.gui.live_plots import MIN_PLOT_HEIGHT_PX, LivePlots
from mimucap.gui.main_window import SENSOR_DOCK_START_PX
from tests.known_mounting import known_mounting_calibration


def test_the_main_window_shrinks_to_800_by_500_and_its_docks_come_back(window, qtbot):
    window.plots.set_joints(["knee_r", "hip_r", "elbow_r"])
    window.live_status.source_status.setText("Source: " + "udp:0.0.0.0:5005, " * 12)  # a long text is elided, not a floor
    minimum = window.minimumSizeHint()
    assert minimum.width() <= 800 and minimum.height() <= 500
    assert window.live_status.source_status.toolTip().startswith("Source: udp")  # the whole text, when elided
    qtbot.waitUntil(lambda: abs(window.sensor_dock.height() - SENSOR_DOCK_START_PX) <= 2, timeout=3000)
    session_width = window.session_dock.width()
    assert session_width >= window.session_panel.sizeHint().width()  # the whole panel, no scroll bar

    window.resize(800, 500)
    qtbot.waitUntil(lambda: window.width() == 800 and window.height() == 500, timeout=3000)
    qtbot.waitUntil(lambda: window.sensor_dock.height() <= 0.3 * 500 + 1, timeout=3000)  # the view keeps most
    assert window.scene_view.height() >= 200

    window.resize(1280, 800)
    qtbot.waitUntil(lambda: window.width() == 1280, timeout=3000)
    qtbot.waitUntil(lambda: abs(window.sensor_dock.height() - SENSOR_DOCK_START_PX) <= 2, timeout=3000)
    qtbot.waitUntil(lambda: abs(window.session_dock.width() - session_width) <= 2, timeout=3000)


def _label_spacing_px(plots: LivePlots) -> dict[str, float]:
    """Smallest distance (px) between two labelled ticks of each plot's vertical axis."""
    spacing = {}
    for key, plot in plots.plots.items():
        ticks = [value for value, _label in plot.getAxis("left")._tickLevels[0]]
        low, high = plot.getViewBox().viewRange()[1]
        if len(ticks) > 1:
            spacing[key] = float(np.min(np.diff(ticks))) * plot.getViewBox().height() / (high - low)
    return spacing


def test_plots_scroll_rather_than_squash_and_label_only_the_ticks_that_fit(window, qtbot):
    plots = window.plots
    window.live.apply_body_calibration(known_mounting_calibration(window.live))  # joint angles need one
    qtbot.waitUntil(lambda: not plots.joint_angles_refused, timeout=10000)
    plots.set_joints(["knee_r", "hip_r", "elbow_r"])
    window.resize(800, 500)
    qtbot.waitUntil(lambda: window.height() == 500, timeout=3000)
    qtbot.waitUntil(lambda: plots.refresh_count > 5, timeout=5000)
    heights = [plot.height() for plot in plots.plots.values()]
    assert len(heights) == 6 and min(heights) >= 0.85 * MIN_PLOT_HEIGHT_PX  # less the layout's spacing
    assert plots.scroll_area.verticalScrollBar().maximum() > 0     # the rest is a scroll away
    assert min(_label_spacing_px(plots).values()) >= 14.0          # one line of 9-pt text

    window.resize(1280, 1100)
    qtbot.waitUntil(lambda: window.height() == 1100, timeout=3000)
    qtbot.waitUntil(lambda: plots.scroll_area.verticalScrollBar().maximum() == 0, timeout=3000)
    tall = max(len(plot.getAxis("left")._tickLevels[0]) for plot in plots.plots.values())
    assert tall >= 3  # with room, more ticks are labelled again
    assert isinstance(plots.scroll_area, QtWidgets.QScrollArea)
