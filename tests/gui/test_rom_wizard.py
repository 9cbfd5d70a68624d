"""The ROM wizard's wiring: instruction, large angle, repetitions captured, markers set on the
live session, the simulated subject told what to do. The pose comes from a stand-in live
session driven by the simulator (its accuracy through the sensor pipeline is tested in
tests/session/test_rom_procedure.py)."""

from __future__ import annotations

import numpy as np

from mimucap.core import skeleton
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import SuitSimulator
from mimucap.gui.wizards.rom import RomWizard
from mimucap.session.events import EmitterGroup
from mimucap.session.procedures.range_of_motion import RomProcedure, RomStep


class SimulatedLive:
    """The parts of LiveSession the wizard reads, one simulator step (0.04 s) per call, each told
    by a ``frame`` event."""

    def __init__(self) -> None:
        self.events = EmitterGroup("frame", "calibration")
        self.simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=1))
        self.model = self.simulator.model
        self.body_calibration = object()
        self.markers: list[str] = []
        self.time_s = float("nan")
        self.q_world_from_segment = None
        self._angles: dict[str, np.ndarray] = {}
        self.columns = {j: tuple(f"{j}_{a}_deg" for a in ("flexion", "adduction", "rotation"))
                        for j in self.model.joint_names}

    def advance(self) -> None:
        block = self.simulator.advance(0.04)
        self.time_s = float(block.truth.t_s[-1])
        self.q_world_from_segment = {s: q[-1] for s, q in block.truth.q_world_from_segment.items()}
        self._angles = skeleton.joint_angles_deg(self.model, self.q_world_from_segment)
        self.events.frame.emit(self.time_s, None)

    @property
    def joint_names(self):
        return tuple(self.columns)

    def joint_columns(self, joint):
        return self.columns[joint]

    def joint_series(self, joint, window_s):
        values = np.array([[self._angles[c] for c in self.columns[joint]]])
        return np.array([self.time_s]), values

    def instruct(self, instruction) -> None:
        from mimucap.session.sources.feeds import simulated_subject_follows

        simulated_subject_follows(self.simulator, instruction)

    def add_marker(self, label: str) -> float:
        self.markers.append(label)
        return self.time_s


def test_rom_wizard_guides_one_movement(qtbot):
    live = SimulatedLive()
    live.advance()
    wizard = RomWizard(None, live, procedure=RomProcedure((RomStep("elbow_flexion", "right"),), repeats=2))
    qtbot.addWidget(wizard)
    wizard.show()
    assert wizard.step_label.text() == "Elbow flexion, right"
    assert wizard.start_button.isEnabled() and not wizard.next_button.isEnabled()
    wizard.start_button.click()
    assert live.markers == ["rom:elbow_flexion:right:start"]
    largest = 0.0
    for _ in range(400):
        live.advance()  # the wizard takes the pose from the event
        if wizard.angle.text() != "–":
            largest = max(largest, float(wizard.angle.text().rstrip("°")))
        if wizard.procedure.state == "step_done":
            break
    assert wizard.procedure.state == "step_done"
    assert largest > 120.0  # the simulated subject bent the elbow as asked (140°)
    assert live.markers == ["rom:elbow_flexion:right:start", "rom:elbow_flexion:right:end"]
    assert wizard.results.rowCount() == 1 and wizard.results.item(0, 0).text() == "Elbow flexion (right)"
    assert abs(float(wizard.results.item(0, 1).text()) - 140.0) < 3.0
    wizard.next_button.click()
    assert wizard.step_label.text() == "Done"


def test_rom_wizard_waits_for_a_body_calibration(qtbot):
    live = SimulatedLive()
    live.body_calibration = None
    wizard = RomWizard(None, live)
    qtbot.addWidget(wizard)
    live.advance()
    assert "Calibrate the body first" in wizard.instruction.text()
    assert not wizard.start_button.isEnabled()
    live.body_calibration = object()
    live.events.calibration.emit()  # the wizard follows the session's calibration
    assert wizard.start_button.isEnabled()
    wizard.close()
    assert not live.events.frame.callbacks and not live.events.calibration.callbacks


def test_the_assess_menu_opens_the_wizard_on_the_live_session(window, qtbot):
    window.action_rom.trigger()
    wizard = window._wizard
    assert isinstance(wizard, RomWizard) and wizard.isVisible()
    assert wizard.live is window.live
    qtbot.waitUntil(lambda: wizard.step_label.text() != "", timeout=5000)
    wizard.close()
