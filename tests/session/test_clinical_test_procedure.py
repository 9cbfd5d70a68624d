"""The guided clinical test's procedure: countdown and start signal, the clinician's own start
and stop, and the end of each kind of test found from the thighs (synthetic poses with known
answers: seated, standing, walking)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mimucap.core import phases
from mimucap.core import rotation as rot
from mimucap.session import instructions
from mimucap.session.clinical_test_procedure import (
    COUNTDOWN_S, END_MARGIN_S, GO_SIGNAL, GUIDES, STILL_S, ClinicalTestProcedure,
)

RATE_HZ = 50.0


def _thighs(inclination_deg: float) -> dict[str, np.ndarray]:
    """Both thighs (long axis y) at ``inclination_deg`` from the world vertical (z, ENU): a turn
    about the world x axis by 90° stands the thigh upright, less tips it."""
    q = rot.from_rotvec(np.array([math.radians(90.0 - inclination_deg), 0.0, 0.0]))
    return {"thigh_l": q, "thigh_r": q}


def _run(procedure, t0: float, seconds: float, inclination) -> float:
    """Feed ``seconds`` of poses from ``t0`` (``inclination(t)`` deg); the time reached (at the
    end, or when the state changed to done)."""
    t = t0
    for t in np.arange(t0, t0 + seconds, 1.0 / RATE_HZ):
        procedure.update(float(t), _thighs(inclination(t)))
        if procedure.state == "done":
            break
    return float(t)


def _started(test: str) -> ClinicalTestProcedure:
    procedure = ClinicalTestProcedure(test)
    procedure.start_countdown(10.0)
    assert procedure.countdown_left_s(11.2) == pytest.approx(COUNTDOWN_S - 1.2)
    assert procedure.update(10.0 + COUNTDOWN_S, None) and procedure.state == "running"
    assert procedure.markers == [(10.0 + COUNTDOWN_S, GO_SIGNAL)]
    return procedure


def test_the_timed_up_and_go_ends_once_the_subject_sits_still_again():
    procedure = _started("tug")
    go = procedure.go_s
    # Seated 1 s, rises, 10 s up and walking, sits down again and stays.
    end = _run(procedure, go, 1.0, lambda t: 90.0)
    assert procedure.state == "running"  # seated before rising: not the end
    end = _run(procedure, end, 11.0, lambda t: 5.0 + 20.0 * math.sin(4.0 * t))
    assert procedure.state == "running"
    end = _run(procedure, end, 5.0, lambda t: 88.0)
    assert procedure.state == "done" and procedure.ended_by == "sensors: seated again"
    assert end - (go + 12.0) == pytest.approx(STILL_S, abs=0.1)


def test_the_ten_metre_walk_ends_once_the_subject_stands_still_again():
    procedure = _started("10mwt")
    go = procedure.go_s
    end = _run(procedure, go, 3.0, lambda t: 2.0)  # standing before walking: not the end
    assert procedure.state == "running"
    end = _run(procedure, end, 8.0, lambda t: 20.0 * math.sin(2.0 * math.pi * t))
    assert procedure.state == "running"
    _run(procedure, end, 5.0, lambda t: 2.0)
    assert procedure.state == "done" and procedure.ended_by == "sensors: standing still again"


@pytest.mark.parametrize("test", ["2mwt", "6mwt", "chair-stand"])
def test_a_timed_test_ends_its_time_after_the_start_signal(test):
    procedure = _started(test)
    duration = GUIDES[test].duration_s
    assert procedure.remaining_s(procedure.go_s + 10.0) == pytest.approx(duration - 10.0)
    procedure.update(procedure.go_s + duration + END_MARGIN_S - 0.1, None)
    assert procedure.state == "running"
    procedure.update(procedure.go_s + duration + END_MARGIN_S, None)
    assert procedure.state == "done" and procedure.ended_by == "time"


def test_the_clinicians_start_and_stop_are_markers_the_analysis_takes():
    procedure = _started("tug")
    procedure.mark_start(14.0)
    procedure.stop(25.0)
    assert procedure.markers[1:] == [(14.0, phases.TEST_START), (25.0, phases.TEST_STOP)]
    assert procedure.state == "done" and procedure.ended_by == "stopped by the clinician"


def test_settings_and_instructions_follow_the_test():
    tug = ClinicalTestProcedure("tug")
    assert tug.metadata() == {"test": "tug", "name": "Timed Up and Go", "guided": True, "walkway_m": 3.0,
                              "chair_height_cm": 43.0}
    assert tug.instruction().kind == instructions.PREPARE_TEST and "Sit" in tug.instruction().text
    walk = ClinicalTestProcedure("6mwt", walkway_m=25.0)
    assert walk.metadata()["walkway_m"] == 25.0 and walk.metadata()["duration_s"] == 360.0
    assert "chair_height_cm" not in walk.metadata()
    with pytest.raises(ValueError, match="walkway must be 1 to 100 m"):
        ClinicalTestProcedure("10mwt", walkway_m=0.2)
    with pytest.raises(ValueError, match="unknown clinical test"):
        ClinicalTestProcedure("sprint")
