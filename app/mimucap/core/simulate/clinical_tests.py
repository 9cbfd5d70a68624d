"""The standard clinical mobility tests performed by the simulated subject, with their true results.

Scenarios (:data:`CLINICAL_TESTS`, scenario name → result name):

* ``tug``, Timed Up and Go (Podsiadlo & Richardson, "The timed 'Up & Go': a test of basic
  functional mobility for frail elderly persons", 1991): seated, stand up, walk to a line
  ``walkway_m`` (3 m) away, turn 180°, walk back, turn 180° and sit down.
* ``walk10m``, 10-metre walk test: from standing, walk straight through a ``walkway_m`` (10 m)
  walkway and one metre beyond it, then stand; the middle 6 m are timed (Bohannon & Andrews,
  "Normal walking speed: a descriptive meta-analysis", 2011: 2 m to speed up, 2 m to slow down).
* ``walk2min`` and ``walk6min``, 2- and 6-minute walk tests: walking to and fro along a
  ``walkway_m`` (30 m, as the ATS statement "ATS statement: guidelines for the six-minute walk
  test", 2002, advises) with a 180° turn at each end, for the test's minutes and a little beyond.
* ``chair_stand``, 30-second chair stand (Jones, Rikli & Beam, "A 30-s chair-stand test as a
  measure of lower body strength in community-residing older adults", 1999): seated with the
  arms crossed over the chest, stand up fully and sit down again, as often as possible in 30 s.

Each begins, as the demo does, with N-pose 3 s, T-pose 3 s and N-pose 2 s (after the
magnetometer turns when asked), then the subject sits down on the chair (``tug``,
``chair_stand``) or stands (walk tests) before the start signal.

The subject differs by seed (:func:`subject_for_seed`): comfortable walking speed (the stride
duration follows from it and the leg lengths), the durations of rising and sitting down, and
of turning. The true results (:func:`protocol_truth`) follow from the scenario's design, with
the phase boundaries of the instrumented tests:

* TUG (Salarian et al., "iTUG, a sensitive and reliable measure of mobility", 2010): the test
  runs from the onset of the rise (the start signal) to the end of sitting down. Sit-to-stand:
  from the onset of the trunk's forward flexion to standing upright; walk out: from standing
  upright to the onset of the turn at the line; turn: the 180° turn there, from the onset of the
  heading change to its end; walk back: from the end of that turn to the onset of the last turn;
  turn-to-sit: from the onset of the turn in front of the chair to the end of sitting down.
* 10MWT: speed over the middle 6 m (crossing 2 m and 8 m of a 10-m walkway; the timed section
  scales with ``walkway_m``: its middle 60 %), and the cadence (steps per minute) of that walking.
* 2MWT / 6MWT: the distance walked along the walkway in the test's 2 or 6 minutes from the start
  signal (the onset of walking), and its mean speed.
* Chair stand: the number of full stands (standing upright reached) within the 30 s from the
  start signal (the onset of the first rise), a stand more than halfway up at 30 s (the thighs
  past 45° from horizontal) counting as a full stand, as Jones et al. score it; and the mean
  duration of a full sit-stand-sit cycle.

Every phase starts with a marker (:mod:`mimucap.core.phases`: "sitting", "sit-to-stand",
"walk", "turn", "stand-to-sit").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mimucap.core.simulate.activities import NPose, TPose, Turn
from mimucap.core.simulate.chair import ChairTransition, Sit
from mimucap.core.simulate.walking import Walk

#: Scenario name → the name of its result (the ``protocol`` command's test names).
CLINICAL_TESTS = {"tug": "tug", "walk10m": "10mwt", "walk2min": "2mwt", "walk6min": "6mwt",
                  "chair_stand": "chair-stand"}
#: Default walkway length (m) per scenario.
DEFAULT_WALKWAY_M = {"tug": 3.0, "walk10m": 10.0, "walk2min": 30.0, "walk6min": 30.0, "chair_stand": 0.0}
#: Test durations (s) of the timed tests.
TEST_DURATION_S = {"walk2min": 120.0, "walk6min": 360.0, "chair_stand": 30.0}
#: Seconds seated (or standing) still before the start signal.
READY_S = 3.0
_STREAM_SUBJECT = 606


@dataclass(frozen=True)
class TestSubject:
    """How the simulated subject performs: ``speed_mps`` comfortable walking speed,
    ``rise_s``/``sit_s`` durations of standing up and sitting down in the TUG, ``stand_rise_s``/
    ``stand_sit_s``/``stand_pause_s`` those of the chair stand (faster, with a short pause
    standing), ``turn_s`` of a 180° turn."""

    speed_mps: float
    rise_s: float
    sit_s: float
    stand_rise_s: float
    stand_sit_s: float
    stand_pause_s: float
    turn_s: float


def subject_for_seed(seed: int) -> TestSubject:
    """The subject of ``seed``: speed 1.0-1.45 m/s, rising 1.2-2.0 s, sitting 1.4-2.2 s, chair
    stand cycles of 2.0-3.3 s (9-15 stands in 30 s), turning 180° in 1.8-2.8 s (healthy to slow adults)."""
    rng = np.random.default_rng([int(seed) & 0xFFFFFFFF, _STREAM_SUBJECT])
    return TestSubject(
        speed_mps=float(rng.uniform(1.0, 1.45)), rise_s=float(rng.uniform(1.2, 2.0)),
        sit_s=float(rng.uniform(1.4, 2.2)), stand_rise_s=float(rng.uniform(0.9, 1.4)),
        stand_sit_s=float(rng.uniform(1.0, 1.5)), stand_pause_s=float(rng.uniform(0.1, 0.4)),
        turn_s=float(rng.uniform(1.8, 2.8)),
    )


def _lead_in() -> list:
    return [NPose(3.0), TPose(3.0, arms="both"), NPose(2.0)]


def _walk_for(distance_m: float, speed_mps: float) -> Walk:
    """A walk that covers about ``distance_m``: with its blends (1 s in from standing, 1 s out
    into the next activity) the body travels ``speed × duration``."""
    return Walk(distance_m / speed_mps, speed_mps=speed_mps)


#: The parts of a test scenario the simulated subject can be asked for (``part``): the whole
#: scenario; ``prepare``, getting ready and waiting (seated, or standing at the start line) until
#: told to go; ``perform``, the test itself from the start signal on.
PARTS = ("whole", "prepare", "perform")


def clinical_test_activities(name: str, params: dict | None = None, seed: int = 0) -> list:
    """The scenario ``name`` (one of :data:`CLINICAL_TESTS`) as a finite list of activities
    (``prepare``: ending in an endless wait); ``params``: ``walkway_m`` (m) for the walking tests,
    ``part`` (one of :data:`PARTS`, default ``whole``) for a guided test, where the subject
    gets ready when the test is chosen and starts at the start signal."""
    params = dict(params or {})
    walkway = float(params.pop("walkway_m", DEFAULT_WALKWAY_M[name]))
    part = str(params.pop("part", "whole"))
    if params:
        raise ValueError(f"scenario {name!r} takes only walkway_m and part, got {', '.join(params)}")
    if part not in PARTS:
        raise ValueError(f"scenario {name!r}: part must be one of {', '.join(PARTS)}, got {part!r}")
    limits = {"tug": (1.0, 10.0), "walk10m": (4.0, 30.0), "walk2min": (5.0, 60.0), "walk6min": (5.0, 60.0),
              "chair_stand": (0.0, 0.0)}[name]
    if not limits[0] <= walkway <= limits[1]:
        raise ValueError(f"scenario {name!r}: walkway_m must be {limits[0]:g}..{limits[1]:g} m, got {walkway:g}")
    subject = subject_for_seed(seed)
    v = subject.speed_mps
    activities = _lead_in()
    if name == "tug":
        activities += [
            ChairTransition(rise=False, move_s=subject.sit_s), Sit(READY_S),
            ChairTransition(rise=True, move_s=subject.rise_s), _walk_for(walkway, v),
            Turn(angle_deg=180.0, turn_s=subject.turn_s, pause_s=0.0, turns=1), _walk_for(walkway, v),
            Turn(angle_deg=-180.0, turn_s=subject.turn_s, pause_s=0.0, turns=1),
            ChairTransition(rise=False, move_s=subject.sit_s), Sit(),
        ]
    elif name == "walk10m":
        activities += [NPose(READY_S), _walk_for(walkway + 1.0, v), NPose()]
    elif name in ("walk2min", "walk6min"):
        activities.append(NPose(READY_S))
        elapsed = 0.0
        angle = 180.0
        while elapsed < TEST_DURATION_S[name] + 5.0:
            walk = _walk_for(walkway, v)
            activities += [walk, Turn(angle_deg=angle, turn_s=subject.turn_s, pause_s=0.0, turns=1)]
            elapsed += walk.duration_s + subject.turn_s
            angle = -angle
        activities.append(NPose())
    else:  # chair_stand
        activities += [ChairTransition(rise=False, move_s=subject.sit_s, arms_crossed=True),
                       Sit(READY_S, arms_crossed=True)]
        elapsed = 0.0
        while elapsed < TEST_DURATION_S[name] + 4.0:
            activities += [ChairTransition(rise=True, move_s=subject.stand_rise_s, hold_s=subject.stand_pause_s,
                                           arms_crossed=True),
                           ChairTransition(rise=False, move_s=subject.stand_sit_s, arms_crossed=True)]
            elapsed += subject.stand_rise_s + subject.stand_pause_s + subject.stand_sit_s
        activities.append(Sit(arms_crossed=True))
    if part == "whole":
        return activities
    start = _start_signal(activities, name)
    if part == "perform":
        return activities[start:]
    waiting = activities[start - 1]  # seated or standing still for READY_S: now until the start signal
    endless = Sit(arms_crossed=waiting.arms_crossed) if isinstance(waiting, Sit) else NPose()
    return activities[len(_lead_in()):start - 1] + [endless]


def _start_signal(activities: list, name: str) -> int:
    """Index of the activity at whose start the test begins: the first rise from the chair
    (TUG, chair stand) or the first walk."""
    for index, activity in enumerate(activities):
        if name in ("tug", "chair_stand") and isinstance(activity, ChairTransition) and activity.rise:
            return index
        if name not in ("tug", "chair_stand") and isinstance(activity, Walk):
            return index
    raise ValueError(f"scenario {name!r} has no start")


def protocol_truth(name: str, activities: list, params: dict | None = None) -> dict[str, Any]:
    """The true results of clinical test scenario ``name`` for the whole list of ``activities``
    the simulator runs (the magnetometer turns included, walks fitted to the subject's legs),
    keys as the ``protocol`` command writes them, plus ``test`` (the result name), ``start_s``
    (the start signal, session time) and ``walkway_m``."""
    walkway = float(dict(params or {}).get("walkway_m", DEFAULT_WALKWAY_M[name]))
    starts = np.concatenate(([0.0], np.cumsum([a.duration_s or 0.0 for a in activities])))
    first = _start_signal(activities, name)
    truth: dict[str, Any] = {"test": CLINICAL_TESTS[name], "start_s": float(starts[first])}
    if name != "chair_stand":
        truth["walkway_m"] = walkway
    if name == "tug":
        rise, walk_out, turn, walk_back, last_turn, sit = activities[first:first + 6]
        truth.update(
            sit_to_stand_s=rise.duration_s, walk_out_s=walk_out.duration_s, turn_s=turn.turn_s,
            walk_back_s=walk_back.duration_s, turn_to_sit_s=last_turn.turn_s + sit.duration_s,
        )
        truth["total_s"] = float(sum(truth[k] for k in ("sit_to_stand_s", "walk_out_s", "turn_s", "walk_back_s",
                                                         "turn_to_sit_s")))
    elif name == "walk10m":
        walk = activities[first]
        truth.update(speed_m_s=walk.speed, cadence_steps_min=120.0 / walk.stride_s)
    elif name in ("walk2min", "walk6min"):
        duration = TEST_DURATION_S[name]
        distance = 0.0
        t = 0.0
        for activity in activities[first:]:
            if t >= duration:
                break
            if isinstance(activity, Walk):
                within = min(activity.duration_s, duration - t)
                distance += activity.distance_m(within)
            t += activity.duration_s
        truth.update(distance_m=float(distance), speed_m_s=float(distance / duration))
    else:  # chair_stand
        duration = TEST_DURATION_S[name]
        stands = 0
        cycles = []
        t = 0.0
        for rise, sit in zip(activities[first::2], activities[first + 1::2]):
            if not (isinstance(rise, ChairTransition) and rise.rise):
                break
            if duration - t > 0.5 * rise.move_s:
                stands += 1  # up by the end, or more than halfway up (half the rise's time: minimum jerk)
            cycle = rise.duration_s + sit.duration_s
            if t + cycle <= duration:
                cycles.append(cycle)
            t += cycle
        truth.update(stands=stands, cycle_s=float(np.mean(cycles)) if cycles else math.nan)
    return truth
