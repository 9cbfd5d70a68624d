"""The standard clinical tests of a reviewed session (no Qt): Timed Up and Go, the 10-metre walk,
the 2- and 6-minute walks and the 30-second chair stand, with their published references.

The results come from the sensors alone, through the one processing path: the review
(:func:`mimucap.session.recorded.review.build_review`: raw samples, magnetometer calibration, filter,
body calibration, segment orientations) gives the trunk (thorax, else pelvis), thighs, shanks
and pelvis, and the foot or shank sensors' sagittal rates (as the gait analysis picks them,
:func:`mimucap.session.recorded.analysis.gait_inputs`); the pure computations are in
:mod:`mimucap.core.analysis` (:mod:`~mimucap.core.analysis.chair_transitions`,
:mod:`~mimucap.core.analysis.trunk_turns`, :mod:`~mimucap.core.analysis.tug`,
:mod:`~mimucap.core.analysis.progression`, :mod:`~mimucap.core.analysis.walk_tests`,
:mod:`~mimucap.core.analysis.chair_stand`). The session's phase markers and the simulator's
truth are never read.

The test starts where the sensors show it (rising from the chair, the first step). Markers
labelled :data:`~mimucap.core.phase_markers.TEST_START` ("test start") and
:data:`~mimucap.core.phase_markers.TEST_STOP` ("test stop") override that: the test is searched
between them, starts at the start marker and, for the Timed Up and Go, ends at the stop
marker (the first of each after the other is used).

A session recorded by the guided test (:mod:`mimucap.session.procedures.clinical_test`) keeps
the test's settings in its metadata (``clinical_test``); the 10-metre walk takes its walkway
from there unless one is given.

Each result carries the reference of the subject's age and sex where the shipped norms have one
(:mod:`mimucap.io.clinical_norms`; the subject record's ``age_years``, ``sex``, ``height_m`` and
``weight_kg``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mimucap import __version__
from mimucap.core import phase_markers
from mimucap.core.analysis.chair_stand import chair_stand
from mimucap.core.analysis.chair_transitions import find_transitions
from mimucap.core.analysis.gait_events import SwingEvents, detect_swing_events
from mimucap.core.analysis.progression import Progression, progression
from mimucap.core.analysis.segment_motion import flexion_rate_dps, inclination_deg, yaw_rate_dps
from mimucap.core.analysis.trunk_turns import find_trunk_turns
from mimucap.core.analysis.tug import timed_up_and_go
from mimucap.core.analysis.walk_tests import ten_metre_walk, timed_walk, walking_start
from mimucap.core.pipeline.settings import RESULT_REPROCESSED
from mimucap.io.clinical_norms import read_norms, reference_for
from mimucap.session.recorded.analysis import gait_inputs
from mimucap.session.recorded.provenance import Provenance
from mimucap.session.recorded.review import ReviewData, load_review, require_body_calibration

#: Test name → the keys of its result, as the ``protocol`` command writes them.
RESULT_KEYS: dict[str, tuple[str, ...]] = {
    "tug": ("total_s", "sit_to_stand_s", "walk_out_s", "turn_s", "walk_back_s", "turn_to_sit_s"),
    "10mwt": ("speed_m_s", "cadence_steps_min"),
    "2mwt": ("distance_m", "speed_m_s"),
    "6mwt": ("distance_m", "speed_m_s"),
    "chair-stand": ("stands", "cycle_s"),
}
TESTS = tuple(RESULT_KEYS)
TEST_NAMES = {"tug": "Timed Up and Go", "10mwt": "10-metre walk test", "2mwt": "2-minute walk test",
              "6mwt": "6-minute walk test", "chair-stand": "30-second chair stand"}
#: Default walkway (m) of the 10-metre walk.
TEN_METRE_WALKWAY_M = 10.0
WALK_DURATION_S = {"2mwt": 120.0, "6mwt": 360.0}


@dataclass
class ClinicalTestResult:
    """One test's result: ``values`` the :data:`RESULT_KEYS` of ``test`` (NaN where not
    measurable), ``start_s``/``end_s`` the test in session time, ``started_by`` what set the
    start ("sensors" or the marker), ``details`` further figures (phase boundaries, per-minute
    distances, ...), ``reference`` the published reference for the subject (or None, with
    ``reference_note`` saying why), ``subject`` the record used, ``result`` the processing
    result (as seen live or reprocessed), ``provenance`` what the result holds."""

    test: str
    values: dict[str, float]
    start_s: float
    end_s: float
    started_by: str
    details: dict[str, Any] = field(default_factory=dict)
    reference: dict[str, Any] | None = None
    reference_note: str = ""
    subject: dict[str, Any] = field(default_factory=dict)
    result: str = RESULT_REPROCESSED
    #: What the result holds, as every output says it (:mod:`mimucap.session.recorded.provenance`).
    provenance: Provenance | None = None
    #: When the session was recorded (ISO 8601 UTC; "" when the file does not say).
    recorded_utc: str = ""

    def to_dict(self) -> dict[str, Any]:
        """The result as the ``protocol`` command writes it (NaN as null)."""
        out: dict[str, Any] = {"test": self.test, "name": TEST_NAMES[self.test]}
        out.update({key: _json_number(value) for key, value in self.values.items()})
        out.update(start_s=self.start_s, end_s=self.end_s, started_by=self.started_by,
                   details=_json_clean(self.details), reference=self.reference,
                   reference_note=self.reference_note or None, subject=self.subject, result=self.result,
                   recorded_utc=self.recorded_utc or None)
        if self.provenance is not None:
            out["calibration"] = self.provenance.body_calibration
            out["provenance"] = dict(self.provenance.items())
            out["software_version"] = __version__
            out["source_file"] = self.provenance.source_file
        return out


def run_clinical_test(path: str | Path, test: str, *, calibration_file: str | Path | None = None,
                      mag_files: Sequence[str | Path] = (), result: str = RESULT_REPROCESSED,
                      walkway_m: float | None = None,
                      progress: Callable[[float], None] | None = None) -> ClinicalTestResult:
    """Open session ``path``, process it as review and export do
    (:func:`mimucap.session.recorded.review.load_review`: its calibrations, or the body calibration of
    ``calibration_file`` and the magnetometer calibration files ``mag_files``) and compute ``test``
    (:func:`clinical_test`)."""
    check_test(test)
    review = load_review(path, progress, result=result, calibration_file=calibration_file, mag_files=mag_files)
    return clinical_test(review, test, walkway_m=walkway_m)


def check_test(test: str) -> None:
    if test not in RESULT_KEYS:
        raise ValueError(f"unknown clinical test {test!r}; use one of {', '.join(TESTS)}")


def clinical_test(review: ReviewData, test: str, walkway_m: float | None = None) -> ClinicalTestResult:
    """``test`` (one of :data:`TESTS`) computed from ``review`` (module doc); ``ValueError``
    saying what is missing when the recording does not hold the test."""
    check_test(test)
    require_body_calibration(review, f"the clinical test {test}")
    guided = review.session.metadata.get("clinical_test") or {}
    if walkway_m is None and test == "10mwt" and guided.get("test") == test and guided.get("walkway_m"):
        walkway_m = float(guided["walkway_m"])  # the walkway the guided test was run on
    window, overrides = _marker_window(review)
    if test == "tug":
        found = _tug(review, window, overrides)
    elif test == "chair-stand":
        found = _chair_stand(review, window, overrides)
    else:
        found = _walk(review, test, window, overrides, walkway_m)
    subject = dict(review.session.metadata.get("subject") or {})
    subject.setdefault("height_m", review.height_m)
    reference, note = reference_for(read_norms(), test, subject)
    found.reference = None if reference is None else reference.to_dict()
    found.reference_note = note
    found.subject = {k: subject[k] for k in ("id", "age_years", "sex", "height_m", "weight_kg") if k in subject}
    found.result = review.result
    found.provenance = review.provenance
    found.recorded_utc = str(review.session.metadata.get("created_utc") or "")
    return found


# -- the tests ------------------------------------------------------------------------------------
def _marker_window(review: ReviewData) -> tuple[tuple[float, float] | None, tuple[float | None, float | None]]:
    """The window between the user's start and stop markers (None without them; from a guided
    test's start signal on when it has one) and the overriding start and stop times."""
    starts = [m.t_s for m in review.markers if phase_markers.is_phase(m.label, phase_markers.TEST_START)]
    if not starts:
        # A guided test's start signal: the test is searched from there on (a subject still
        # walking to the start line before it is not doing the test), its start still found
        # from the sensors.
        signals = [m.t_s for m in review.markers if phase_markers.is_phase(m.label, phase_markers.GO_SIGNAL)]
        return (None if not signals else (min(signals) - _MARKER_SLACK_S, math.inf)), (None, None)
    start = min(starts)
    stops = [m.t_s for m in review.markers if phase_markers.is_phase(m.label, phase_markers.TEST_STOP) and m.t_s > start]
    stop = min(stops) if stops else None
    return (start - _MARKER_SLACK_S, math.inf if stop is None else stop + _MARKER_SLACK_S), (start, stop)


#: How far a detected event may lie outside the user's markers (s): a marker pressed a moment late.
_MARKER_SLACK_S = 1.0


def _segment(review: ReviewData, *names: str) -> np.ndarray:
    for name in names:
        if name in review.q_world_from_segment:
            return np.asarray(review.q_world_from_segment[name], dtype=float)
    raise ValueError(f"{review.path}: the test needs a sensor on the {' or '.join(names)} (calibrated to it)")


def _transitions(review: ReviewData):
    t = np.asarray(review.t_s, dtype=float)
    thighs = 0.5 * (inclination_deg(_segment(review, "thigh_l")) + inclination_deg(_segment(review, "thigh_r")))
    trunk = _segment(review, "thorax", "pelvis")
    return find_transitions(t, thighs, flexion_rate_dps(t, trunk))


def _tug(review: ReviewData, window, overrides) -> ClinicalTestResult:
    t = np.asarray(review.t_s, dtype=float)
    turns = find_trunk_turns(t, yaw_rate_dps(t, _segment(review, "thorax", "pelvis")))
    found = timed_up_and_go(_transitions(review), turns, window)
    bounds = list(found.boundaries_s)
    started_by = "sensors: the start of rising from the chair"
    if overrides[0] is not None:
        bounds[0], started_by = overrides[0], f"marker '{phase_markers.TEST_START}'"
    if overrides[1] is not None:
        bounds[-1] = overrides[1]
    keys = RESULT_KEYS["tug"]
    values = {key: float(b - a) for key, a, b in zip(keys[1:], bounds[:-1], bounds[1:])}
    values = {"total_s": float(bounds[-1] - bounds[0]), **values}
    details = {"boundaries_s": bounds, "turn_peak_trunk_rate_dps": found.turn_peak_dps,
               "turn_to_sit_peak_trunk_rate_dps": found.turn_to_sit_peak_dps}
    return ClinicalTestResult("tug", values, bounds[0], bounds[-1], started_by, details)


def _chair_stand(review: ReviewData, window, overrides) -> ClinicalTestResult:
    found = chair_stand(_transitions(review), within_s=window, start_s=overrides[0])
    started_by = ("sensors: the start of the first rise from the chair" if overrides[0] is None
                  else f"marker '{phase_markers.TEST_START}'")
    details = {"stand_times_s": list(found.stand_times_s)}
    return ClinicalTestResult("chair-stand", {"stands": float(found.stands), "cycle_s": found.cycle_s},
                              found.start_s, found.start_s + found.duration_s, started_by, details)


def walking_signals(review: ReviewData) -> tuple[dict[str, SwingEvents], Progression]:
    """Each foot's swings and the body's progression over the ground (:mod:`~mimucap.core.analysis.progression`)."""
    inputs, legs = gait_inputs(review)
    if legs is None or len(inputs) < 2:
        raise ValueError(f"{review.path}: the walking tests need both thighs and both shanks (or feet) with "
                         "calibrated sensors")
    events = {item.side: detect_swing_events(item.t_s, item.sagittal_rate, item.placement) for item in inputs}
    return events, progression(legs, events)


def _walk(review: ReviewData, test: str, window, overrides, walkway_m: float | None) -> ClinicalTestResult:
    events, way = walking_signals(review)
    if overrides[0] is not None:
        start, started_by = overrides[0], f"marker '{phase_markers.TEST_START}'"
    else:
        start, started_by = walking_start(events, window), "sensors: the first step"
    if test == "10mwt":
        walkway = TEN_METRE_WALKWAY_M if walkway_m is None else float(walkway_m)
        found = ten_metre_walk(way, events, start, walkway)
        details = {"walkway_m": walkway, "timed_section_s": list(found.timed_s), "timed_section_m": found.timed_m}
        values = {"speed_m_s": found.speed_m_s, "cadence_steps_min": found.cadence_steps_min}
        return ClinicalTestResult(test, values, start, found.timed_s[1], started_by, details)
    if walkway_m is not None:
        raise ValueError(f"the {TEST_NAMES[test]} takes no walkway length (it measures the distance walked)")
    walked = timed_walk(way, start, WALK_DURATION_S[test])
    details = {"minute_distances_m": list(walked.minute_distances_m),
               "minute_speeds_m_s": list(walked.minute_speeds_m_s),
               "last_vs_first_minute_percent": walked.last_vs_first_minute_percent}
    return ClinicalTestResult(test, {"distance_m": walked.distance_m, "speed_m_s": walked.speed_m_s}, start,
                              start + walked.duration_s, started_by, details)


def _json_number(value: float) -> float | None:
    return None if value is None or not math.isfinite(float(value)) else float(value)


def _json_clean(value):
    if isinstance(value, dict):
        return {k: _json_clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_clean(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return _json_number(float(value))
    return value
