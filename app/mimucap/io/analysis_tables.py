"""The CSV tables of a gait and range-of-motion analysis, and of a comparison of two sessions.

Each table is CSV with one header row, after ``#`` lines saying what the input holds (result,
calibrations, software, source file); empty cells are values that could not be estimated;
booleans are ``true``/``false`` (:func:`write_table`, :func:`read_table`). A gait analysis gives
``strides.csv`` (one row per stride and why one was not analysed), ``parameters.csv`` (each
spatio-temporal parameter per side: count, mean, SD, coefficient of variation; and the symmetry
indices) and ``bouts_turns.csv`` (:func:`write_gait_tables`); a session's analysis adds
``gait_cycle_curves.csv`` (each joint angle's mean and SD over the gait cycle, 0-100 %) and
``rom.csv`` (the range of motion of each movement between markers) (:func:`write_analysis_tables`).
A comparison's tables go into one file (:func:`write_comparison_csv`). Times in s, angles in
degrees, lengths in m; units are in the column names.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np

from mimucap.core.analysis import rom as rom_core
from mimucap.core.analysis.gait import GaitAnalysis
from mimucap.core.analysis.gait_cycle import CycleCurve
from mimucap.core.analysis.gait_parameters import PARAMETERS, SYMMETRY_PARAMETERS


def format_cell(value: object) -> str:
    """A table cell: empty for None/NaN, ``true``/``false``, numbers with up to 6 significant
    decimals."""
    if value is None:
        return ""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (float, np.floating)):
        return "" if not math.isfinite(float(value)) else f"{float(value):.6g}"
    return str(value)


def write_table(path: str | Path, header: Sequence[str], rows: Iterable[Sequence[object]],
                notes: Sequence[str] = ()) -> Path:
    """Write one CSV table (module doc), ``notes`` as ``#`` lines above it; returns the path."""
    target = Path(path)
    with open(target, "w", newline="", encoding="utf-8") as handle:
        for note in notes:
            handle.write("# " + " ".join(str(note).split()) + "\n")
        writer = csv.writer(handle)
        writer.writerow(list(header))
        for row in rows:
            writer.writerow([format_cell(v) for v in row])
    return target


def read_table(path: str | Path) -> list[dict[str, str]]:
    """Rows of a CSV table as header → text (its ``#`` lines skipped)."""
    with open(path, newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(line for line in handle if not line.startswith("#")))


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


def write_gait_tables(folder: str | Path, gait: GaitAnalysis, notes: Sequence[str] = ()) -> list[Path]:
    """``strides.csv``, ``parameters.csv`` and ``bouts_turns.csv`` in ``folder``, each headed
    by ``notes`` (``#`` lines: what the input holds)."""
    base = Path(folder)
    return [write_table(base / "strides.csv", *strides_table(gait), notes=notes),
            write_table(base / "parameters.csv", *parameters_table(gait), notes=notes),
            write_table(base / "bouts_turns.csv", *bouts_table(gait), notes=notes)]


def write_analysis_tables(folder: str | Path, gait: GaitAnalysis | None, curves: Mapping[str, CycleCurve],
                          rom: Mapping[tuple[str, str], rom_core.RomResult], notes: Sequence[str] = ()) -> list[Path]:
    """The tables of an analysis in ``folder`` (created if needed), each headed by ``notes``:
    the gait tables when there is a ``gait`` analysis, the gait-cycle curves and the range of
    motion when there are any."""
    base = Path(folder)
    base.mkdir(parents=True, exist_ok=True)
    written = []
    if gait is not None:
        written += write_gait_tables(base, gait, notes)
    if curves:
        written.append(write_table(base / "gait_cycle_curves.csv", *curves_table(dict(curves)), notes=notes))
    if rom:
        written.append(write_table(base / "rom.csv", *rom_table(dict(rom)), notes=notes))
    return written


def comparison_csv(tables: Sequence) -> str:
    """Tables (each with a ``name``, ``headers`` and ``rows``) as CSV text: each table's name,
    its header row and rows, a blank line between; floats with two decimals."""
    import io

    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    for table in tables:
        writer.writerow([table.name])
        writer.writerow(table.headers)
        for row in table.rows:
            writer.writerow(["" if v is None else (f"{v:.2f}" if isinstance(v, float) else v) for v in row])
        writer.writerow([])
    return out.getvalue()


def write_comparison_csv(path: str | Path, tables: Sequence) -> Path:
    """Write :func:`comparison_csv` of ``tables`` to ``path``."""
    target = Path(path)
    target.write_text(comparison_csv(tables), encoding="utf-8")
    return target
