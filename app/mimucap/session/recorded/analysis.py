"""Clinical analysis of a reviewed session (no Qt): gait from the foot or shank sensors, joint
angles over the gait cycle, range of motion between markers, and the tables saved as CSV.

The computations are pure functions of :mod:`mimucap.core.analysis`; this module only picks
their inputs out of :class:`~mimucap.session.recorded.review.ReviewData` (the processed result: sensor
samples, segment orientations and joint angles; nothing from the simulator's truth):

* per side the foot sensor (``foot_l``/``foot_r``) if there is one, else the shank sensor;
  its sagittal axes (flexion and antero-posterior) from the body calibration's mounting
  rotation, or without a calibration found in its own samples
  (:mod:`mimucap.core.analysis.sagittal`);
* the thighs, shanks and pelvis for the leg model and the heading, only when the segment
  orientations come from a body calibration (sensor axes alone are not the segments);
* nothing from the phases in which the sensors were in the hands (the magnetometer turns),
  :func:`while_worn`.

Joint-angle curves, range of motion, turns and spatial gait parameters (stride length, gait
speed) need a body calibration: without one the segment "orientations" are the sensors' own
axes. A review without one is analysed for the temporal parameters alone, labelled so
(:data:`NEEDS_BODY_CALIBRATION`, :attr:`SessionAnalysis.limits`).

ROM protocol markers are labelled ``rom:<movement>:<side>:start`` and ``...:end`` (side
``left``, ``right`` or ``both``), see :mod:`mimucap.session.procedures.range_of_motion`.

The tables as the Analysis workspace and the PDF report show them are built here once: the gait
parameter rows (:func:`gait_parameter_rows`), the ROM rows (:func:`rom_rows`), each with its
label, unit and values and :meth:`cells` for its text, and the cycle curves grouped by joint
angle (:func:`curve_groups`); the CSV tables are written by :mod:`mimucap.io.analysis_tables`
(:func:`write_analysis_csv` says what they hold).

Doubtful data is marked, not hidden (:mod:`mimucap.core.pipeline.doubt_reasons`): the joints whose angles are
doubtful somewhere, when and why (:func:`doubt_rows`), the strides of each cycle curve that
hold doubtful samples, and the share of each ROM window that is doubtful.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from mimucap.core import bodycal, phase_markers
from mimucap.core.analysis import rom as rom_core
from mimucap.core.analysis.gait import GaitAnalysis, GaitInput, analyse_gait
from mimucap.core.analysis.gait_cycle import CycleCurve, cycle_curves, split_column
from mimucap.core.analysis.gait_parameters import PARAMETERS, SYMMETRY_PARAMETERS, ParameterSummary, gait_parameters
from mimucap.core.analysis.leg_model import LegChain
from mimucap.core.analysis.sagittal import axes_calibrated, axes_from_data, sagittal_rate_dominant
from mimucap.core.clinical_names import axis_short_name, joint_name
from mimucap.core.pipeline import doubt_reasons
from mimucap.core.wording import fixed
from mimucap.io.analysis_tables import write_analysis_tables
from mimucap.io.session import Marker
from mimucap.session.recorded.review import ReviewData

SIDE_LETTER = {"left": "l", "right": "r"}


def body_calibration_of(review: ReviewData) -> bodycal.BodyCalibration | None:
    """The body calibration the review's processing applied, or None."""
    return review.body_calibration


def _sensor_of_segment(review: ReviewData, calibration, segment: str) -> str | None:
    if calibration is not None and segment in calibration.sensors:
        return calibration.sensors[segment]
    for sensor_id, stream in review.session.sensors.items():
        if stream.segment == segment:
            return sensor_id
    return None


def gait_inputs(review: ReviewData) -> tuple[list[GaitInput], LegChain | None]:
    """The per-side gait inputs and the leg chain of a review (module doc)."""
    calibration = body_calibration_of(review)
    inputs = []
    for side, letter in SIDE_LETTER.items():
        for placement in ("foot", "shank"):
            segment = f"{placement}_{letter}"
            sensor_id = _sensor_of_segment(review, calibration, segment)
            stream = review.session.sensors.get(sensor_id) if sensor_id else None
            if stream is None or stream.gyr is None or len(stream.t_s) < 10:
                continue
            if placement == "foot" and stream.acc is None:
                continue
            if calibration is not None and segment in calibration.q_segment_from_sensor:
                axes = axes_calibrated(calibration.q_segment_from_sensor[segment])
            elif stream.acc is not None:
                axes = axes_from_data(stream.acc, stream.gyr, 1.0 / float(np.median(np.diff(stream.t_s))))
            else:   # a shank sensor without accelerometer: the flexion axis from the rotation alone
                inputs.append(GaitInput(side, placement, sensor_id, stream.t_s, sagittal_rate_dominant(stream.gyr),
                                        None, stream.gyr))
                break
            sagittal_acc = axes.acceleration(stream.acc) if stream.acc is not None else None
            inputs.append(GaitInput(side, placement, sensor_id, stream.t_s, axes.rate(stream.gyr), stream.acc,
                                    stream.gyr, sagittal_acc))
            break
    legs = None
    q = review.q_world_from_segment
    needed = ("pelvis", "thigh_l", "thigh_r", "shank_l", "shank_r")
    # Segment orientations mean something only through a body calibration (sensor axes alone
    # are not the segments' axes).
    if calibration is not None and all(s in q for s in needed) and len(review.t_s) > 1:
        legs = LegChain.from_segments(review.model, review.height_m, np.asarray(review.t_s, dtype=float), q)
    return inputs, legs


def rom_markers(markers: list[Marker]) -> list[tuple[str, str, float, float]]:
    """``(movement key, side, start_s, end_s)`` of every ROM protocol marker pair."""
    starts: dict[tuple[str, str], float] = {}
    found = []
    for marker in markers:
        parsed = rom_core.parse_rom_marker(marker.label)
        if parsed is None:
            continue
        key, side, what = parsed
        if what == "start":
            starts[(key, side)] = marker.t_s
        elif what == "end" and (key, side) in starts:
            found.append((key, side, starts.pop((key, side)), marker.t_s))
    return found


def rom_between(review: ReviewData, start_s: float, end_s: float,
                keys: tuple[str, ...] | None = None, sides: tuple[str, ...] | None = None
                ) -> dict[tuple[str, str], rom_core.RomResult]:
    """ROM of the movements ``keys`` (default all the recording has) on ``sides`` between two
    instants (e.g. two markers) of the review."""
    if not end_s > start_s:
        raise ValueError(f"the ROM window must end after it starts ({start_s:.2f} .. {end_s:.2f} s)")
    window = rom_core.window_mask(review.t_s, start_s, end_s)
    if np.count_nonzero(window) < 3:
        raise ValueError(f"no poses between {start_s:.2f} and {end_s:.2f} s")
    angles = {c: np.asarray(v)[window] for c, v in review.angles_deg.items()}
    segments = {s: np.asarray(v)[window] for s, v in review.q_world_from_segment.items()}
    results = {}
    for key in keys or rom_core.MOVEMENT_KEYS:
        m = rom_core.movement(key)
        for side in sides or rom_core.sides_of(m):
            if side not in rom_core.sides_of(m):
                continue
            try:
                series = rom_core.movement_series(m, side, angles, segments)
            except ValueError:
                continue
            results[(key, side)] = rom_core.rom_of(m, side, series)
    return results


def rom_of_protocol(review: ReviewData) -> dict[tuple[str, str], rom_core.RomResult]:
    """ROM of every movement recorded by the ROM protocol (its markers)."""
    results = {}
    for key, side, start, end in rom_markers(review.markers):
        results.update(rom_between(review, start, end, keys=(key,), sides=(side,)))
    return results


#: Why an analysis without a body calibration gives the temporal gait parameters alone.
NEEDS_BODY_CALIBRATION = ("no body calibration: joint-angle curves, range of motion, turns and spatial gait "
                          "parameters (stride length, gait speed) need one; temporal gait parameters only")


def unworn_windows(review: ReviewData) -> list[tuple[float, float]]:
    """The time windows (s) in which the review's markers say the sensors were not worn."""
    return phase_markers.off_body_windows(review.markers, review.end_s)


def while_worn(gait: GaitAnalysis, windows: Sequence[tuple[float, float]]) -> GaitAnalysis:
    """``gait`` without the strides, bouts and turns that overlap ``windows`` (s) in which the sensors
    were not worn (turning a sensor in the hand is no turn of the walker), its parameters
    recomputed."""
    if not windows:
        return gait

    def outside(start: float, end: float) -> bool:
        return not any(start < b and end > a for a, b in windows)

    strides = [s for s in gait.strides if outside(s.ic_s, s.next_ic_s)]
    bouts = [b for b in gait.bouts if outside(b.start_s, b.end_s)]
    turns = [t for t in gait.turns if outside(t.start_s, t.end_s)]
    return replace(gait, strides=strides, bouts=bouts, turns=turns, parameters=gait_parameters(strides))


def temporal_only(gait: GaitAnalysis) -> GaitAnalysis:
    """``gait`` without what needs a body calibration: stride lengths and heading changes
    left out (NaN), no turns, the parameters of the same strides recomputed (stride length and
    gait speed then have no value)."""
    strides = [replace(s, stride_length_m=math.nan, heading_change_deg=math.nan) for s in gait.strides]
    sources = {side: text.split(";")[0] + "; temporal parameters only (no body calibration)"
               for side, text in gait.sources.items()}
    return replace(gait, strides=strides, turns=[], parameters=gait_parameters(strides), sources=sources)


def rom_doubt(review: ReviewData) -> dict[tuple[str, str], float]:
    """The share of each ROM protocol window (keyed (movement, side)) in which the movement's
    joint angles are doubtful."""
    found = {}
    for key, side, start, end in rom_markers(review.markers):
        m = rom_core.movement(key)
        joint = m.joint if m.joint in ("lumbar", "neck") else f"{m.joint}_{side[0]}"
        reasons = review.joint_doubt.get(joint)
        window = rom_core.window_mask(review.t_s, start, end)
        if reasons is not None and np.any(window):
            found[(key, side)] = float(np.mean(reasons[window] != 0))
    return found


@dataclass(frozen=True)
class DoubtRow:
    """A joint whose angles are doubtful somewhere in the review: the ``fraction`` of its
    poses, the ``spans`` ``(start_s, end_s, reasons)`` (reason bits of :mod:`mimucap.core.pipeline.doubt_reasons`)."""

    joint: str
    fraction: float
    spans: tuple[tuple[float, float, int], ...]

    #: Spans shown in a table cell (the rest are counted).
    SHOWN_SPANS = 4

    def cells(self) -> list[str]:
        """The row's text under :data:`DOUBT_HEADER`."""
        shown = ", ".join(f"{a:.1f}–{b:.1f}" for a, b, _r in self.spans[:self.SHOWN_SPANS])
        if len(self.spans) > self.SHOWN_SPANS:
            shown += f" and {len(self.spans) - self.SHOWN_SPANS} more"
        reasons = int(np.bitwise_or.reduce([r for _a, _b, r in self.spans])) if self.spans else 0
        return [joint_name(self.joint), f"{100.0 * self.fraction:.1f}", shown, doubt_reasons.describe(reasons)]


DOUBT_HEADER = ("Joint", "Doubtful %", "When (s)", "Why")


def doubt_rows(review: ReviewData) -> list[DoubtRow]:
    """The joints whose angles are doubtful somewhere, in the model's joint order."""
    rows = []
    for joint in review.model.joint_names:
        reasons = review.joint_doubt.get(joint)
        if reasons is None or not np.any(reasons):
            continue
        rows.append(DoubtRow(joint, float(np.mean(reasons != 0)), tuple(doubt_reasons.spans(review.t_s, reasons))))
    return rows


def doubtful_strides(review: ReviewData, curves: dict[str, CycleCurve], strides) -> dict[str, int]:
    """Curve key → how many of the strides it averages hold a doubtful sample of its joint."""
    found = {}
    for key, curve in curves.items():
        joint = next((j for j in review.joint_doubt if curve.column.startswith(j + "_")), None)
        if joint is None:
            continue
        reasons = review.joint_doubt[joint]
        count = 0
        for stride in strides:
            if stride.side != curve.side or not stride.analysed:
                continue
            inside = (review.t_s >= stride.ic_s) & (review.t_s <= stride.next_ic_s)
            count += int(np.any(reasons[inside] != 0))
        found[key] = count
    return found


def curve_doubt_of(analysis: "SessionAnalysis", curve: CycleCurve) -> int:
    """How many strides of ``curve`` (one of ``analysis.curves``) hold doubtful samples."""
    sided = split_column(curve.column)[1] is not None
    return analysis.curve_doubt.get(curve.column if sided else f"{curve.column}@{curve.side}", 0)


@dataclass
class SessionAnalysis:
    """The analysis of one session: ``gait`` (None with ``gait_problem`` saying why),
    ``curves`` joint-angle cycle curves, ``rom`` results keyed (movement, side) with
    ``rom_source`` saying where they come from; ``limits`` what it leaves out and why ('' for a
    full analysis, :data:`NEEDS_BODY_CALIBRATION` without a body calibration); ``doubt`` the
    joints doubtful somewhere, ``curve_doubt`` curve key → its strides holding doubtful samples,
    ``rom_doubt`` (movement, side) → the doubtful share of its window."""

    review: ReviewData
    gait: GaitAnalysis | None
    gait_problem: str
    curves: dict[str, CycleCurve] = field(default_factory=dict)
    rom: dict[tuple[str, str], rom_core.RomResult] = field(default_factory=dict)
    rom_source: str = ""
    limits: str = ""
    doubt: list[DoubtRow] = field(default_factory=list)
    curve_doubt: dict[str, int] = field(default_factory=dict)
    rom_doubt: dict[tuple[str, str], float] = field(default_factory=dict)

    @property
    def calibrated(self) -> bool:
        """Whether the review had a body calibration (a full analysis)."""
        return self.review.body_calibration is not None


def analyse_review(review: ReviewData, progress: Callable[[float], None] | None = None) -> SessionAnalysis:
    """Gait, cycle curves and ROM of a review (module doc); without a body calibration, the
    temporal gait parameters alone (:func:`temporal_only`)."""
    report = progress or (lambda fraction: None)
    calibrated = review.body_calibration is not None
    gait, problem, curves = None, "", {}
    inputs, legs = gait_inputs(review)
    if not inputs:
        problem = "no foot or shank sensor with a gyroscope"
    else:
        try:
            gait = while_worn(analyse_gait(inputs, legs), unworn_windows(review))
        except ValueError as error:
            problem = str(error)
        if gait is not None and not calibrated:
            gait = temporal_only(gait)
        if gait is not None and not gait.analysed:
            problem = "no straight-walking stride found"
    report(0.6)
    curve_doubt = {}
    if calibrated and gait is not None and gait.analysed and len(review.t_s) > 1:
        curves = cycle_curves(review.t_s, review.angles_deg, gait.strides)
        curve_doubt = doubtful_strides(review, curves, gait.strides)
    report(0.8)
    rom = rom_of_protocol(review) if calibrated else {}
    source = "ROM protocol" if rom else ""
    report(1.0)
    return SessionAnalysis(review, gait, problem, curves, rom, source, "" if calibrated else NEEDS_BODY_CALIBRATION,
                           doubt_rows(review), curve_doubt, rom_doubt(review))


def table_notes(analysis: SessionAnalysis) -> list[str]:
    """The header lines of an analysis table: what the result holds
    (:attr:`~mimucap.session.recorded.review.ReviewData.provenance`) and what the analysis leaves out."""
    notes = analysis.review.provenance.lines()
    return notes + ([f"Analysis: {analysis.limits}"] if analysis.limits else [])


# -- tables as shown (the Analysis workspace and the PDF report) -------------------------------------
#: Typical values of healthy adults walking at their own pace (Perry & Burnfield, "Gait
#: Analysis: Normal and Pathological Function", 2nd ed., 2010: velocity 82 m/min, cadence 113
#: steps/min, stride length 1.41 m, stance 60 %, swing 40 %, double support 2 × 10 %).
TYPICAL_ADULT = {"cadence": 113.0, "stride_length": 1.41, "gait_speed": 1.37, "stance": 60.0, "swing": 40.0,
                 "double_support": 20.0, "stride_time": 120.0 / 113.0, "step_time": 60.0 / 113.0}
TYPICAL_SOURCE = "typical adult: Perry & Burnfield 2010"
SHOWN_SIDES = ("left", "right", "both")
GAIT_PARAMETER_HEADER = ("Parameter (mean ± SD)", "Left", "Right", "Both", "CV %", "Symmetry %", "Typical adult")
ROM_HEADER = ("Movement", "Side", "Repetitions", "Active ROM (°)", "Peak (°)", "Peaks (°)", "L − R (°)",
              "Reference (°)", "% of reference")
#: Order of a joint's angle axes in lists and plots.
AXIS_ORDER = ("flexion", "adduction", "rotation", "plane_of_elevation", "elevation")


def format_value(value: float | None, digits: int = 2) -> str:
    """``value`` with ``digits`` decimals, ``–`` when None or NaN; a small negative value
    that rounds to zero shows as zero (``-0.00`` would suggest a sign the figure does not have)."""
    return fixed(value, digits)


def parameter_digits(unit: str) -> int:
    """Decimals shown for a gait parameter of ``unit`` (percentages and cadence: 1, else 2)."""
    return 1 if unit in ("%", "steps/min") else 2


@dataclass(frozen=True)
class GaitParameterRow:
    """One gait parameter as shown: ``summaries`` left, right, both; ``symmetry_percent`` and
    ``typical_adult`` (:data:`TYPICAL_ADULT`) NaN where not given."""

    name: str
    label: str
    unit: str
    summaries: tuple[ParameterSummary, ParameterSummary, ParameterSummary]
    symmetry_percent: float
    typical_adult: float

    @property
    def digits(self) -> int:
        return parameter_digits(self.unit)

    @property
    def title(self) -> str:
        return f"{self.label} ({self.unit})"

    def cells(self) -> list[str]:
        """The row's text under :data:`GAIT_PARAMETER_HEADER`."""
        d = self.digits
        both = self.summaries[2]
        return ([self.title] + [f"{format_value(s.mean, d)} ± {format_value(s.sd, d)}" for s in self.summaries]
                + [format_value(both.cv_percent, 1),
                   format_value(self.symmetry_percent, 1) if self.name in SYMMETRY_PARAMETERS else "",
                   format_value(self.typical_adult, d)])


def gait_parameter_rows(gait: GaitAnalysis) -> list[GaitParameterRow]:
    """Every parameter of :data:`~mimucap.core.analysis.gait_parameters.PARAMETERS` of ``gait``."""
    return [GaitParameterRow(name, label, unit, tuple(gait.parameters.get(name, side) for side in SHOWN_SIDES),
                             gait.parameters.symmetry_percent.get(name, math.nan),
                             TYPICAL_ADULT.get(name, math.nan))
            for name, unit, label in PARAMETERS]


@dataclass(frozen=True)
class RomRow:
    """One ROM result as shown; ``left_minus_right_deg`` on the left side's row only (None on
    the others: the difference belongs to the pair, shown once)."""

    key: str
    label: str
    side: str
    result: rom_core.RomResult
    left_minus_right_deg: float | None

    def cells(self) -> list[str]:
        """The row's text under :data:`ROM_HEADER` (degrees)."""
        r = self.result
        return [self.label, self.side, str(r.repetitions), format_value(r.active_rom_deg, 1),
                format_value(r.peak_deg, 1), " ".join(f"{p:.0f}" for p in r.peaks_deg),
                "" if self.left_minus_right_deg is None else format_value(self.left_minus_right_deg, 1),
                format_value(r.reference_deg, 0), format_value(r.percent_of_reference, 0)]


def rom_rows(rom: dict[tuple[str, str], rom_core.RomResult]) -> list[RomRow]:
    """The rows of ``rom`` (keyed (movement, side)) in its order."""
    return [RomRow(key, rom_core.movement(key).label, side, r,
                   rom_core.left_right_difference_deg(rom, key) if side == "left" else None)
            for (key, side), r in rom.items()]


@dataclass(frozen=True)
class CurveGroup:
    """One joint angle over the gait cycle: ``joint`` and ``axis`` (as split from the column
    name), ``curves`` one side → :class:`CycleCurve` mapping per analysis compared."""

    joint: str
    axis: str
    curves: tuple[dict[str, CycleCurve], ...]

    @property
    def label(self) -> str:
        """The angle in clinical words, both sides: "Knee varus/valgus", "Lumbar spine flexion"."""
        return f"{joint_name(self.joint)} {axis_short_name(self.joint, self.axis)}"


def curve_groups(analyses: Sequence[SessionAnalysis]) -> list[CurveGroup]:
    """The cycle curves of ``analyses`` (one, or before and after) grouped by joint angle, in
    the first review's model joint order, then :data:`AXIS_ORDER`."""
    found: dict[tuple[str, str], list[dict[str, CycleCurve]]] = {}
    for index, analysis in enumerate(analyses):
        for curve in analysis.curves.values():
            joint, _, axis = split_column(curve.column)
            per_analysis = found.setdefault((joint, axis), [{} for _ in analyses])
            per_analysis[index][curve.side] = curve
    if not found:
        return []
    order = {name: index for index, name in enumerate(analyses[0].review.model.joint_names)}

    def rank(pair: tuple[str, str]) -> tuple[int, int]:
        joint, axis = pair
        joint_rank = min((order[n] for n in (joint, f"{joint}_l", f"{joint}_r") if n in order), default=len(order))
        return joint_rank, AXIS_ORDER.index(axis) if axis in AXIS_ORDER else len(AXIS_ORDER)

    return [CurveGroup(joint, axis, tuple(found[(joint, axis)])) for joint, axis in sorted(found, key=rank)]


def write_analysis_csv(folder: str | Path, analysis: SessionAnalysis) -> list[Path]:
    """Every table of ``analysis`` as one CSV in ``folder`` (created if needed), each headed by
    :func:`table_notes` (:func:`mimucap.io.analysis_tables.write_analysis_tables`)."""
    return write_analysis_tables(folder, analysis.gait, analysis.curves, analysis.rom, table_notes(analysis))
