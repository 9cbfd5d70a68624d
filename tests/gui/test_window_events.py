"""The main window's widgets follow the live session's events: each updates when its event comes
and not without it (nothing polls the session), and every subscription goes with the session
when the source changes or the window closes."""

from __future__ import annotations

import math

import pytest

from mimucap.core.pipeline.recording import POSE_BODY_CALIBRATION
from mimucap.gui.live_status_bar import VIEW_HINTS
from mimucap.gui.main_window import MainWindow
from mimucap.session.live.processing import POSE_NONE, POSE_UNASSIGNED
from mimucap.session.live.sensor_rows import SensorRow
from mimucap.session.live.checklist import CheckItem


def _row(sensor_id: str, segment: str | None, rate_hz: float, stale: bool = False) -> SensorRow:
    return SensorRow(sensor_id=sensor_id, segment=segment, rate_hz=rate_hz, drops=3, latency_ms=4.0,
                     battery_pct=math.nan, mag_cal="not calibrated", mag_cal_age_s=math.nan, flags=(),
                     stale=stale, state="stale" if stale else "mag_uncalibrated")


def _subscribed(session) -> dict[str, int]:
    """Event name → number of subscribers, for the events someone listens to."""
    counts = {name: len(getattr(session.events, name).callbacks) for name in session.events.names}
    return {name: count for name, count in counts.items() if count}


@pytest.fixture
def idle_window(qtbot):
    """The main window on the simulated suit, shown but not started: its session never steps,
    so only the events a test emits reach the widgets."""
    window = MainWindow("simulated:demo")
    qtbot.addWidget(window)
    window.show()
    qtbot.waitExposed(window)
    yield window
    window.close()


def test_the_panels_and_the_status_bar_show_the_status_event_and_nothing_else(idle_window, qtbot):
    window = idle_window
    live = window.live
    assert not window._pump.isActive()
    live.events.status.emit([_row("S01", "pelvis", 99.0), _row("S02", None, 50.0, stale=True)])
    panel = window.sensor_panel
    assert panel.rowCount() == 2 and panel.cell_text("S01", "Rate (Hz)") == "99.0"
    assert panel.cell_text("S02", "State") == "STALE: no data"
    assert window.live_status.rate_status.text() == "2 sensors, 74 Hz, 6 drops"
    # the session's state changes underneath; without an event nothing shows it
    live.sensor_rows = lambda: [_row("S09", "head", 10.0)]
    qtbot.wait(700)
    assert panel.rowCount() == 2 and window.live_status.rate_status.text() == "2 sensors, 74 Hz, 6 drops"
    live.publish_status()  # the session tells: now it shows
    assert panel.rowCount() == 1 and panel.cell_text("S09", "Segment") == "Head"


def test_the_hint_pose_status_checklist_and_truth_action_follow_their_events(idle_window, qtbot):
    window = idle_window
    events = window.live.events
    events.pose_source.emit(POSE_UNASSIGNED)
    assert window.scene_view.hint == VIEW_HINTS[POSE_UNASSIGNED]
    assert window.live_status.pose_status.text() == f"Pose: {POSE_UNASSIGNED}"
    events.pose_source.emit(POSE_NONE)
    events.source_problem.emit("cannot open /dev/ttyUSB0")
    assert "cannot open /dev/ttyUSB0" in window.scene_view.hint
    events.truth_errors.emit({"knee_r_flexion_deg": 1.5})   # nothing to judge without a body calibration
    assert window.live_status.pose_status.text() == f"Pose: {POSE_NONE}"
    events.pose_source.emit(POSE_BODY_CALIBRATION)
    events.truth_errors.emit({"knee_r_flexion_deg": 1.5})
    text = window.live_status.pose_status.text()
    assert text.startswith(f"Pose: {POSE_BODY_CALIBRATION}") and "truth" in text
    window.action_truth.setEnabled(False)
    events.truth_available.emit(True)
    assert window.action_truth.isEnabled()
    events.checklist.emit([CheckItem("body", "Body calibration", True, "done, verdict good")])
    label = window.session_panel.checklist_labels["body"]
    assert label.property("ok") and "verdict good" in label.text()
    events.refused.emit({"unknown_address": 5}, {"address 10.0.0.9": 5})
    assert window.live_status.refused_status.text() == "5 packets refused from no known sensor"


def test_changing_the_source_or_closing_leaves_no_subscription_behind(qtbot):
    window = MainWindow("simulated:demo")
    qtbot.addWidget(window)
    window.show()
    window.start()
    qtbot.waitUntil(lambda: window.plots.refresh_count > 2 and window.scene_view.frames_rendered > 2, timeout=15000)
    first = window.live
    listened = _subscribed(first)
    # the widgets and the window follow what they show
    assert {"frame", "data", "status", "checklist", "recording_progress", "marker", "pose_source",
            "source_problem", "refused", "truth_errors", "sensors", "assignment"} <= set(listened)
    assert window.open_source("simulated:walk", interactive=False)
    second = window.live
    assert second is not first and _subscribed(first) == {}
    assert _subscribed(second) == listened  # the same subscriptions, once each
    frames = window.scene_view.frames_rendered
    qtbot.waitUntil(lambda: window.scene_view.frames_rendered > frames + 2, timeout=15000)
    window.close()
    assert _subscribed(second) == {}


def test_the_review_follows_its_player_and_lets_it_go(qtbot, window, calibrated_walk):
    review = window.open_review(calibrated_walk)
    with qtbot.waitSignal(review.loaded, timeout=30000):
        pass
    player = review.player
    assert _subscribed(player) == {"data": 1, "frame": 1}
    qtbot.waitUntil(lambda: not review.plots._redraw_timer.isActive(), timeout=2000)
    qtbot.waitUntil(lambda: review.scene_view.frames_rendered > 0, timeout=5000)  # the first picture shown
    qtbot.wait(100)
    plots, frames = review.plots.refresh_count, review.scene_view.frames_rendered
    qtbot.wait(200)  # paused: the play head stays, nothing is drawn
    assert (review.plots.refresh_count, review.scene_view.frames_rendered) == (plots, frames)
    review.seek(4.0)
    qtbot.waitUntil(lambda: review.plots.refresh_count == plots + 1, timeout=2000)
    assert review.plots.curve_data("acc", 0)[0][-1] == pytest.approx(4.0, abs=0.02)
    qtbot.waitUntil(lambda: review.scene_view.frames_rendered > frames, timeout=2000)
    window.action_truth.setChecked(True)  # View → Show Simulator Truth: live and in Review
    assert _subscribed(player) == {"data": 1, "frame": 1, "truth_frame": 1}
    window.action_close_recording.trigger()
    assert _subscribed(player) == {} and window.review.view is None


def test_a_doubtful_orientation_is_named_in_the_sensor_panel_and_the_status_bar(idle_window):
    window = idle_window
    doubtful = SensorRow(sensor_id="S07", segment="thigh_l", rate_hz=99.0, drops=0, latency_ms=4.0,
                         battery_pct=math.nan, mag_cal="calibrated", mag_cal_age_s=60.0, flags=("magnetic field disturbed",),
                         stale=False, state="ok",
                         doubt="heading taken from a magnetic field that differs from the calibrated one")
    window.live.events.status.emit([doubtful, _row("S01", "pelvis", 99.0)])
    assert window.sensor_panel.cell_text("S07", "State") == (
        "orientation doubtful: heading taken from a magnetic field that differs from the calibrated one")
    assert window.live_status.doubt_status.isVisible()
    assert window.live_status.doubt_status.text() == ("Orientation doubtful — heading taken from a magnetic field that differs "
                                          "from the calibrated one: Left thigh (S07)")
    window.live.events.status.emit([_row("S01", "pelvis", 99.0)])
    assert not window.live_status.doubt_status.isVisible()


def test_the_review_shades_the_doubtful_spans_and_says_why_at_the_play_head(qtbot, tmp_path):
    """A recording without a body calibration: its joint angles are doubtful throughout."""
    from mimucap.cli import main
    from mimucap.gui.review_view import ReviewView

    session = tmp_path / "walk.h5"
    assert main(["simulate", "--scenario", "walk", "--duration", "4", "--no-magcal-turns", "--out", str(session)]) == 0
    review = ReviewView(session)
    qtbot.addWidget(review)
    review.show()
    with qtbot.waitSignal(review.loaded, timeout=30000):
        review.load()
    # Without a body calibration the joint angles are not plotted at all, and the selector says why;
    assert review.plots.joint_angles_refused and not review.plots.selected_joints
    # plotted anyway (as they are with a calibration), their doubtful spans are shaded.
    review.plots.refuse_joint_angles("")
    review.plots.set_joints(["knee_r"])
    review.seek(3.0)
    qtbot.waitUntil(lambda: [end for _start, end in review.plots.doubt_shown("knee_r")] == [pytest.approx(3.0, abs=0.02)],
                    timeout=5000)
    assert review.plots.doubt_shown("knee_r")[0][0] <= 0.1
    assert review._doubt_regions  # on the timeline
    assert review.doubt_status.isVisible() and "Right knee" in review.doubt_status.text()
    assert "no body calibration" in review.doubt_status.text()
    review.shutdown()
