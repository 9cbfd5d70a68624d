"""The simulated subject performs the clinical tests, and the truth's results agree with the motion.

Each scenario's true results (``SimulationResult.protocol``, the session's ``protocol_json``)
come from its design; here they are checked against what the simulated body did: the pelvis
trajectory (distances, speeds, turns), the true hip angle (seated, standing, stands counted) and
the true foot contacts (cadence), on several seeds."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.cli.simulate import check_size
from mimucap.core import phase_markers
from mimucap.core import rotation as rot
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import SuitSimulator, simulate_session

SEEDS = (1, 2, 3)


def run(scenario: str, seed: int, duration_s: float, **params):
    return simulate_session(SimulationConfig(scenario=scenario, duration_s=duration_s, n_sensors=1, seed=seed,
                                             errors="ideal", magcal_turns=True, scenario_params=params))


def index_at(result, t_s: float) -> int:
    return int(np.searchsorted(result.truth.t_s, t_s))


def pelvis_heading_deg(result) -> np.ndarray:
    """Heading (deg, unwrapped) of the pelvis's forward (segment x) axis in the world."""
    forward = rot.rotate(result.truth.q_world_from_segment["pelvis"], np.array([1.0, 0.0, 0.0]))
    return np.degrees(np.unwrap(np.arctan2(forward[:, 1], forward[:, 0])))


@pytest.mark.parametrize("seed", SEEDS)
def test_timed_up_and_go_phases_match_the_motion(seed: int) -> None:
    result = run("tug", seed, 60.0)
    truth = result.protocol
    assert truth["test"] == "tug" and truth["walkway_m"] == 3.0
    parts = ("sit_to_stand_s", "walk_out_s", "turn_s", "walk_back_s", "turn_to_sit_s")
    assert truth["total_s"] == pytest.approx(sum(truth[k] for k in parts))
    assert 7.0 < truth["total_s"] < 20.0 and 1.0 < truth["sit_to_stand_s"] < 2.5
    t0 = truth["start_s"]
    bounds = np.cumsum([t0] + [truth[k] for k in parts])
    hip = result.truth.joint_angles_deg["hip_r_flexion_deg"]
    knee = result.truth.joint_angles_deg["knee_r_flexion_deg"]
    root = result.truth.root_position_m
    heading = pelvis_heading_deg(result)
    seated_start, standing, turn_start, turn_end, last_turn, seated_end = (
        index_at(result, t) for t in (t0 - 0.5, bounds[1], bounds[2], bounds[3], bounds[4], bounds[5] + 0.5))
    assert hip[seated_start] > 85.0 and knee[seated_start] > 85.0  # seated at the start signal
    assert hip[seated_end] > 85.0 and knee[seated_end] > 85.0      # seated again at the end
    assert abs(hip[standing]) < 10.0 and abs(knee[standing]) < 10.0  # upright when the rise ends
    assert root[seated_start, 2] < root[standing, 2] - 0.3          # the pelvis lower on the chair
    # the onset of rising is the start signal: still before, moving after
    assert abs(hip[index_at(result, t0)] - hip[index_at(result, t0 - 1.0)]) < 1.0
    # walk out to the 3-m line and back, turning 180° there and again before sitting
    assert np.abs(root[:turn_start, 1] - root[standing, 1]).max() == pytest.approx(3.0, abs=0.5)
    assert abs(heading[turn_end] - heading[turn_start]) == pytest.approx(180.0, abs=8.0)
    assert abs(heading[turn_start] - heading[index_at(result, bounds[2] - 0.3)]) < 12.0  # pelvis yaw of gait ±5°
    assert abs(heading[index_at(result, bounds[5])] - heading[last_turn]) == pytest.approx(180.0, abs=8.0)
    assert np.hypot(*(root[seated_end, :2] - root[seated_start, :2])) < 0.2  # back on the same chair
    markers = [label for t, label in result.markers if t >= t0 - 1e-9]
    assert markers[:7] == [phase_markers.SIT_TO_STAND, phase_markers.WALK, phase_markers.TURN, phase_markers.WALK, phase_markers.TURN,
                           phase_markers.STAND_TO_SIT, phase_markers.SITTING]


def test_the_subject_differs_by_seed() -> None:
    totals = {seed: SuitSimulator(SimulationConfig(scenario="tug", n_sensors=1, seed=seed)).protocol["total_s"]
              for seed in range(6)}
    speeds = {seed: SuitSimulator(SimulationConfig(scenario="walk10m", n_sensors=1, seed=seed)).protocol["speed_m_s"]
              for seed in range(6)}
    assert len(set(np.round(list(totals.values()), 3))) == 6 and max(totals.values()) - min(totals.values()) > 1.0
    assert max(speeds.values()) - min(speeds.values()) > 0.1


@pytest.mark.parametrize("seed", SEEDS)
def test_ten_metre_walk_speed_and_cadence_match_the_motion(seed: int) -> None:
    result = run("walk10m", seed, 55.0)
    truth = result.protocol
    t0 = truth["start_s"]
    y = result.truth.root_position_m[:, 1]
    t = result.truth.t_s
    after = t >= t0
    crossing = [float(np.interp(d, y[after], t[after])) for d in (2.0, 8.0)]  # the middle 6 m
    assert 6.0 / (crossing[1] - crossing[0]) == pytest.approx(truth["speed_m_s"], rel=0.02)
    contact = result.truth.foot_contact
    timed = (t >= crossing[0]) & (t <= crossing[1])
    strikes = [np.flatnonzero(np.diff((contact[timed, side] > 0.5).astype(int)) == 1) for side in (0, 1)]
    steps = sum(len(s) for s in strikes)
    cadence = 60.0 * steps / (crossing[1] - crossing[0])
    assert cadence == pytest.approx(truth["cadence_steps_min"], rel=0.12)  # whole steps in ~5 s
    assert 0.9 < truth["speed_m_s"] < 1.6 and 90.0 < truth["cadence_steps_min"] < 140.0
    assert y.max() > 10.5  # through the whole walkway, not stopping in it


@pytest.mark.parametrize("seed", (1, 4))
def test_two_minute_walk_distance_matches_the_pelvis_path(seed: int) -> None:
    result = run("walk2min", seed, 165.0, walkway_m=20.0)
    truth = result.protocol
    t = result.truth.t_s
    window = (t >= truth["start_s"]) & (t <= truth["start_s"] + 120.0)
    y_all = result.truth.root_position_m[:, 1]
    y = y_all[window]
    # along the walkway from the start to each turn at its ends, then to the 2 minutes' end
    onsets = [tm for tm, label in result.markers if label == phase_markers.TURN and truth["start_s"] < tm < truth["start_s"] + 120]
    places = [y_all[index_at(result, tm)] for tm in [truth["start_s"], *onsets, truth["start_s"] + 120.0]]
    walked = float(np.abs(np.diff(places)).sum())
    assert walked == pytest.approx(truth["distance_m"], rel=0.02)
    assert truth["speed_m_s"] == pytest.approx(truth["distance_m"] / 120.0)
    assert -0.6 < y.min() and y.max() < 20.0 + 0.6  # within the walkway, turning at its ends
    assert len(onsets) >= 4


@pytest.mark.parametrize("seed", SEEDS)
def test_chair_stands_counted_from_the_hip_angle(seed: int) -> None:
    result = run("chair_stand", seed, 80.0)
    truth = result.protocol
    t0 = truth["start_s"]
    t = result.truth.t_s
    hip = result.truth.joint_angles_deg["hip_r_flexion_deg"]
    # a stand counts once the thigh is more than halfway up (steeper than 45° from vertical) in 30 s
    thigh_axis = rot.rotate(result.truth.q_world_from_segment["thigh_r"], np.array([0.0, 1.0, 0.0]))
    up = np.degrees(np.arccos(np.clip(thigh_axis[:, 2], -1.0, 1.0))) < 45.0
    window = (t >= t0) & (t <= t0 + 30.0)
    ups = np.flatnonzero(np.diff(up[window].astype(int)) == 1)
    assert len(ups) == truth["stands"] and 8 <= truth["stands"] <= 16
    ups_all = t[np.flatnonzero(np.diff(up.astype(int)) == 1)]
    ups_all = ups_all[ups_all >= t0]
    assert np.diff(ups_all[:truth["stands"]]).mean() == pytest.approx(truth["cycle_s"], rel=0.03)
    upright = [hip[index_at(result, tu + 0.6)] for tu in ups_all[:truth["stands"]]]
    assert max(upright) < 15.0  # full stands


def test_the_six_minute_walk_fits_in_memory() -> None:
    simulator = SuitSimulator(SimulationConfig(scenario="walk6min", n_sensors=10, seed=2))
    truth = simulator.protocol
    duration = truth["start_s"] + 360.0 + 2.0
    check_size(duration, 100.0, 10)  # the ten-sensor suit at 100 Hz is within the command's bound
    assert 350.0 < truth["distance_m"] < 560.0 and truth["walkway_m"] == 30.0
    assert truth["speed_m_s"] == pytest.approx(truth["distance_m"] / 360.0)
