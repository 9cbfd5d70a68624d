"""The guided ROM protocol with the simulated subject: body calibration from its N/T-pose, each
movement done by the simulator (``rom`` activity), angles through the sensor pipeline
(on-board orientations, calibration, joint angles), compared with the simulator's truth."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mimucap.core import bodycal, skeleton
from mimucap.core.analysis import rom as rom_core
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import SuitSimulator
from mimucap.session.procedures.range_of_motion import RomProcedure, RomStep, default_steps

#: (movement, side) → simulator joint, axis and signed angle (deg).
MOVES = {
    ("shoulder_flexion", "right"): ("shoulder_r", "flexion", 160.0),
    ("shoulder_abduction", "left"): ("shoulder_l", "adduction", -150.0),
    ("elbow_flexion", "right"): ("elbow_r", "flexion", 130.0),
    ("hip_flexion", "left"): ("hip_l", "flexion", 100.0),
    ("hip_abduction", "right"): ("hip_r", "adduction", -35.0),
    ("knee_flexion", "left"): ("knee_l", "flexion", 110.0),
    ("trunk_flexion", "both"): ("lumbar", "flexion", 70.0),
    ("trunk_rotation", "right"): ("lumbar", "rotation", -40.0),
}


def pipeline_poses(block, calibration, model):
    """Segment orientations and joint angles from the block's sensor output (on-board
    orientation of each unit, nearest sample on the first unit's clock)."""
    samples = block.samples
    t = next(iter(samples.values())).t_s
    q = {}
    for sid, s in samples.items():
        index = np.clip(np.searchsorted(s.t_s, t), 0, len(s.t_s) - 1)
        q[sid] = s.q_world_from_sensor[index]
    segments = bodycal.segment_orientations(calibration, q)
    segments = bodycal.fill_missing_segments(segments, [(s.name, s.parent) for s in model.segments])
    return t, segments, skeleton.joint_angles_deg(model, segments)


def test_rom_protocol_on_the_simulated_subject_is_within_two_degrees_of_truth():
    simulator = SuitSimulator(SimulationConfig(scenario="bodycal", n_sensors=10, errors="bno055", seed=4))
    first = simulator.advance(7.0)
    sensors = first.samples
    t0 = sensors["S01"].t_s
    q0 = {sid: s.q_world_from_sensor[np.clip(np.searchsorted(s.t_s, t0), 0, len(s.t_s) - 1)] for sid, s in sensors.items()}
    mapping = {s.segment: sid for sid, s in sensors.items()}
    calibration = bodycal.calibrate_npose_tpose(t0, q0, mapping, (0.5, 2.5), (4.6, 5.9))
    model = simulator.model
    steps = tuple(RomStep(key, side) for key, side in MOVES)
    procedure = RomProcedure(steps, repeats=2)
    truth_results = {}
    for step in steps:
        joint, axis, angle = MOVES[(step.key, step.side)]
        simulator.set_activity("rom", joint=joint, axis=axis, angle_deg=angle, cycles=3)
        assert procedure.state == "ready" and step.title in procedure.instruction
        procedure.start_step(simulator.time_s)
        truth_blocks = []
        for _ in range(200):  # 0.1 s blocks; 2 repetitions take about 8 s
            block = simulator.advance(0.1)
            t, segments, angles = pipeline_poses(block, calibration, model)
            procedure.update(t, angles, segments)
            truth_blocks.append(block.truth)
            if procedure.state == "step_done":
                break
        assert procedure.state == "step_done", f"{step.title}: repetitions not captured"
        assert math.isfinite(procedure.active_angle_deg)
        truth_angles = {c: np.concatenate([b.joint_angles_deg[c] for b in truth_blocks]) for c in truth_blocks[0].joint_angles_deg}
        truth_segments = {s: np.concatenate([b.q_world_from_segment[s] for b in truth_blocks]) for s in truth_blocks[0].q_world_from_segment}
        series = rom_core.movement_series(step.movement, step.side, truth_angles, truth_segments)
        truth_results[(step.key, step.side)] = rom_core.rom_of(step.movement, step.side, series)
        procedure.next_step()
    assert procedure.state == "finished"
    errors = []
    for key, result in procedure.results.items():
        truth = truth_results[key]
        assert result.repetitions == 2
        assert truth.repetitions >= 2
        errors.append(result.active_rom_deg - np.mean(truth.excursions_deg[:2]))
        assert result.active_rom_deg == pytest.approx(np.mean(truth.excursions_deg[:2]), abs=2.0), key
        assert result.peak_deg == pytest.approx(np.mean(truth.peaks_deg[:2]), abs=2.0), key
        # The simulated movement reached the angle asked for (the truth is what it claims).
        assert np.mean(truth.peaks_deg) == pytest.approx(abs(MOVES[key][2]), abs=1.0)
    print("ROM active-ROM errors (deg):", np.round(errors, 2))
    labels = [label for _, label in procedure.markers]
    assert labels[:2] == ["rom:shoulder_flexion:right:start", "rom:shoulder_flexion:right:end"]
    assert len(labels) == 2 * len(steps)


def test_protocol_steps_and_refusals():
    assert len(default_steps()) == 15  # 7 movements × 2 sides + trunk flexion
    procedure = RomProcedure((RomStep("elbow_flexion", "left"),), repeats=1)
    with pytest.raises(RuntimeError):
        procedure.next_step() or procedure.start_step(0.0) or procedure.next_step()
    with pytest.raises(ValueError):
        RomProcedure((RomStep("trunk_flexion", "left"),))
    with pytest.raises(ValueError):
        RomProcedure(repeats=0)
    procedure = RomProcedure((RomStep("elbow_flexion", "left"),), repeats=3)
    procedure.start_step(1.0)
    procedure.skip_step()
    assert procedure.state == "finished" and procedure.markers == [] and procedure.results == {}
