"""Guided N-pose/T-pose calibration on the simulated suit: the result against the simulator's
true mounting rotations, movement restarting a capture, and the refusals."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import SuitSimulator
from mimucap.core.simulate.sensor_errors import error_model
from mimucap.session.procedures.body import BodycalProcedure, BodycalProcedureSettings
from mimucap.session.sources.calibration_feed import SimulatedSuitFeed
from tests.session.settling_feed import SettlingFeed

#: Units with an on-board orientation as good as 0.3° rms (the procedure's own error is then
#: what is measured); everything else of the default error model.
ONBOARD = replace(error_model("default"), onboard_orientation=True, onboard_error_deg=0.3)


def make(seed: int = 1, **kwargs):
    simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=seed, errors=ONBOARD))
    feed = SimulatedSuitFeed(simulator, step_s=0.1)
    mapping = {m.segment: sid for sid, m in simulator.mounting.items()}
    return simulator, feed, BodycalProcedure(feed, mapping, **kwargs)


def mounting_errors_deg(procedure, simulator) -> dict[str, float]:
    cal = procedure.calibration
    return {seg: float(np.degrees(rot.angle_between(cal.q_segment_from_sensor[seg],
                                                    simulator.mounting[sid].q_segment_from_sensor)))
            for seg, sid in cal.sensors.items()}


def run(procedure, limit_s: float = 60.0) -> list:
    statuses = []
    while procedure.phase in ("npose", "tpose"):
        statuses.append(procedure.step())
        assert procedure.feed.time_s < limit_s
    return statuses


@pytest.mark.parametrize("arms, seed", [("both", 1), ("right", 2)])
def test_result_matches_the_true_mountings_within_one_degree(arms, seed) -> None:
    simulator, feed, procedure = make(seed, arms=arms, height_m=1.75)
    procedure.start()
    statuses = run(procedure)
    assert procedure.phase == "result", procedure.refusal
    # Both pages counted down a still, averaged window.
    for pose in ("npose", "tpose"):
        counting = [s.countdown_s for s in statuses if s.pose == pose and s.capturing]
        assert counting and counting[0] > counting[-1]
        assert all(s.still for s in statuses if s.pose == pose and s.capturing)
    t0, t1 = procedure.windows["npose"]
    assert t1 - t0 >= procedure.settings.hold_s
    errors = mounting_errors_deg(procedure, simulator)
    assert len(errors) == 10 and max(errors.values()) < 1.0, errors
    assert procedure.calibration.quality.verdict == "good"
    labels = [label for label, _ in procedure.quality_figures()]
    assert f"{arms if arms != 'both' else 'left'} arm raised" in labels
    assert ("left/right agreement" in labels) == (arms == "both")
    # The calibrated N-pose: every segment parallel to the body frame (within the sway).
    npose = procedure.npose_segment_orientations()
    q_body = procedure.calibration.q_world_from_body
    assert max(float(np.degrees(rot.angle_between(q, q_body))) for q in npose.values()) < 3.0


def test_movement_restarts_the_capture_and_a_restless_subject_is_refused() -> None:
    settings = BodycalProcedureSettings(pose_timeout_s=10.0)
    _, feed, procedure = make(3, settings=settings)
    procedure.start()
    while not procedure.status().capturing:
        procedure.step()
    feed.simulator.set_activity("arm_raise")  # the subject moves during the N-pose capture
    statuses = run(procedure)
    assert any(s.message.startswith("Movement detected: sensor S0") for s in statuses)
    assert max(s.restarts for s in statuses) >= 1
    assert any(not s.still for s in statuses)
    assert procedure.phase == "refused"
    assert procedure.calibration is None
    assert "kept moving during the N-pose" in procedure.refusal
    # Redo with the subject standing still succeeds.
    procedure.redo()
    run(procedure)
    assert procedure.phase == "result"


class _StubbornSubject:
    """A feed whose subject ignores the T-pose request (keeps standing in N-pose)."""

    def __init__(self, feed):
        self._feed = feed
        self.sensor_ids = feed.sensor_ids

    @property
    def time_s(self):
        return self._feed.time_s

    def read(self):
        return self._feed.read()

    def static_orientation(self, sensor_id, acc, mag_raw_uT):
        return self._feed.static_orientation(sensor_id, acc, mag_raw_uT)

    def instruct(self, instruction):
        if instruction.kind != "tpose":
            self._feed.instruct(instruction)


def test_arms_not_raised_are_refused() -> None:
    simulator, feed, _ = make(4)
    mapping = {m.segment: sid for sid, m in simulator.mounting.items()}
    procedure = BodycalProcedure(_StubbornSubject(feed), mapping, arms="left",
                                 settings=BodycalProcedureSettings(pose_timeout_s=5.0))
    procedure.start()
    run(procedure)
    assert procedure.phase == "refused"
    assert "not raised" in procedure.refusal and "left arm" in procedure.refusal


def test_bad_arguments_are_refused() -> None:
    simulator, feed, _ = make()
    mapping = {m.segment: sid for sid, m in simulator.mounting.items()}
    with pytest.raises(ValueError, match="arms"):
        BodycalProcedure(feed, mapping, arms="up")
    with pytest.raises(ValueError, match="height"):
        BodycalProcedure(feed, mapping, height_m=4.0)
    without_right = {k: v for k, v in mapping.items() if not k.endswith("_r")}
    with pytest.raises(ValueError, match="right arm has no sensor"):
        BodycalProcedure(feed, without_right, arms="both")
    with pytest.raises(ValueError, match="S99"):
        BodycalProcedure(feed, {**mapping, "pelvis": "S99"})


def test_the_functional_method_stands_then_walks_and_needs_no_arm_raised() -> None:
    """No T-pose: the still page, then a walk of ``movement_s`` counted down (the simulated
    subject walks as it is told), then every segment within 2.5° of its true mounting."""
    simulator, _, procedure = make(4, method="functional", settings=BodycalProcedureSettings(movement_s=8.0))
    procedure.start()
    statuses = []
    while procedure.phase in ("npose", "movement"):
        statuses.append(procedure.step())
        assert procedure.feed.time_s < 60.0
    assert procedure.phase == "result", procedure.refusal
    counting = [s.countdown_s for s in statuses if s.pose == "movement"]
    assert counting and counting[0] > counting[-1] and "tpose" not in procedure.windows
    still, movement = procedure.windows["npose"], procedure.windows["movement"]
    assert movement[0] > still[1] and movement[1] - still[1] >= 8.0
    errors = mounting_errors_deg(procedure, simulator)
    assert len(errors) == 10 and max(errors.values()) < 2.5, errors
    assert {axis.axis for axis in procedure.calibration.quality.axes} >= {"knee_l", "knee_r", "pelvis", "thorax"}


def test_the_functional_method_needs_no_arm_sensor_and_an_unknown_method_is_refused() -> None:
    simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=1, errors=ONBOARD))
    feed = SimulatedSuitFeed(simulator, step_s=0.1)
    legs = {m.segment: sid for sid, m in simulator.mounting.items() if "arm" not in m.segment}
    with pytest.raises(ValueError, match="the left arm has no sensor"):
        BodycalProcedure(feed, legs)
    assert BodycalProcedure(feed, legs, method="functional").arm_sensors == {}
    with pytest.raises(ValueError, match="method must be one of npose-tpose, functional, got 'walk'"):
        BodycalProcedure(feed, legs, method="walk")


def _settling(until_s: float, **kwargs):
    simulator, feed, _ = make(5)
    mapping = {m.segment: sid for sid, m in simulator.mounting.items()}
    settling = SettlingFeed(feed, mapping["thigh_l"], until_s)  # the feed's clock starts at 0 s
    return settling, BodycalProcedure(settling, mapping, **kwargs)


def test_the_npose_waits_until_no_orientation_is_settling() -> None:
    """A pose captured while a filter still converges on a new magnetometer calibration would make
    every joint angle doubtful: the N-pose page says whose orientation it waits for and captures
    only after it settled, and the calibration is then not doubtful."""
    feed, procedure = _settling(4.0)
    procedure.start()
    statuses = run(procedure)
    assert procedure.phase == "result", procedure.refusal
    assert procedure.windows["npose"][0] >= feed.until_s
    waiting = [s for s in statuses if s.settling_sensor]
    assert waiting and {s.settling_sensor for s in waiting} == {feed.settling_sensor}
    assert all(s.pose == "npose" and not s.capturing and f"left thigh sensor ({feed.settling_sensor})" in s.message
               for s in waiting)
    assert not procedure.calibration.quality.doubtful_sensors


def test_an_orientation_that_never_settles_is_refused_naming_the_sensor() -> None:
    feed, procedure = _settling(1e9, settings=BodycalProcedureSettings(pose_timeout_s=5.0))
    procedure.start()
    run(procedure)
    assert procedure.phase == "refused"
    assert f"the left thigh sensor ({feed.settling_sensor})'s orientation did not settle" in procedure.refusal
