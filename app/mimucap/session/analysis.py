"""Clinical analysis of a reviewed session (no Qt): gait from the foot or shank sensors, joint
angles over the gait cycle, range of motion between markers, and the tables saved as CSV.

The computations are pure functions of :mod:`mimucap.core.analysis`; this module only picks
their inputs out of :class:`~mimucap.session.review.ReviewData` (the processed result: sensor
samples, segment orientations and joint angles; nothing from the simulator's truth):

* per side the foot sensor (``foot_l``/``foot_r``) if there is one, else the shank sensor;
  its sagittal rate from the body calibration's mounting rotation, or without a calibration
  from the dominant gyroscope axis (:mod:`mimucap.core.analysis.sagittal`);
* the thighs, shanks and pelvis for the leg model and the heading, only when the segment
  orientations come from a body calibration (sensor axes alone are not the segments).

ROM protocol markers are labelled ``rom:<movement>:<side>:start`` and ``...:end`` (side
``left``, ``right`` or ``both``), see :mod:`mimucap.session.rom_procedure`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mimucap.core import bodycal
from mimucap.core.analysis import rom as rom_core
from mimucap.core.analysis.gait import GaitAnalysis, GaitInput, analyse_gait
from mimucap.core.analysis.gait_cycle import CycleCurve, cycle_curves
from mimucap.core.analysis.gait_parameters import PARAMETERS, SYMMETRY_PARAMETERS
from mimucap.core.analysis.leg_model import LegChain
from mimucap.core.analysis.sagittal import sagittal_rate_calibrated, sagittal_rate_dominant
from mimucap.io.gait_csv import write_table
from mimucap.io.session import Marker
from mimucap.session.review import ReviewData

SIDE_LETTER = {"left": "l", "right": "r"}
ROM_MARKER_PREFIX = "rom:"


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
                rate = sagittal_rate_calibrated(stream.gyr, calibration.q_segment_from_sensor[segment])
            else:
                rate = sagittal_rate_dominant(stream.gyr)
            inputs.append(GaitInput(side, placement, sensor_id, stream.t_s, rate, stream.acc, stream.gyr))
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
        parts = marker.label.split(":")
        if len(parts) != 4 or parts[0] + ":" != ROM_MARKER_PREFIX or parts[1] not in rom_core.MOVEMENT_KEYS:
            continue
        key, side, what = parts[1], parts[2], parts[3]
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
    t = np.asarray(review.t_s, dtype=float)
    window = (t >= start_s) & (t <= end_s)
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


@dataclass
class SessionAnalysis:
    """The analysis of one session: ``gait`` (None with ``gait_problem`` saying why),
    ``curves`` joint-angle cycle curves, ``rom`` results keyed (movement, side) with
    ``rom_source`` saying where they come from."""

    review: ReviewData
    gait: GaitAnalysis | None
    gait_problem: str
    curves: dict[str, CycleCurve] = field(default_factory=dict)
    rom: dict[tuple[str, str], rom_core.RomResult] = field(default_factory=dict)
    rom_source: str = ""


def analyse_review(review: ReviewData, progress: Callable[[float], None] | None = None) -> SessionAnalysis:
    """Gait, cycle curves and ROM of a review (module doc)."""
    report = progress or (lambda fraction: None)
    gait, problem, curves = None, "", {}
    inputs, legs = gait_inputs(review)
    if not inputs:
        problem = "no foot or shank sensor with a gyroscope"
    else:
        try:
            gait = analyse_gait(inputs, legs)
        except ValueError as error:
            problem = str(error)
        if gait is not None and not gait.analysed:
            problem = "no straight-walking stride found"
    report(0.6)
    if gait is not None and gait.analysed and len(review.t_s) > 1:
        curves = cycle_curves(review.t_s, review.angles_deg, gait.strides)
    report(0.8)
    rom = rom_of_protocol(review)
    source = "ROM protocol"
    if not rom:
        source = ""
    report(1.0)
    return SessionAnalysis(review, gait, problem, curves, rom, source)


# -- tables ------------------------------------------------------------------------------------
def strides_table(gait: GaitAnalysis) -> tuple[list[str], list[list[object]]]:
    header = ["foot", "ic_s", "fc_s", "next_ic_s", "stride_time_s", "stride_length_m", "straight",
              "heading_change_deg", "analysed", "refused_because"]
    rows = [[s.side, s.ic_s, s.fc_s, s.next_ic_s, s.stride_time_s, s.stride_length_m, s.straight,
             s.heading_change_deg, s.analysed, s.refused_because] for s in gait.strides]
    return header, rows


def parameters_table(gait: GaitAnalysis) -> tuple[list[str], list[list[object]]]:
    header = ["parameter", "unit", "side", "n", "mean", "sd", "cv_percent"]
    rows = []
    for name, unit, _ in PARAMETERS:
        for side in ("left", "right", "both"):
            s = gait.parameters.get(name, side)
            rows.append([name, unit, side, s.n, s.mean, s.sd, s.cv_percent])
    for name in SYMMETRY_PARAMETERS:
        rows.append([f"{name}_symmetry_index", "%", "both", None, gait.parameters.symmetry_percent[name], None, None])
    return header, rows


def curves_table(curves: dict[str, CycleCurve]) -> tuple[list[str], list[list[object]]]:
    header = ["column", "side", "percent", "mean_deg", "sd_deg", "n_strides", "stance_percent"]
    rows = []
    for curve in curves.values():
        for k in range(101):
            rows.append([curve.column, curve.side, k, curve.mean_deg[k], curve.sd_deg[k], curve.n_strides,
                         curve.stance_percent])
    return header, rows


def rom_table(rom: dict[tuple[str, str], rom_core.RomResult]) -> tuple[list[str], list[list[object]]]:
    header = ["movement", "side", "repetitions", "active_rom_deg", "peak_deg", "peaks_deg",
              "left_minus_right_deg", "reference_deg", "reference_source"]
    rows = []
    for (key, side), r in rom.items():
        rows.append([key, side, r.repetitions, r.active_rom_deg, r.peak_deg,
                     " ".join(f"{p:.1f}" for p in r.peaks_deg), rom_core.left_right_difference_deg(rom, key),
                     r.reference_deg, rom_core.REFERENCE_SOURCE])
    return header, rows


def bouts_table(gait: GaitAnalysis) -> tuple[list[str], list[list[object]]]:
    header = ["kind", "start_s", "end_s", "n_strides", "angle_deg"]
    rows = [["bout", b.start_s, b.end_s, b.n_strides, None] for b in gait.bouts]
    rows += [["turn", t.start_s, t.end_s, t.n_strides, t.angle_deg] for t in gait.turns]
    return header, rows


def write_gait_csv(folder: str | Path, gait: GaitAnalysis) -> list[Path]:
    """``strides.csv``, ``parameters.csv`` and ``bouts_turns.csv`` in ``folder``."""
    base = Path(folder)
    return [write_table(base / "strides.csv", *strides_table(gait)),
            write_table(base / "parameters.csv", *parameters_table(gait)),
            write_table(base / "bouts_turns.csv", *bouts_table(gait))]


def write_analysis_csv(folder: str | Path, analysis: SessionAnalysis) -> list[Path]:
    """Every table of ``analysis`` as one CSV in ``folder`` (created if needed)."""
    base = Path(folder)
    base.mkdir(parents=True, exist_ok=True)
    written = []
    if analysis.gait is not None:
        written += write_gait_csv(base, analysis.gait)
    if analysis.curves:
        written.append(write_table(base / "gait_cycle_curves.csv", *curves_table(analysis.curves)))
    if analysis.rom:
        written.append(write_table(base / "rom.csv", *rom_table(analysis.rom)))
    return written

