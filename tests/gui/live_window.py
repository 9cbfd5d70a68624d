"""A main window on a simulated suit whose time runs faster than the wall clock, calibrated
through both wizards as a user clicks through them (for the end-to-end tests)."""

from __future__ import annotations


from PyQt5 import QtCore

from mimucap.gui.main_window import MainWindow
from mimucap.session.sources.fast_clock import fast_clock
from mimucap.session.live.live_session import open_live_session

SPEED_UP = 4.0


def live_window(qtbot, spec: str):
    clock = fast_clock(SPEED_UP)
    window = MainWindow(spec, session_factory=lambda chosen: open_live_session(chosen, clock=clock))
    window.clock = clock
    window.confirm_recording = lambda items: True  # recording without calibrations, knowingly
    window.show()
    window.start()
    qtbot.waitExposed(window)
    return window


def closed(window) -> None:
    if window.live is not None and window.live.recording:
        window.live.stop_recording()
    window.close()


def calibrate(window, qtbot) -> None:
    """Both wizards, as a user clicks through them; the simulated subject walks on after."""
    live = window.live
    qtbot.waitUntil(lambda: live.samples_received > 200, timeout=10000)
    window.action_magcal.trigger()
    wizard = window._wizard
    qtbot.mouseClick(wizard.start_button, QtCore.Qt.LeftButton)
    qtbot.waitUntil(lambda: wizard.procedure.phase == "result", timeout=60000)
    qtbot.mouseClick(wizard.accept_button, QtCore.Qt.LeftButton)
    assert set(live.mag_calibrations) == set(live.sensor_ids)
    assert not wizard.isVisible()  # every sensor stored: Accept was the last click
    # The 3D view's prompt follows: the body is next.
    from mimucap.gui.live_status_bar import BODY_NEXT_HINT

    qtbot.waitUntil(lambda: window.scene_view.hint == BODY_NEXT_HINT, timeout=5000)
    # The sensors are strapped back on (half a minute in a clinic): the filters, learning the
    # heading from the newly calibrated magnetometers, settle meanwhile.
    settled = window.clock() + 20.0
    qtbot.waitUntil(lambda: window.clock() > settled, timeout=20000)
    window.action_bodycal.trigger()
    wizard = window._wizard
    qtbot.mouseClick(wizard.start_button, QtCore.Qt.LeftButton)
    qtbot.waitUntil(lambda: wizard.procedure.phase in ("result", "refused"), timeout=60000)
    assert wizard.procedure.phase == "result", wizard.procedure.refusal
    qtbot.mouseClick(wizard.accept_button, QtCore.Qt.LeftButton)
    assert live.body_calibration is not None
    qtbot.waitUntil(lambda: live.pose_source == "body calibration", timeout=5000)
    # Now there is a calibration to judge: the on-screen check against the simulator's truth.
    qtbot.waitUntil(lambda: "vs. truth" in window.live_status.pose_status.text(), timeout=10000)
    # The wizard is closed: the simulated subject walks on.
    qtbot.waitUntil(lambda: live.simulator.current_activity().startswith("walk"), timeout=10000)
