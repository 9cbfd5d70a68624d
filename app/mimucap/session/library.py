"""The library seen from the application (no Qt): opening the configured folder, and comparing
two sessions of a subject.

A comparison is a list of named tables (:class:`ComparisonTable`), each made by one builder of
:data:`COMPARISON_TABLES` from the two sessions' processed results (:class:`ComparedSession`,
taken from :func:`mimucap.session.review.load_review` by the caller). The joint-angle range of
motion is the first builder; another analysis adds its table by appending a builder, and every
view of a comparison shows whatever tables it gets.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from mimucap.core.analysis.rom import range_of_motion
from mimucap.core.pipeline import RESULT_LABELS, RESULT_REPROCESSED
from mimucap.io.library import Library, SessionEntry
from mimucap.io.library_settings import configured_library_folder
from mimucap.io.session import Marker
from mimucap.session.export import marker_at, marker_range


def open_library(folder: str | os.PathLike[str] | None = None, default: str | os.PathLike[str] | None = None) -> Library:
    """The library in ``folder``, else in the configured folder
    (:func:`mimucap.io.library_settings.configured_library_folder` with ``default``)."""
    return Library(folder if folder is not None else configured_library_folder(default))


@dataclass(frozen=True)
class TimeWindow:
    """A part of a recording: ``start_s``..``end_s`` in s since the recording started (None: its
    start or end), named ``label`` (e.g. ``"whole recording"``, ``"heel strike → turn"``)."""

    start_s: float | None = None
    end_s: float | None = None
    label: str = "whole recording"

    @classmethod
    def between_markers(cls, markers: Sequence[Marker], first: int | None, second: int | None) -> "TimeWindow":
        """The window from marker ``first`` to marker ``second`` (indexes into ``markers``, in
        either order, by the export's rule :func:`mimucap.session.export.marker_range`); None
        stands for the recording's start (``first``) or end (``second``). ``ValueError`` when a
        marker does not exist or the two are at one time."""
        if first is None and second is None:
            return cls()
        if first is None or second is None:
            marker = marker_at(markers, second if first is None else first)
            if first is None:
                return cls(None, float(marker.t_s), f"start → {_named(marker)}")
            return cls(float(marker.t_s), None, f"{_named(marker)} → end")
        start_s, end_s = marker_range(markers, first, second)
        a, b = sorted((markers[first], markers[second]), key=lambda m: m.t_s)
        return cls(start_s, end_s, f"{_named(a)} → {_named(b)}")


def _named(marker: Marker) -> str:
    return f"{marker.label} ({marker.t_s:.2f} s)"


@dataclass
class ComparedSession:
    """One side of a comparison: the library ``entry``, its processed joint angles
    ``angles_deg`` (column → (T,) deg, ISB sequences, columns of
    ``core.skeleton.joint_angle_columns``) at ``t_s`` (T,) s since the recording started, its
    ``markers`` and the ``window`` compared; ``calibrated`` whether a body calibration made
    its segments, ``result`` which result it is (``core.pipeline.RESULTS``)."""

    entry: SessionEntry
    t_s: np.ndarray
    angles_deg: dict[str, np.ndarray]
    markers: list[Marker] = field(default_factory=list)
    window: TimeWindow = field(default_factory=TimeWindow)
    calibrated: bool = True
    result: str = RESULT_REPROCESSED

    @classmethod
    def from_review(cls, entry: SessionEntry, review, window: TimeWindow | None = None) -> "ComparedSession":
        """From a :class:`mimucap.session.review.ReviewData` (the one pipeline's results)."""
        return cls(entry, np.asarray(review.t_s, dtype=float), dict(review.angles_deg), list(review.markers),
                   window or TimeWindow(), review.body_calibration is not None, review.result)


@dataclass(frozen=True)
class ComparisonTable:
    """A named table of a comparison: ``headers`` (the unit in each numeric column's name) and
    ``rows`` (first cell a label, then numbers; None where one side has no value)."""

    name: str
    headers: tuple[str, ...]
    rows: tuple[tuple, ...]
    note: str = ""


def rom_table(a: ComparedSession, b: ComparedSession) -> ComparisonTable:
    """Joint-angle range of motion of both sessions over their windows, and B − A."""
    rom_a = range_of_motion(a.t_s, a.angles_deg, a.window.start_s, a.window.end_s)
    rom_b = range_of_motion(b.t_s, b.angles_deg, b.window.start_s, b.window.end_s)
    columns = list(a.angles_deg) + [c for c in b.angles_deg if c not in a.angles_deg]
    rows = []
    for column in columns:
        first, second = rom_a.get(column), rom_b.get(column)
        if first is None and second is None:
            continue
        cells: list = [column.removesuffix("_deg")]
        for value in (first, second):
            cells += [None, None, None] if value is None else [value.min_deg, value.max_deg, value.rom_deg]
        cells.append(None if first is None or second is None else second.rom_deg - first.rom_deg)
        rows.append(tuple(cells))
    return ComparisonTable(
        name="Joint-angle range of motion",
        headers=("joint angle", "A min (°)", "A max (°)", "A ROM (°)", "B min (°)", "B max (°)", "B ROM (°)",
                 "ROM B − A (°)"),
        rows=tuple(rows),
        note=f"A: {a.entry.file_name}, {a.window.label}. B: {b.entry.file_name}, {b.window.label}.")


#: The builders of a comparison's tables, in the order they are shown. Each takes the two
#: sides and returns a table, or None when it has nothing to say about these sessions.
COMPARISON_TABLES: list[Callable[[ComparedSession, ComparedSession], ComparisonTable | None]] = [rom_table]


def compare(a: ComparedSession, b: ComparedSession,
            builders: Sequence[Callable[[ComparedSession, ComparedSession], ComparisonTable | None]] | None = None,
            ) -> list[ComparisonTable]:
    """The tables comparing ``a`` with ``b`` (:data:`COMPARISON_TABLES` unless ``builders``);
    ``ValueError`` when the two are not sessions of one subject, hold different results (as seen
    live / reprocessed), or one of them has no body calibration (:func:`check_comparable`)."""
    if a.entry.subject_id != b.entry.subject_id:
        raise ValueError(f"{a.entry.file_name} ({a.entry.subject_id}) and {b.entry.file_name} "
                         f"({b.entry.subject_id}) are not sessions of one subject")
    check_comparable(a, b)
    tables = [build(a, b) for build in (COMPARISON_TABLES if builders is None else builders)]
    return [table for table in tables if table is not None]


#: Why two sessions without a body calibration are not compared.
COMPARISON_NEEDS_CALIBRATION = ("joint angles and their range of motion mean nothing without a body calibration "
                                "(the segments are the sensors' own axes)")


def check_comparable(a: ComparedSession, b: ComparedSession) -> None:
    """``ValueError`` saying why ``a`` and ``b`` cannot be compared: one or both without a body
    calibration, or results of different kinds (differences would be the processing's)."""
    uncalibrated = [side.entry.file_name for side in (a, b) if not side.calibrated]
    if len(uncalibrated) == 2:
        raise ValueError(f"neither {a.entry.file_name} nor {b.entry.file_name} has a body calibration: "
                         f"{COMPARISON_NEEDS_CALIBRATION}")
    if uncalibrated:
        raise ValueError(f"{uncalibrated[0]} has no body calibration, the other session has one: their "
                         f"differences would be the calibration's ({COMPARISON_NEEDS_CALIBRATION})")
    if a.result != b.result:
        raise ValueError(f"{a.entry.file_name} is {RESULT_LABELS[a.result]}, {b.entry.file_name} "
                         f"{RESULT_LABELS[b.result]}: compare results of one kind")


def comparison_csv(tables: Sequence[ComparisonTable]) -> str:
    """The tables as CSV text: each table's name, its header row and rows, a blank line between."""
    import csv
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


__all__ = ["open_library", "TimeWindow", "ComparedSession", "ComparisonTable", "rom_table", "COMPARISON_TABLES",
           "COMPARISON_NEEDS_CALIBRATION", "check_comparable", "compare", "comparison_csv"]
