"""Joint-angle files: MimuCap CSV and OpenSim motion (``.mot``), written and read back.

Both hold ``t_s`` (N,) seconds and one column per joint and axis, named
``<joint>_<flexion|adduction|rotation>_deg`` (shoulder X-Z'-Y'' and Y-X'-Y'' columns are named
for their meaning, see :func:`mimucap.core.skeleton.joint_angle_columns`), in degrees.

* CSV: ``#`` comment lines state the Euler sequence of every joint, the sign convention
  (:data:`mimucap.core.skeleton.JOINT_ANGLE_SIGNS_DOC`), units and provenance, every column's
  readable label and sign (``column knee_r_flexion_deg: Right knee flexion (°); + flexion /
  − extension``, from :mod:`mimucap.core.clinical_names`) and the markers of the record
  (``marker 12.340000 "heel strike"``: time in s on the ``t_s`` axis, the label as a JSON
  string); then the header ``t_s,<columns>`` and one row per sample.
* ``.mot``: OpenSim's storage format: a name line, ``version=1``, ``nRows``, ``nColumns``
  (counting ``time``), ``inDegrees=yes``, free description lines, ``endheader``, then a
  tab-separated table whose first column is ``time``. Description lines carry no ``=``
  (OpenSim reads ``key=value`` header lines as metadata); they hold the same column and marker
  lines as the CSV. With ``opensim_names`` the columns are named as the OpenSim model's
  coordinates instead (``hip_flexion_r``, ``knee_angle_r``, ``lumbar_extension``…, with OpenSim's
  signs; the table is :data:`mimucap.io.opensense.OPENSIM_COORDINATES`), so that OpenSim loads the
  file as a motion of its Rajagopal or gait2392-style models.

Both may carry, after a joint's three angle columns, its **trust column** ``<joint>_ok``: 1
where the joint's angles are trustworthy, 0 where they are doubtful (the reasons of
:mod:`mimucap.core.doubt`: a magnetometer rejected for longer than the gyroscope can bridge, a
heading taken from a foreign magnetic field, lost samples, no body calibration…). The header
explains the column and lists every doubtful span of each joint with its reasons in words
(:func:`doubt_lines`). A ``.mot`` named for OpenSim coordinates carries the spans only (OpenSim
would take another column for a coordinate).

Any later export format writes its markers with :func:`marker_lines` and reads them back with
:func:`parse_marker_line`, so that a marker reads the same in every file.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mimucap.core.clinical_names import angle_label, angle_sign_text
from mimucap.core.skeleton import JOINT_ANGLE_SIGNS_DOC
from mimucap.io.session import Marker

#: How a marker line starts in a header (after the comment sign of the format).
MARKER_PREFIX = "marker "
#: How a column's label line starts.
COLUMN_PREFIX = "column "
#: The suffix of a joint's trust column.
OK_SUFFIX = "_ok"
#: Doubtful spans closer than this (s) are listed as one.
DOUBT_SPAN_JOIN_S = 1.0
#: Spans listed per joint at most (the rest are counted).
DOUBT_SPANS_LISTED = 40


@dataclass(frozen=True)
class AnglesTable:
    """Joint angles read back from a file: ``t_s`` (N,), ``angles_deg`` column → (N,), header
    notes, ``labels`` column → readable label, ``markers`` of the record (times in s on the
    ``t_s`` axis), ``ok`` joint → (N,) bool (its trust column, when the file has one)."""

    t_s: np.ndarray
    angles_deg: Mapping[str, np.ndarray]
    header: Sequence[str] = field(default_factory=tuple)
    labels: Mapping[str, str] = field(default_factory=dict)
    markers: Sequence[Marker] = field(default_factory=tuple)
    ok: Mapping[str, np.ndarray] = field(default_factory=dict)


def marker_lines(markers: Sequence[Marker]) -> list[str]:
    """Header lines for ``markers``: a count line, then ``marker <t_s> <label as JSON>`` each,
    in time order. A JSON string keeps any label on one line (quotes, commas, tabs, non-ASCII);
    ``=`` is written as ``\\u003d`` so that OpenSim never takes the line for ``key=value``."""
    ordered = sorted(markers, key=lambda m: m.t_s)
    lines = [f"Markers: {len(ordered)} (time in s on the table's time axis, then the label)"]
    for marker in ordered:
        if not np.isfinite(marker.t_s):
            raise ValueError(f"marker {marker.label!r} has no finite time ({marker.t_s})")
        label = json.dumps(str(marker.label), ensure_ascii=False).replace("=", "\\u003d")
        lines.append(f"{MARKER_PREFIX}{marker.t_s:.6f} {label}")
    return lines


def parse_marker_line(line: str) -> Marker | None:
    """The marker a header line written by :func:`marker_lines` holds (``None`` for another
    line); ``ValueError`` for a marker line that is damaged."""
    if not line.startswith(MARKER_PREFIX):
        return None
    time_text, _sep, label = line[len(MARKER_PREFIX):].partition(" ")
    try:
        return Marker(float(time_text), str(json.loads(label)))
    except (ValueError, json.JSONDecodeError):
        raise ValueError(f"damaged marker line {line!r}: expected 'marker <seconds> \"label\"'") from None


def column_lines(columns: Sequence[str]) -> list[str]:
    """``column <name>: <readable label>; <sign>`` for each column (no ``=``, no comma needed)."""
    lines = []
    for column in columns:
        sign = angle_sign_text(column)
        lines.append(f"{COLUMN_PREFIX}{column}: {angle_label(column)}" + (f"; {sign}" if sign else ""))
    return lines


def doubt_lines(t_s: np.ndarray, joint_doubt: Mapping[str, np.ndarray]) -> list[str]:
    """Header lines explaining the trust columns and listing, per joint, the doubtful spans
    (times in s on the table's axis) and their reasons in words."""
    from mimucap.core.doubt import describe, spans

    lines = ["Trust: <joint>_ok is 1 where the joint's angles are trustworthy and 0 where they may be wrong "
             "(the orientation of a sensor it uses, or the body calibration, is doubtful)"]
    for joint, reasons in joint_doubt.items():
        found = spans(t_s, reasons, DOUBT_SPAN_JOIN_S)
        doubtful = float(np.count_nonzero(np.asarray(reasons))) / max(len(reasons), 1)
        lines.append(f"doubtful {joint}: {100.0 * doubtful:.1f} % of the samples, {len(found)} span(s)")
        for start, stop, bits in found[:DOUBT_SPANS_LISTED]:
            lines.append(f"doubtful {joint} {start:.3f}-{stop:.3f} s: {describe(bits)}")
        if len(found) > DOUBT_SPANS_LISTED:
            lines.append(f"doubtful {joint}: {len(found) - DOUBT_SPANS_LISTED} more span(s)")
    return lines


def _read_header(header: Sequence[str], path: Path) -> tuple[dict[str, str], tuple[Marker, ...]]:
    labels: dict[str, str] = {}
    markers: list[Marker] = []
    for line in header:
        try:
            marker = parse_marker_line(line)
        except ValueError as error:
            raise ValueError(f"{path}: {error}") from None
        if marker is not None:
            markers.append(marker)
        elif line.startswith(COLUMN_PREFIX) and ": " in line:
            name, _sep, rest = line[len(COLUMN_PREFIX):].partition(": ")
            labels[name] = rest.split("; ", 1)[0]
    return labels, tuple(markers)


def sequence_description(shoulder_sequence: str) -> str:
    """One line naming the Euler sequence of every joint."""
    shoulder = {"zxy": "Z-X'-Y''", "xzy": "X-Z'-Y''", "yxy": "Y-X'-Y'' (ISB)"}.get(shoulder_sequence.lower())
    if shoulder is None:
        raise ValueError(f"unknown shoulder sequence {shoulder_sequence!r}; use zxy, xzy or yxy")
    return f"Euler sequences (intrinsic): shoulders {shoulder}; every other joint Z-X'-Y''"


def _check(t_s: np.ndarray, angles: Mapping[str, np.ndarray],
           unit_suffix: bool = True) -> tuple[np.ndarray, list[str], np.ndarray]:
    t = np.asarray(t_s, dtype=np.float64)
    if t.ndim != 1 or t.size == 0:
        raise ValueError("joint angles need a non-empty 1-D time axis t_s")
    if not angles:
        raise ValueError("no joint angle columns to write")
    columns = list(angles)
    for name in columns:
        if (unit_suffix and not name.endswith("_deg")) or any(c in name for c in " \t,"):
            raise ValueError(f"joint angle column {name!r} must end in '_deg' and hold no blank or comma")
    data = np.column_stack([np.asarray(angles[c], dtype=np.float64) for c in columns]) if columns else None
    if data.shape[0] != t.size:
        raise ValueError(f"joint angle columns have {data.shape[0]} rows, t_s has {t.size}")
    return t, columns, data + 0.0  # no "-0.000000" in the files


def _notes(shoulder_sequence: str, notes: Sequence[str], columns: Sequence[str],
           markers: Sequence[Marker], doubt: Sequence[str] = ()) -> list[str]:
    lines = ["MimuCap joint angles", sequence_description(shoulder_sequence)]
    lines += JOINT_ANGLE_SIGNS_DOC.splitlines()
    lines += ["Units: t_s in seconds; every <joint>_<axis>_deg column in degrees"]
    lines += list(notes)
    lines += ["Columns: machine name, readable label, sign"] + column_lines(columns)
    lines += list(doubt)
    lines += marker_lines(markers)
    return lines


def _with_trust(t: np.ndarray, columns: list[str], data: np.ndarray,
                joint_doubt: Mapping[str, np.ndarray] | None) -> tuple[list[str], np.ndarray, list[str]]:
    """The table with each joint's trust column after its angle columns (for the joints of
    ``joint_doubt`` that have columns), and the header lines that explain them."""
    if not joint_doubt:
        return columns, data, []
    out_columns: list[str] = []
    out_data: list[np.ndarray] = []
    used = {}
    for index, column in enumerate(columns):
        out_columns.append(column)
        out_data.append(data[:, index])
        joint = next((j for j in joint_doubt if column.startswith(j + "_")), None)
        following = columns[index + 1] if index + 1 < len(columns) else ""
        if joint is not None and not following.startswith(joint + "_"):
            reasons = np.asarray(joint_doubt[joint])
            if reasons.shape != t.shape:
                raise ValueError(f"the trust of joint {joint} has {reasons.shape[0]} rows, t_s has {t.size}")
            out_columns.append(joint + OK_SUFFIX)
            out_data.append((reasons == 0).astype(np.float64))
            used[joint] = reasons
    return out_columns, np.column_stack(out_data), doubt_lines(t, used)


def _cell(column: str, value: float) -> str:
    return f"{int(value)}" if column.endswith(OK_SUFFIX) else f"{value:.6f}"


def write_angles_csv(
    path: str | Path,
    t_s: np.ndarray,
    angles_deg: Mapping[str, np.ndarray],
    shoulder_sequence: str = "zxy",
    notes: Sequence[str] = (),
    markers: Sequence[Marker] = (),
    joint_doubt: Mapping[str, np.ndarray] | None = None,
) -> None:
    """Write joint angles (deg) as CSV with a commented header; ``notes`` are extra comment
    lines, ``markers`` (times in s on the ``t_s`` axis) go in the header's marker table;
    ``joint_doubt`` joint → (N,) reasons (:mod:`mimucap.core.doubt`) adds its trust column."""
    t, columns, data = _check(t_s, angles_deg)
    angle_columns = columns
    columns, data, doubt = _with_trust(t, columns, data, joint_doubt)
    header = _notes(shoulder_sequence, notes, angle_columns, markers, doubt)
    with Path(path).open("w", encoding="utf-8", newline="") as handle:
        for line in header:
            handle.write(f"# {line}\n")
        handle.write(",".join(["t_s"] + columns) + "\n")
        for time, row in zip(t, data):
            handle.write(f"{time:.6f}," + ",".join(_cell(c, v) for c, v in zip(columns, row)) + "\n")


def write_angles_mot(
    path: str | Path,
    t_s: np.ndarray,
    angles_deg: Mapping[str, np.ndarray],
    shoulder_sequence: str = "zxy",
    notes: Sequence[str] = (),
    name: str = "mimucap_joint_angles",
    opensim_names: bool = False,
    markers: Sequence[Marker] = (),
    joint_doubt: Mapping[str, np.ndarray] | None = None,
) -> None:
    """Write joint angles (deg) as an OpenSim ``.mot`` motion with ``inDegrees=yes``;
    ``markers`` (times in s on the time axis) go in its description lines; ``joint_doubt``
    joint → (N,) reasons (:mod:`mimucap.core.doubt`) adds the trust columns (with
    ``opensim_names`` the doubtful spans only).

    ``opensim_names``: name the columns as OpenSim coordinates with OpenSim's signs (see the
    module doc; needs the shoulder's Z-X'-Y'' columns for ``arm_flex``/``arm_add``/``arm_rot``);
    joint-angle columns without an OpenSim coordinate are left out."""
    if opensim_names:
        from mimucap.io.opensense import OPENSIM_COORDINATES, opensim_coordinates

        if shoulder_sequence.lower() != "zxy":
            raise ValueError(f"{path}: OpenSim's arm_flex/arm_add/arm_rot are Z-X'-Y'' angles: "
                             f"export with the zxy shoulder sequence, not {shoulder_sequence}")

        renamed = opensim_coordinates(angles_deg)
        if not renamed:
            raise ValueError(f"{path}: no joint-angle column has an OpenSim coordinate")
        notes = list(notes) + [
            "Columns are OpenSim coordinates (Rajagopal 2015 names and signs), computed from MimuCap's angles: "
            + "; ".join(f"{c} = {'-' if OPENSIM_COORDINATES[c][1] < 0 else ''}{OPENSIM_COORDINATES[c][0]}"
                        for c in renamed)]
        t, columns, data = _check(t_s, renamed, unit_suffix=False)
        labelled = [OPENSIM_COORDINATES[c][0] for c in columns]
        doubt = doubt_lines(t, joint_doubt) if joint_doubt else []
    else:
        t, columns, data = _check(t_s, angles_deg)
        labelled = columns
        columns, data, doubt = _with_trust(t, columns, data, joint_doubt)
    header = _notes(shoulder_sequence, notes, labelled, markers, doubt)
    with Path(path).open("w", encoding="utf-8", newline="") as handle:
        handle.write(f"{name}\nversion=1\nnRows={t.size}\nnColumns={len(columns) + 1}\ninDegrees=yes\n\n")
        handle.write("Units are S.I. units (second, meters, Newtons, ...)\n")
        handle.write("If the header above contains a line with 'inDegrees', this indicates whether "
                     "rotational values are in degrees (yes) or radians (no).\n")
        for line in header:
            handle.write(line.replace("=", ":") + "\n")
        handle.write("\nendheader\n")
        handle.write("\t".join(["time"] + columns) + "\n")
        for time, row in zip(t, data):
            handle.write(f"{time:.6f}\t" + "\t".join(_cell(c, v) for c, v in zip(columns, row)) + "\n")


def write_angles(path: str | Path, t_s, angles_deg, shoulder_sequence: str = "zxy", notes: Sequence[str] = (),
                 opensim_names: bool = False, markers: Sequence[Marker] = (),
                 joint_doubt: Mapping[str, np.ndarray] | None = None) -> None:
    """Write ``.csv`` or ``.mot`` by the file's suffix (``opensim_names`` only for ``.mot``)."""
    suffix = Path(path).suffix.lower()
    if opensim_names and suffix != ".mot":
        raise ValueError(f"{path}: OpenSim coordinate names are for .mot files")
    if suffix == ".csv":
        write_angles_csv(path, t_s, angles_deg, shoulder_sequence, notes, markers, joint_doubt)
    elif suffix == ".mot":
        write_angles_mot(path, t_s, angles_deg, shoulder_sequence, notes, opensim_names=opensim_names, markers=markers,
                         joint_doubt=joint_doubt)
    else:
        raise ValueError(f"{path}: joint angles are written as .csv or .mot, not {suffix or 'no suffix'!r}")


def read_angles_csv(path: str | Path) -> AnglesTable:
    """Read a joint-angle CSV written by :func:`write_angles_csv`."""
    path = Path(path)
    header: list[str] = []
    columns = None
    rows = []
    for number, raw in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if raw.startswith("#"):
            header.append(raw[1:].strip())
            continue
        if not raw.strip():
            continue
        cells = raw.split(",")
        if columns is None:
            columns = cells
            if columns[0] != "t_s":
                raise ValueError(f"{path}: line {number}: the first column must be t_s")
            continue
        if len(cells) != len(columns):
            raise ValueError(f"{path}: line {number}: {len(cells)} fields, the header has {len(columns)}")
        try:
            rows.append([float(c) for c in cells])
        except ValueError:
            raise ValueError(f"{path}: line {number}: not a number") from None
    if columns is None:
        raise ValueError(f"{path}: no header line")
    data = np.array(rows).reshape(len(rows), len(columns))
    labels, markers = _read_header(header, path)
    return AnglesTable(data[:, 0], {c: data[:, i] for i, c in enumerate(columns) if i > 0 and not c.endswith(OK_SUFFIX)},
                       tuple(header), labels, markers, _trust(columns, data))


def _trust(columns: Sequence[str], data: np.ndarray) -> dict[str, np.ndarray]:
    """Joint → its trust column as bool, for the ``<joint>_ok`` columns of a table."""
    return {c[:-len(OK_SUFFIX)]: data[:, i] != 0 for i, c in enumerate(columns) if c.endswith(OK_SUFFIX)}


def read_angles_mot(path: str | Path) -> AnglesTable:
    """Read an OpenSim ``.mot``; angles in radians (``inDegrees=no``) are converted to degrees."""
    path = Path(path)
    lines = path.read_text(encoding="utf-8").splitlines()
    try:
        end = next(i for i, line in enumerate(lines) if line.strip().lower() == "endheader")
    except StopIteration:
        raise ValueError(f"{path}: no 'endheader' line: not an OpenSim motion file") from None
    header = [line.strip() for line in lines[:end]]
    meta = dict(h.split("=", 1) for h in header if "=" in h)
    in_degrees = meta.get("inDegrees", "yes").strip().lower() == "yes"
    columns = lines[end + 1].split("\t")
    if columns[0].strip().lower() != "time":
        raise ValueError(f"{path}: line {end + 2}: the first column must be time")
    rows = []
    for number, line in enumerate(lines[end + 2:], start=end + 3):
        if not line.strip():
            continue
        cells = line.split("\t")
        if len(cells) != len(columns):
            raise ValueError(f"{path}: line {number}: {len(cells)} fields, the header has {len(columns)}")
        rows.append([float(c) for c in cells])
    data = np.array(rows).reshape(len(rows), len(columns))
    if "nRows" in meta and int(meta["nRows"]) != data.shape[0]:
        raise ValueError(f"{path}: nRows={meta['nRows']} but {data.shape[0]} rows follow")
    if "nColumns" in meta and int(meta["nColumns"]) != len(columns):
        raise ValueError(f"{path}: nColumns={meta['nColumns']} but {len(columns)} columns follow")
    scale = 1.0 if in_degrees else 180.0 / np.pi
    labels, markers = _read_header(header, path)
    return AnglesTable(data[:, 0], {c: data[:, i] * scale for i, c in enumerate(columns)
                                    if i > 0 and not c.endswith(OK_SUFFIX)}, tuple(header),
                       labels, markers, _trust(columns, data))
