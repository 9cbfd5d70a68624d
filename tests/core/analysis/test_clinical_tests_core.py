"""The clinical tests' pure computations on synthetic signals with known answers: segment motion,
chair transitions, trunk turns, the TUG phases, the chair stand, which foot carries the body and
the walking progression (also on the simulator's exact walk: its segment orientations and foot
contacts against its root's path), and the timed walks."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.core import skeleton
from mimucap.core.analysis.chair_stand import chair_stand
from mimucap.core.analysis.chair_transitions import SIT_TO_STAND, STAND_TO_SIT, find_transitions
from mimucap.core.analysis.gait_events import SwingEvents
from mimucap.core.analysis.leg_model import LegChain
from mimucap.core.analysis.progression import progression, stance_weights
from mimucap.core.analysis.segment_motion import flexion_rate_dps, inclination_deg, yaw_rate_dps
from mimucap.core.analysis.trunk_turns import find_trunk_turns
from mimucap.core.analysis.tug import timed_up_and_go
from mimucap.core.analysis.walk_tests import ten_metre_walk, timed_walk, walking_start
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import simulate_session

RATE_HZ = 100.0


def minimum_jerk(x):
    x = np.clip(x, 0.0, 1.0)
    return 10 * x**3 - 15 * x**4 + 6 * x**5


#: An ISB segment upright and facing world +x: x anterior = world x, y up = world z, z right = world -y.
FACING_X = rot.from_matrix(np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]))


def test_inclination_and_rates_of_a_segment():
    t = np.arange(0.0, 2.0, 1.0 / RATE_HZ)
    lean = 30.0 * t  # 30 deg/s sideways, about the segment's own x axis
    q = rot.multiply(rot.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.radians(lean)),
                     np.broadcast_to(FACING_X, (t.shape[0], 4)))
    assert inclination_deg(q) == pytest.approx(lean, abs=1e-4)
    assert flexion_rate_dps(t, q) == pytest.approx(np.zeros_like(t), abs=1e-6)  # no flexion about its z axis
    turning = rot.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.radians(45.0 * t))
    assert yaw_rate_dps(t, turning) == pytest.approx(np.full_like(t, 45.0), rel=1e-6)


def test_a_trunk_leaning_forward_flexes_positively():
    t = np.arange(0.0, 1.0, 1.0 / RATE_HZ)
    lean = rot.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.radians(20.0 * t))  # top towards +x: forward
    q = rot.multiply(lean, np.broadcast_to(FACING_X, (t.shape[0], 4)))
    assert flexion_rate_dps(t, q) == pytest.approx(np.full_like(t, 20.0), rel=1e-6)
    assert inclination_deg(q)[-1] == pytest.approx(20.0 * t[-1], abs=1e-6)


def chair_signals(rises: list[tuple[float, float, float]], end_s: float):
    """Thigh inclination and trunk flexion rate for rises ``(start, duration, sit_start)``:
    thighs 90° → 0° by minimum jerk, trunk leaning forward and back by 30·sin²(πx)."""
    t = np.arange(0.0, end_s, 1.0 / RATE_HZ)
    thigh = np.full_like(t, 90.0)
    lean = np.zeros_like(t)
    for start, duration, sit_start in rises:
        x = (t - start) / duration
        inside = (x > 0) & (x < 1)
        thigh -= 90.0 * minimum_jerk(x)
        lean[inside] += 30.0 * np.sin(np.pi * x[inside]) ** 2
        y = (t - sit_start) / duration
        inside = (y > 0) & (y < 1)
        thigh += 90.0 * minimum_jerk(y)
        lean[inside] += 30.0 * np.sin(np.pi * y[inside]) ** 2
    return t, thigh, np.gradient(lean, t)


def test_chair_transitions_are_found_with_their_trunk_bounds():
    t, thigh, trunk = chair_signals([(2.0, 1.6, 10.0)], 14.0)
    found = find_transitions(t, thigh, trunk)
    assert [tr.kind for tr in found] == [SIT_TO_STAND, STAND_TO_SIT]
    rise, sit = found
    assert rise.mid_s == pytest.approx(2.8, abs=0.01)  # halfway up at half the time (minimum jerk)
    assert sit.mid_s == pytest.approx(10.8, abs=0.01)
    # 5 % of the peak rate: sin(2πx) = 0.05 → x = 0.008 of the movement
    assert rise.start_s == pytest.approx(2.0, abs=0.03) and rise.end_s == pytest.approx(3.6, abs=0.03)
    assert sit.start_s == pytest.approx(10.0, abs=0.03) and sit.end_s == pytest.approx(11.6, abs=0.03)


def test_thighs_moving_without_the_trunk_are_no_transition():
    t, thigh, trunk = chair_signals([(2.0, 1.6, 10.0)], 14.0)
    assert find_transitions(t, thigh, 0.0 * trunk) == []


def test_the_chair_stand_counts_stands_halfway_up_within_30_s():
    period = 2.5
    rises = [(1.0 + k * period, 1.0, 1.0 + k * period + 1.2) for k in range(14)]
    t, thigh, trunk = chair_signals(rises, 40.0)
    found = chair_stand(find_transitions(t, thigh, trunk))
    # the stand k passes halfway at 1.5 + 2.5 k; the test runs 1.0 .. 31.0 s → k = 0 .. 11
    assert found.stands == 12
    assert found.cycle_s == pytest.approx(period, abs=1e-3)
    assert found.start_s == pytest.approx(1.0, abs=0.03)
    later = chair_stand(find_transitions(t, thigh, trunk), start_s=2.0)  # the user's start marker
    assert later.start_s == 2.0 and later.stands == 12  # the stand at 1.5 s is before it, 31.5 s within


def turning(t: np.ndarray, turns: list[tuple[float, float, float]], wobble_dps: float = 0.0) -> np.ndarray:
    """A yaw rate (deg/s) with minimum-jerk turns ``(start, duration, angle)`` and a stride wobble."""
    heading = np.zeros_like(t)
    for start, duration, angle in turns:
        heading += angle * minimum_jerk((t - start) / duration)
    return np.gradient(heading, t) + wobble_dps * np.sin(2.0 * np.pi * 0.9 * t)


def test_trunk_turns_are_found_with_their_angle_and_peak():
    t = np.arange(0.0, 20.0, 1.0 / RATE_HZ)
    found = find_trunk_turns(t, turning(t, [(3.0, 2.0, 180.0), (10.0, 2.5, -180.0)], wobble_dps=4.0))
    assert len(found) == 2
    assert found[0].angle_deg == pytest.approx(180.0, abs=10.0) and found[1].angle_deg == pytest.approx(-180.0, abs=10.0)
    assert found[0].peak_rate_dps == pytest.approx(1.875 * 90.0, rel=0.05)
    for turn, (start, duration) in zip(found, [(3.0, 2.0), (10.0, 2.5)]):
        assert turn.start_s == pytest.approx(start, abs=0.3) and turn.end_s == pytest.approx(start + duration, abs=0.3)
    assert find_trunk_turns(t, turning(t, [(3.0, 2.0, 45.0)])) == []  # a bend of the way is no turn


def test_the_tug_phases_follow_from_the_transitions_and_turns():
    t, thigh, trunk = chair_signals([(2.0, 1.5, 11.0)], 15.0)
    transitions = find_transitions(t, thigh, trunk)
    turns = find_trunk_turns(t, turning(t, [(5.5, 2.0, 180.0), (9.5, 2.0, 180.0)]))
    found = timed_up_and_go(transitions, turns)
    assert found.start_s == pytest.approx(2.0, abs=0.05) and found.end_s == pytest.approx(12.5, abs=0.05)
    expected = {"sit_to_stand_s": 1.5, "walk_out_s": 2.0, "turn_s": 2.0, "walk_back_s": 2.0, "turn_to_sit_s": 3.0}
    for key, value in expected.items():
        assert found.phases[key] == pytest.approx(value, abs=0.15), key
    assert sum(found.phases.values()) == pytest.approx(found.total_s)
    with pytest.raises(ValueError, match="turn"):
        timed_up_and_go(transitions, [])


def events_of(fc: list[float], ic: list[float]) -> SwingEvents:
    return SwingEvents("shank", np.array(fc, dtype=float), np.array(ic, dtype=float),
                       0.5 * (np.array(fc) + np.array(ic)), RATE_HZ, np.zeros(len(ic), dtype=bool))


def test_the_foot_that_landed_last_carries_the_body():
    t = np.arange(0.0, 3.0, 1.0 / RATE_HZ)
    # right swings 0.4-0.8 and 1.4-1.8; left swings 0.9-1.3
    weights = stance_weights(t, {"right": events_of([0.4, 1.4], [0.8, 1.8]), "left": events_of([0.9], [1.3])})
    at = lambda s: weights[int(round(s * RATE_HZ))]  # noqa: E731
    assert at(0.2) == pytest.approx([0.5, 0.5])  # standing, no foot landed yet
    assert at(0.6) == pytest.approx([1.0, 0.0])  # right swings: left carries
    assert at(1.1) == pytest.approx([0.0, 1.0])  # left swings: right carries
    assert at(0.85) == pytest.approx([0.0, 1.0])  # double support: right landed at 0.8, leads
    assert at(1.35) == pytest.approx([1.0, 0.0])  # left landed at 1.3, leads
    assert at(2.5) == pytest.approx([0.0, 1.0])  # stopped on both feet: the last to land


def test_walking_progression_and_the_timed_walks():
    """Legs that alternate: each ankle moves back at 1.2 m/s relative to the root while it
    carries and swings forward at 2.4 m/s; the root walks 1.2 m/s along +y."""
    t = np.arange(0.0, 200.0, 1.0 / RATE_HZ)
    stride = 1.0
    start = 5.0
    ankles = {}
    fc, ic = {"left": [], "right": []}, {"left": [], "right": []}
    for side, shift in (("right", 0.0), ("left", 0.5)):
        phase = ((t - start) / stride - shift) % 1.0
        walking = t >= start + shift * stride
        along = np.where(phase < 2 / 3, 0.4 - 1.2 * stride * phase, 0.4 - 0.8 + 2.4 * stride * (phase - 2 / 3))
        along = np.where(walking, along, 0.4)
        ankles[side] = np.stack((np.zeros_like(t), along, np.full_like(t, -0.9)), axis=-1)
        k = np.arange(0, 195)
        fc[side] = list(start + (k + shift + 2 / 3) * stride)
        ic[side] = list(start + (k + shift + 1) * stride)
    events = {side: events_of(fc[side], ic[side]) for side in ("left", "right")}
    facing = rot.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.full(t.shape[0], math.pi / 2))  # pelvis x → +y
    # Upright shanks and ankles level with each other: the feet land and leave flat (no rocker).
    legs = LegChain(t, ankles, facing, {"left": facing, "right": facing}, skeleton.foot_sole_m(1.75))
    way = progression(legs, events)
    assert way.distance_at(start + 100.0) - way.distance_at(start + 10.0) == pytest.approx(1.2 * 90.0, rel=0.01)
    first = walking_start(events)
    assert first == pytest.approx(start + 2 / 3, abs=1e-6)
    ten = ten_metre_walk(way, events, first)
    assert ten.speed_m_s == pytest.approx(1.2, rel=0.01)
    assert ten.cadence_steps_min == pytest.approx(120.0, rel=0.01)
    walked = timed_walk(way, first, 120.0)
    assert walked.distance_m == pytest.approx(144.0, rel=0.01) and len(walked.minute_distances_m) == 2
    assert walked.last_vs_first_minute_percent == pytest.approx(100.0, abs=1.0)
    with pytest.raises(ValueError, match="before the 360-s test"):
        timed_walk(way, first, 360.0)


def swings_of(t: np.ndarray, on_floor: np.ndarray) -> SwingEvents:
    """The swings of a foot from its contact truth (T,) (final contact → initial contact)."""
    change = np.diff(on_floor.astype(int))
    lifts, lands = t[1:][change == -1], t[1:][change == 1]
    fc = [a for a in lifts if np.any(lands > a)]
    ic = [lands[lands > a][0] for a in fc]
    return events_of(fc, ic)


@pytest.mark.parametrize("seed", [1, 2])
def test_progression_follows_the_simulated_walk(seed: int) -> None:
    """On the simulator's exact walk (segment orientations and foot contacts; its feet roll over
    the heel and the toe) the distance walked matches the root's advance along the walk within
    1 % over the steady strides (the simulator blends into the walk from standing, feet and root
    together, so its first step is no foot's roll)."""
    result = simulate_session(SimulationConfig(scenario="walk", duration_s=14.0, n_sensors=10, errors="ideal",
                                               seed=seed))
    truth = result.truth
    t = np.asarray(truth.t_s, dtype=float)
    legs = LegChain.from_segments(skeleton.load_model(result.model_name), result.height_m, t,
                                  truth.q_world_from_segment)
    events = {side: swings_of(t, truth.foot_contact[:, column] > 0.5) for column, side in enumerate(("left", "right"))}
    way = progression(legs, events)
    root = np.asarray(truth.root_position_m, dtype=float)[:, :2]
    direction = (root[-1] - root[0]) / np.linalg.norm(root[-1] - root[0])
    landings = np.sort(np.concatenate([events[side].t_ic_s for side in events]))
    assert landings.size >= 10
    a, b = np.searchsorted(t, [landings[2], landings[-3]])
    assert way.distance_m[b] - way.distance_m[a] == pytest.approx(float((root[b] - root[a]) @ direction), rel=0.01)
