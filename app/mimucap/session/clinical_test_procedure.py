"""A standard clinical test run guided in the window (no Qt): what to prepare and say, the
countdown and start signal, and when the test is over.

The procedure does not compute the result. It records the test as a session with the test's
settings in the session's metadata (:meth:`ClinicalTestProcedure.metadata`, key
:data:`METADATA_KEY`) and its markers, and the result is computed afterwards from that session
file by :func:`mimucap.session.clinical_tests.run_clinical_test`, the one path the
``protocol`` command also takes. The start of the test is found there from the sensors (rising
from the chair, the first step); the start signal is only a marker (:data:`GO_SIGNAL`). The
clinician can override: :meth:`~ClinicalTestProcedure.mark_start` sets the
:data:`~mimucap.core.phases.TEST_START` marker, and :meth:`~ClinicalTestProcedure.stop` the
:data:`~mimucap.core.phases.TEST_STOP` marker, which the analysis takes in place of what the
sensors show.

The recording ends by itself when the test is over:

* timed tests (2- and 6-minute walks, 30-second chair stand): the test's time after the start
  signal, plus :data:`END_MARGIN_S` (the sensors find the start a moment after the signal);
* Timed Up and Go: once the subject, having stood up, sits still on the chair again for
  :data:`STILL_S` (thighs more than :data:`SEATED_DEG` from vertical);
* 10-metre walk: once the subject, having walked, stands still again for :data:`STILL_S`
  (thighs within :data:`UPRIGHT_DEG` of vertical and moving less than :data:`STILL_RANGE_DEG`).

Each step is also an instruction to the live session (:mod:`mimucap.session.instructions`):
the person reads it, the simulated subject does it.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from mimucap.core import phases
from mimucap.core.analysis.segment_motion import inclination_deg
from mimucap.session import instructions
from mimucap.session.clinical_tests import TEN_METRE_WALKWAY_M, TEST_NAMES, WALK_DURATION_S

#: Session metadata key of a guided test's settings.
METADATA_KEY = "clinical_test"
#: Marker at the start signal ("Go!"): when the subject was told to start.
GO_SIGNAL = "go signal"
#: Seconds counted down before the start signal.
COUNTDOWN_S = 3.0
#: Seconds recorded after a timed test's time is up.
END_MARGIN_S = 5.0
#: Seconds seated or standing still that end an untimed test.
STILL_S = 2.0
#: Thigh inclination (deg from vertical) above which the subject sits, below which it stands.
SEATED_DEG = 60.0
UPRIGHT_DEG = 25.0
#: Thigh inclination range (deg) within :data:`STILL_S` below which the legs are still, and
#: above which within one second they walk.
STILL_RANGE_DEG = 5.0
WALKING_RANGE_DEG = 15.0
#: Chair seat height (cm) the tests' authors used (Jones, Rikli & Beam 1999: 17 inches;
#: Podsiadlo & Richardson 1991: a standard arm chair of about 46 cm).
DEFAULT_CHAIR_HEIGHT_CM = 43.0

STATES = ("ready", "countdown", "running", "done")


@dataclass(frozen=True)
class TestGuide:
    """What the clinician prepares (``setup``), says to the subject (``say``) and how the
    subject starts (``start_position``: ``seated`` or ``standing``); ``duration_s`` of a timed
    test (None: the subject's own time); ``walkway`` whether a walkway length is set, and
    ``chair`` whether a chair is used."""

    test: str
    setup: str
    say: str
    start_position: str
    duration_s: float | None
    walkway: bool
    chair: bool

    @property
    def name(self) -> str:
        return TEST_NAMES[self.test]


GUIDES: dict[str, TestGuide] = {
    "tug": TestGuide(
        "tug", "Place a chair with arm rests against a wall and mark a line on the floor 3 m in front of it. "
        "The subject sits with the back against the chair, wearing the usual footwear (and walking aid, if any).",
        "“When I say go, stand up, walk to the line at your normal pace, turn, walk back to the chair and "
        "sit down again.”", "seated", None, True, True),
    "10mwt": TestGuide(
        "10mwt", "Mark a straight walkway (10 m, with 2 m more at each end to speed up and slow down). "
        "The subject stands at the start of the walkway.",
        "“When I say go, walk at your comfortable speed past the far end of the walkway, then stop.”",
        "standing", None, True, False),
    "2mwt": TestGuide(
        "2mwt", "Mark a straight corridor (30 m) with a cone at each end. The subject stands at one end.",
        "“Walk as far as you can for two minutes, to and fro along the corridor, turning around the cones. "
        "You may slow down and rest if you need to. Start when I say go.”", "standing",
        WALK_DURATION_S["2mwt"], True, False),
    "6mwt": TestGuide(
        "6mwt", "Mark a straight corridor (30 m) with a cone at each end (ATS 2002 guideline). The subject "
        "stands at one end, rested.",
        "“Walk as far as possible for six minutes, to and fro along the corridor, turning around the cones. "
        "You may slow down and rest if you need to. Start when I say go.”", "standing",
        WALK_DURATION_S["6mwt"], True, False),
    "chair-stand": TestGuide(
        "chair-stand", "Place a chair without arm rests (seat about 43 cm high) against a wall. The subject "
        "sits in the middle of the seat, feet flat on the floor, arms crossed over the chest.",
        "“When I say go, stand up fully and sit down again, as many times as you can in 30 seconds, "
        "keeping your arms crossed.”", "seated", 30.0, False, True),
}


class ClinicalTestProcedure:
    """One guided run of clinical test ``test`` (a key of :data:`GUIDES`), with its walkway
    (m; the test's default when None) and chair seat height (cm).

    Time ``t`` is the live session's time (s). The caller (the wizard) records while the
    procedure is past ``ready``, adds :attr:`markers` to the recording as they appear, gives the
    subject each :meth:`instruction`, and stops recording when :attr:`state` becomes ``done``."""

    def __init__(self, test: str, walkway_m: float | None = None, chair_height_cm: float | None = None) -> None:
        if test not in GUIDES:
            raise ValueError(f"unknown clinical test {test!r}; use one of {', '.join(GUIDES)}")
        self.guide = GUIDES[test]
        default_walkway = {"tug": 3.0, "10mwt": TEN_METRE_WALKWAY_M, "2mwt": 30.0, "6mwt": 30.0}.get(test, 0.0)
        self.walkway_m = float(default_walkway if walkway_m is None else walkway_m)
        if self.guide.walkway and not 1.0 <= self.walkway_m <= 100.0:
            raise ValueError(f"the walkway must be 1 to 100 m, got {self.walkway_m:g} m")
        self.chair_height_cm = float(DEFAULT_CHAIR_HEIGHT_CM if chair_height_cm is None else chair_height_cm)
        if self.guide.chair and not 30.0 <= self.chair_height_cm <= 70.0:
            raise ValueError(f"the chair seat must be 30 to 70 cm high, got {self.chair_height_cm:g} cm")
        self.state = "ready"
        #: (t_s, label) markers to put in the recording, in order
        self.markers: list[tuple[float, str]] = []
        self.countdown_started_s = math.nan
        self.go_s = math.nan
        self.ended_by = ""
        self._history: deque[tuple[float, float]] = deque()  # (t, mean thigh inclination deg)
        self._left_start = False  # stood up (TUG) or walked (10MWT) since the start signal

    @property
    def test(self) -> str:
        return self.guide.test

    def metadata(self) -> dict[str, Any]:
        """The settings the recording keeps (metadata key :data:`METADATA_KEY`)."""
        settings: dict[str, Any] = {"test": self.test, "name": self.guide.name, "guided": True}
        if self.guide.walkway:
            settings["walkway_m"] = self.walkway_m
        if self.guide.chair:
            settings["chair_height_cm"] = self.chair_height_cm
        if self.guide.duration_s is not None:
            settings["duration_s"] = self.guide.duration_s
        return settings

    def instruction(self) -> instructions.Instruction:
        """What the subject is asked to do in the current state."""
        walkway = self.walkway_m if self.guide.walkway else 0.0
        if self.state in ("running", "done"):
            return instructions.perform_test(self.test, "Go!", walkway)
        position = "Sit on the chair" if self.guide.start_position == "seated" else "Stand at the start line"
        return instructions.prepare_test(self.test, f"{position} and wait for the start signal", walkway)

    # -- the run --------------------------------------------------------------------------------
    def start_countdown(self, t_s: float) -> None:
        if self.state != "ready":
            raise ValueError(f"the countdown starts from 'ready', not from {self.state!r}")
        self.state = "countdown"
        self.countdown_started_s = float(t_s)

    def countdown_left_s(self, t_s: float) -> float:
        """Seconds to the start signal (0 once given)."""
        if self.state != "countdown":
            return 0.0
        return max(COUNTDOWN_S - (float(t_s) - self.countdown_started_s), 0.0)

    def elapsed_s(self, t_s: float) -> float:
        """Seconds since the start signal (0 before it)."""
        return 0.0 if not math.isfinite(self.go_s) else max(float(t_s) - self.go_s, 0.0)

    def remaining_s(self, t_s: float) -> float | None:
        """Seconds left of a timed test (None for an untimed one)."""
        if self.guide.duration_s is None:
            return None
        return max(self.guide.duration_s - self.elapsed_s(t_s), 0.0)

    def update(self, t_s: float, q_world_from_segment: dict[str, np.ndarray] | None) -> bool:
        """Advance to time ``t_s`` with the newest segment orientations (segment → (4,) or
        (1, 4); None before the body calibration); True when the state changed (the start
        signal was given, or the test is over)."""
        t = float(t_s)
        if self.state == "countdown" and self.countdown_left_s(t) <= 0.0:
            self.state = "running"
            self.go_s = t
            self.markers.append((t, GO_SIGNAL))
            return True
        if self.state != "running":
            return False
        if self.guide.duration_s is not None:
            if self.elapsed_s(t) >= self.guide.duration_s + END_MARGIN_S:
                return self._end("time")
            return False
        thighs = [np.asarray(q_world_from_segment[s], dtype=float).reshape(-1, 4)[-1]
                  for s in ("thigh_l", "thigh_r") if q_world_from_segment and s in q_world_from_segment]
        if not thighs:
            return False
        self._history.append((t, float(np.mean(inclination_deg(np.array(thighs))))))
        while self._history and self._history[0][0] < t - max(STILL_S, 1.0):
            self._history.popleft()
        return self._check_end(t)

    def _check_end(self, t: float) -> bool:
        times = np.array([h[0] for h in self._history])
        angles = np.array([h[1] for h in self._history])
        recent = angles[times >= t - 1.0]
        if self.test == "tug":
            self._left_start |= bool(angles[-1] < UPRIGHT_DEG)
            seated = bool(np.all(angles > SEATED_DEG))
            if self._left_start and seated and times[-1] - times[0] >= STILL_S - 0.05:
                return self._end("sensors: seated again")
            return False
        self._left_start |= bool(np.ptp(recent) > WALKING_RANGE_DEG)
        still = bool(np.ptp(angles) < STILL_RANGE_DEG and np.all(angles < UPRIGHT_DEG))
        if self._left_start and still and times[-1] - times[0] >= STILL_S - 0.05:
            return self._end("sensors: standing still again")
        return False

    def _end(self, why: str) -> bool:
        self.state = "done"
        self.ended_by = why
        return True

    def mark_start(self, t_s: float) -> None:
        """The clinician's start: overrides the start the sensors show."""
        if self.state != "running":
            raise ValueError("the start can be marked once the test runs")
        self.markers.append((float(t_s), phases.TEST_START))

    def stop(self, t_s: float) -> None:
        """The clinician's stop: ends the test now, and the analysis ends it here."""
        if self.state not in ("countdown", "running"):
            raise ValueError(f"no test is running (state {self.state!r})")
        if self.state == "running":
            self.markers.append((float(t_s), phases.TEST_STOP))
        self.state = "done"
        self.ended_by = "stopped by the clinician"
