"""The calibration wizards driven end to end on the simulated suit (pytest-qt, under Xvfb).

The simulated subject performs what each page asks; simulated time runs faster than real
time (each timer tick advances the simulation by a fixed step). Results are checked against
the simulator's truth: the true magnetometer distortion ``A``, ``b`` and the true mounting
rotations ``q_segment_from_sensor``.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import replace

import numpy as np
import pytest
from PyQt5 import QtCore

from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import SuitSimulator
from mimucap.core.simulate.sensor_errors import error_model
from mimucap.gui.wizards import BodyCalibrationWizard, MagnetometerWizard
from mimucap.gui.capture import grab_window
from mimucap.gui.simulated_suit_clock import SimulatedSuitClock
from mimucap.io.calibration_store import CalibrationStore
from mimucap.session.procedures.body import BodycalProcedureSettings
from mimucap.session.sources.calibration_feed import SimulatedSuitFeed
from mimucap.session.sources.feeds import SimulatorFeed as LiveSimulatorFeed
from mimucap.session.live.live_session import LiveSession
from tests.gui.body_wizard_runs import FakeClock, mounting_errors_deg, run_on_live
from tests.session.settling_feed import SettlingFeed

NOW = dt.datetime(2026, 11, 21, 7, 0, tzinfo=dt.timezone.utc)
ONBOARD = replace(error_model("default"), onboard_orientation=True, onboard_error_deg=0.3)


def truth_errors(calibration, parameters) -> tuple[float, float]:
    """Offset error (µT) and soft-iron shape error of a calibration against ``A``, ``b``."""
    product = calibration.soft_iron @ parameters.mag_A
    scale = float(np.mean(np.linalg.svd(product, compute_uv=False)))
    return (float(np.linalg.norm(calibration.offset_uT - parameters.mag_b_uT)),
            float(np.linalg.norm(product / scale - np.eye(3), 2)))


@pytest.fixture
def magnetometer_wizard(qtbot, tmp_path):
    simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=3))
    wizard = MagnetometerWizard.for_simulator(simulator, step_s=0.25, store=CalibrationStore(tmp_path),
                                              tick_ms=1, view_interval_ms=100, now=lambda: NOW)
    qtbot.addWidget(wizard)
    wizard.show()
    qtbot.waitExposed(wizard)
    return simulator, wizard


def test_magnetometer_wizard_calibrates_several_sensors_at_once(qtbot, magnetometer_wizard) -> None:
    simulator, wizard = magnetometer_wizard
    ids = ["S01", "S04", "S07", "S10"]
    wizard.set_selected_sensors(ids)
    assert wizard.protocol() == "single_axis"
    qtbot.mouseClick(wizard.start_button, QtCore.Qt.LeftButton)
    assert wizard.page_name == "recording"
    # The page asks for x first, shows y once x is done, and the live views fill.
    assert wizard.picture.description == "turn about x"
    qtbot.waitUntil(lambda: wizard.procedure.status().axis_to_turn == "y", timeout=20000)
    assert wizard.axis_bars["x"].value() == 100 and wizard.picture.description == "turn about y"
    qtbot.waitUntil(lambda: wizard.view.fit_shown is not None and wizard.view.raw_cloud.count > 200, timeout=20000)
    page = grab_window(wizard).toImage()
    vtk = wizard.view.vtk_widget
    corner = vtk.mapTo(wizard, QtCore.QPoint(0, 0))
    pixels = {page.pixel(corner.x() + x, corner.y() + y)
              for x in range(0, vtk.width(), 7) for y in range(0, vtk.height(), 7)}
    assert len(pixels) > 50  # the 3D view was painted into the page (cloud, ellipsoid, sphere)
    qtbot.waitUntil(lambda: wizard.page_name == "result", timeout=30000)
    for sensor_id in ids:
        outcome = wizard.procedure.outcomes[sensor_id]
        assert outcome.verdict == "good"
        offset_error, shape_error = truth_errors(outcome.result.calibration, simulator.parameters[sensor_id])
        assert offset_error < 0.5 and shape_error < 0.01
    assert wizard.result_table.rowCount() == len(ids)
    qtbot.wait(50)
    assert wizard.result_table.horizontalScrollBar().maximum() == 0  # every column in view
    # Another sensor chosen: the raw view looks at its cloud (another offset), not the first one's.
    offsets = [wizard.procedure.outcomes[s].result.calibration.offset_uT for s in ids[:2]]
    assert np.linalg.norm(offsets[1] - offsets[0]) > 10.0
    wizard.result_table.selectRow(1)
    qtbot.wait(50)
    focal = np.array(wizard.view.raw_renderer.GetActiveCamera().GetFocalPoint())
    assert np.linalg.norm(focal - offsets[1]) < 2.0, (focal, offsets)
    assert wizard.accept_button.isEnabled()
    with qtbot.waitSignal(wizard.calibrations_accepted) as accepted:
        qtbot.mouseClick(wizard.accept_button, QtCore.Qt.LeftButton)
    assert [c.sensor_id for c in accepted.args[0]] == ids
    assert wizard.store.sensor_ids() == sorted(ids)
    assert "calibrated just now (good)" in wizard.sensor_list.item(0).text()
    assert not wizard.isVisible()  # every sensor stored: nothing left to do in the wizard


def test_enter_starts_the_magnetometer_wizard_instead_of_closing_it(qtbot, magnetometer_wizard) -> None:
    _, wizard = magnetometer_wizard
    wizard.sensor_list.setFocus()
    qtbot.keyClick(wizard.sensor_list, QtCore.Qt.Key_Return)
    assert wizard.isVisible() and wizard.page_name == "recording"
    assert not wizard.finish_button.isDefault()  # Enter while turning neither finishes nor cancels


def test_magnetometer_wizard_refuses_a_one_axis_capture(qtbot, magnetometer_wizard) -> None:
    _, wizard = magnetometer_wizard
    wizard.set_selected_sensors(["S02", "S03"])
    qtbot.mouseClick(wizard.start_button, QtCore.Qt.LeftButton)
    qtbot.waitUntil(lambda: wizard.axis_bars["x"].value() == 100, timeout=20000)
    wizard.feed.simulator.set_activity("npose")  # the user stops after one axis and presses "Compute now"
    qtbot.mouseClick(wizard.finish_button, QtCore.Qt.LeftButton)
    assert wizard.page_name == "result"
    assert not wizard.accept_button.isEnabled()
    assert "failed for Thorax sensor (S02), Left upper arm sensor (S03)" in wizard.result_title.text()
    details = wizard.result_details.toPlainText()
    assert "turn about y again" in details and "turn about z again" in details
    assert wizard.result_table.item(0, 1).text().startswith("Failed")
    qtbot.mouseClick(wizard.redo_button, QtCore.Qt.LeftButton)
    assert wizard.page_name == "setup" and wizard.store.sensor_ids() == []


class FakeLiveSession:
    """Stands in for the main window's pipeline: receives the accepted body calibration."""

    def __init__(self) -> None:
        self.applied = []

    def apply_body_calibration(self, calibration) -> None:
        self.applied.append(calibration)


def body_wizard(qtbot, seed: int, settings=BodycalProcedureSettings(), live=None):
    simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=seed, errors=ONBOARD))
    feed = SimulatedSuitFeed(simulator, step_s=0.1)
    wizard = BodyCalibrationWizard(None, live, feed=feed, model=simulator.model, settings=settings,
                                   mapping={m.segment: sid for sid, m in simulator.mounting.items()})
    SimulatedSuitClock(feed, 1, wizard)
    qtbot.addWidget(wizard)
    wizard.show()
    qtbot.waitExposed(wizard)
    return simulator, wizard


def test_body_wizard_matches_the_true_mountings_and_applies_the_result(qtbot) -> None:
    live = FakeLiveSession()
    simulator, wizard = body_wizard(qtbot, seed=6, live=live)
    assert wizard.height_spin.value() == pytest.approx(1.75)
    wizard.set_arms("right")
    qtbot.mouseClick(wizard.start_button, QtCore.Qt.LeftButton)
    assert wizard.page_name == "pose" and wizard.pose_picture.description == "N-pose"
    qtbot.waitUntil(lambda: wizard.countdown.text().endswith(" s") and wizard.meter.property("still"), timeout=10000)
    qtbot.waitUntil(lambda: wizard.pose_picture.description == "T-pose (right arm)", timeout=10000)
    qtbot.waitUntil(lambda: wizard.page_name == "result", timeout=20000)
    calibration = wizard.procedure.calibration
    errors = mounting_errors_deg(calibration, simulator)
    assert len(errors) == 10 and max(errors) < 1.0
    assert "good" in wizard.verdict_label.text()
    assert wizard.figures_table.rowCount() >= 4
    assert wizard.scene.last_geometry is not None  # the skeleton in the calibrated N-pose
    with qtbot.waitSignal(wizard.calibration_accepted):
        qtbot.mouseClick(wizard.accept_button, QtCore.Qt.LeftButton)
    assert live.applied == [calibration]


def test_body_wizard_without_a_tpose_calibrates_from_a_walk(qtbot) -> None:
    """The "no T-pose" path: the simulated subject stands still, then walks as the page asks;
    the functional calibration (the code of ``mimucap bodycal --method functional``) gives every
    segment within 2° of its true mounting, and the result names each axis' verdict in words."""
    live = FakeLiveSession()
    simulator, wizard = body_wizard(qtbot, seed=6, live=live)
    wizard.set_method("functional")
    assert not wizard.arms_combo.isEnabled()
    qtbot.mouseClick(wizard.start_button, QtCore.Qt.LeftButton)
    assert wizard.page_name == "pose" and "stand still" in wizard.pose_title.text()
    qtbot.waitUntil(lambda: "walk" in wizard.pose_title.text(), timeout=10000)
    assert wizard.pose_instruction.text().startswith("Walk a few steps")
    qtbot.waitUntil(lambda: simulator.current_activity() == "walk", timeout=5000)
    qtbot.waitUntil(lambda: wizard.page_name == "result", timeout=30000)
    calibration = wizard.procedure.calibration
    assert calibration.quality.method == "functional"
    errors = mounting_errors_deg(calibration, simulator)
    assert len(errors) == 10 and max(errors) < 2.5, errors
    rows = {wizard.figures_table.item(row, 0).text(): wizard.figures_table.item(row, 1).text()
            for row in range(wizard.figures_table.rowCount())}
    assert rows["Left knee axis"].startswith("good: it bent") and "moved as a hinge" in rows["Right knee axis"]
    assert rows["Pelvis forward direction"].startswith("good: it faces the walking direction")
    assert "standing still" in wizard.verdict_label.text()
    with qtbot.waitSignal(wizard.calibration_accepted):
        qtbot.mouseClick(wizard.accept_button, QtCore.Qt.LeftButton)
    assert live.applied == [calibration]


def test_body_wizard_without_a_tpose_refuses_a_subject_who_did_not_walk(qtbot) -> None:
    """A subject who stays standing: no joint bent, so no axis and no forward direction."""
    _, wizard = body_wizard(qtbot, seed=7, settings=BodycalProcedureSettings(movement_s=4.0))
    wizard.set_method("functional")
    wizard.feed.instruct = lambda instruction: None  # the subject ignores the instructions
    qtbot.mouseClick(wizard.start_button, QtCore.Qt.LeftButton)
    qtbot.waitUntil(lambda: wizard.page_name == "refused", timeout=30000)
    assert "no knee or elbow flexion axis" in wizard.refusal_label.text()


def test_enter_starts_the_body_wizard(qtbot) -> None:
    _, wizard = body_wizard(qtbot, seed=6)
    wizard.height_spin.setFocus()
    qtbot.keyClick(wizard.height_spin, QtCore.Qt.Key_Return)
    assert wizard.isVisible() and wizard.page_name == "pose"


def test_body_wizard_refuses_a_subject_moving_during_the_npose(qtbot) -> None:
    _, wizard = body_wizard(qtbot, seed=7, settings=BodycalProcedureSettings(pose_timeout_s=8.0))
    qtbot.mouseClick(wizard.start_button, QtCore.Qt.LeftButton)
    qtbot.waitUntil(lambda: wizard.procedure.status().capturing, timeout=10000)
    wizard.feed.simulator.set_activity("arm_raise")
    qtbot.waitUntil(lambda: wizard.movement_message.text().startswith("Movement detected"), timeout=10000)
    assert not wizard.meter.property("still")
    qtbot.waitUntil(lambda: wizard.page_name == "refused", timeout=20000)
    assert "kept moving during the N-pose" in wizard.refusal_label.text()
    assert wizard.procedure.calibration is None


def test_body_wizard_says_whose_orientation_it_waits_for_before_the_npose(qtbot) -> None:
    simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=5, errors=ONBOARD))
    inner = SimulatedSuitFeed(simulator, step_s=0.1)
    mapping = {m.segment: sid for sid, m in simulator.mounting.items()}
    feed = SettlingFeed(inner, mapping["thigh_l"], 4.0)
    wizard = BodyCalibrationWizard(None, None, feed=feed, model=simulator.model, mapping=mapping)
    SimulatedSuitClock(inner, 1, wizard)
    qtbot.addWidget(wizard)
    wizard.show()
    qtbot.waitExposed(wizard)
    qtbot.mouseClick(wizard.start_button, QtCore.Qt.LeftButton)
    qtbot.waitUntil(lambda: wizard.countdown.text() == "settling", timeout=10000)
    assert (f"the left thigh sensor ({feed.settling_sensor})'s orientation is still settling"
            in wizard.movement_message.text())
    assert wizard.movement_message.isVisible()
    qtbot.waitUntil(lambda: wizard.page_name == "result", timeout=30000)
    assert wizard.procedure.windows["npose"][0] >= feed.until_s


def test_body_wizard_on_the_main_windows_live_session(qtbot, tmp_path) -> None:
    """Opened as the main window does, ``(parent, live_session)``: the wizard reads the
    session's blocks while the session is stepped (here by a timer on a fake clock that runs
    faster than the wall clock), and Accept applies the result to the session."""
    clock = FakeClock()
    config = SimulationConfig(scenario="npose", n_sensors=10, seed=8, errors=ONBOARD)
    live = LiveSession(LiveSimulatorFeed(config, clock=clock), clock=clock)
    live.start()
    magnetometer = MagnetometerWizard(None, live, store=CalibrationStore(tmp_path))
    qtbot.addWidget(magnetometer)
    assert magnetometer.feed.sensor_ids == live.sensor_ids
    magnetometer.close()

    wizard = BodyCalibrationWizard(None, live)
    qtbot.addWidget(wizard)
    assert wizard.height_spin.value() == pytest.approx(live.height_m)
    assert wizard.mapping()["upper_arm_r"] == "S04"
    wizard.show()
    run_on_live(qtbot, wizard, live, clock)
    assert wizard.page_name == "result", wizard.refusal_label.text()
    simulator = live.simulator
    calibration = wizard.procedure.calibration
    errors = mounting_errors_deg(calibration, simulator)
    assert max(errors) < 1.0
    qtbot.mouseClick(wizard.accept_button, QtCore.Qt.LeftButton)
    assert live.body_calibration is calibration
