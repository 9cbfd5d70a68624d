"""Orientation tables: one time axis, one ``q_world_from_sensor`` series per sensor, and the two
generic table formats.

:class:`QuaternionTable` is what every orientation reader returns: ``t_s`` (N,) seconds as the
file gives them (CSV ``t_s``, ``.sto`` ``time``; vendor files that count packets or Unix
microseconds start at 0), and for each sensor ``q_world_from_sensor`` (N, 4), scalar-first
Hamilton unit quaternions mapping sensor coordinates into the table's world frame. The world
frame is whatever the file uses; its **up** direction is declared in ``up_world`` (unit vector
in world coordinates), because body calibration needs to know which way is up and nothing else
about the world.

Formats read here (the vendors' in :mod:`mimucap.io.xsens_text` and :mod:`mimucap.io.apdm_csv`;
:mod:`mimucap.io.orientation_inputs` picks the reader of a path):

* MimuCap CSV: ``#`` comment lines, then a header ``t_s,<s>_qw,<s>_qx,<s>_qy,<s>_qz,...``.
  World frame ENU (up +z) unless a comment line ``# up_axis: <axis>`` says otherwise.
* OpenSim quaternion table ``.sto`` (``DataType=Quaternion``; header up to ``endheader``, a
  ``time`` column, one ``w,x,y,z`` cell per sensor). OpenSim's *ground* is Y-up, but the
  quaternion tables that OpenSense's IMU readers write (Xsens, APDM) keep the **vendor's world
  frame** (ENU, z up); OpenSense's ``IMUPlacer`` only later maps it to ground with
  ``sensor_to_opensim_rotations = (-π/2, 0, 0)`` (a −90° turn about x, which takes z up to
  y up). So ``.sto`` tables default to up = +z; pass ``up_axis="y"`` for a table that is
  already expressed in OpenSim ground. (Check on the OpenSense example: its ``.sto`` rows equal
  the Xsens ENU exports of the same trial, and the leg sensors' long axes point along +z.)

Bad input raises ``ValueError`` naming the file, line and sensor: malformed rows, missing
columns, NaN or zero quaternions, non-increasing time (:func:`checked_unit`,
:func:`parse_float`, :func:`check_time`, shared by the vendor readers).
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: A quaternion whose norm is outside ``1 ± QUATERNION_NORM_TOLERANCE`` is rejected as corrupt.
QUATERNION_NORM_TOLERANCE = 0.05

_AXES = {
    "x": (1.0, 0.0, 0.0), "+x": (1.0, 0.0, 0.0), "-x": (-1.0, 0.0, 0.0),
    "y": (0.0, 1.0, 0.0), "+y": (0.0, 1.0, 0.0), "-y": (0.0, -1.0, 0.0),
    "z": (0.0, 0.0, 1.0), "+z": (0.0, 0.0, 1.0), "-z": (0.0, 0.0, -1.0),
}


def axis_vector(spec: str) -> np.ndarray:
    """Unit vector (3,) of an axis name ``x``, ``+y``, ``-z`` ...; ``ValueError`` otherwise."""
    key = str(spec).strip().lower()
    if key not in _AXES:
        raise ValueError(f"unknown axis {spec!r}: use x, y, z, -x, -y or -z")
    return np.array(_AXES[key])


@dataclass(frozen=True)
class QuaternionTable:
    """Sensor orientations on one time axis.

    ``t_s`` (N,) float64 seconds, strictly increasing; ``q_world_from_sensor`` maps sensor
    id to (N, 4) unit quaternions (w, x, y, z); ``up_world`` (3,) is the unit up direction in
    world coordinates; ``world_frame`` names the world frame; ``source`` the file it came from;
    ``segment_hints`` the body segment each sensor was recorded as worn on, when the file says;
    ``doubt`` sensor → (N,) the reasons each orientation may be wrong (``uint16`` bits of
    :mod:`mimucap.core.pipeline.doubt_reasons`), when the orientations come from MimuCap's processing path.
    """

    t_s: np.ndarray
    q_world_from_sensor: Mapping[str, np.ndarray]
    up_world: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    world_frame: str = "ENU"
    source: str = ""
    segment_hints: Mapping[str, str] = field(default_factory=dict)
    doubt: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        t = np.asarray(self.t_s, dtype=np.float64)
        if t.ndim != 1 or t.size == 0:
            raise ValueError(f"{self.source}: a quaternion table needs at least one sample")
        if np.any(~np.isfinite(t)) or np.any(np.diff(t) <= 0.0):
            raise ValueError(f"{self.source}: time must be finite and strictly increasing")
        quats = {}
        for sensor, q in self.q_world_from_sensor.items():
            q = np.asarray(q, dtype=np.float64)
            if q.shape != (t.size, 4):
                raise ValueError(
                    f"{self.source}: sensor {sensor} has quaternions of shape {q.shape}, "
                    f"expected ({t.size}, 4)"
                )
            quats[str(sensor)] = checked_unit(q, self.source, str(sensor))
        if not quats:
            raise ValueError(f"{self.source}: no sensor orientations found")
        up = np.asarray(self.up_world, dtype=np.float64)
        if up.shape != (3,) or not np.isclose(np.linalg.norm(up), 1.0):
            raise ValueError(f"{self.source}: up_world must be a unit 3-vector, got {up}")
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "q_world_from_sensor", quats)
        object.__setattr__(self, "up_world", up)
        object.__setattr__(self, "segment_hints", dict(self.segment_hints))

    @property
    def sensor_ids(self) -> tuple[str, ...]:
        """Sensor ids in file order."""
        return tuple(self.q_world_from_sensor)

    def __len__(self) -> int:
        return int(self.t_s.size)


def checked_unit(q: np.ndarray, source: str, sensor: str, lines: np.ndarray | None = None) -> np.ndarray:
    """Reject NaN, zero and far-from-unit quaternions (naming the row); return them normalised."""
    norm = np.linalg.norm(q, axis=-1)
    bad = ~np.isfinite(norm) | (np.abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE)
    if np.any(bad):
        index = int(np.flatnonzero(bad)[0])
        where = f"line {int(lines[index])}" if lines is not None else f"row {index}"
        kind = "NaN" if not np.all(np.isfinite(q[index])) else f"non-unit (norm {norm[index]:.3g})"
        raise ValueError(
            f"{source}: {where}: sensor {sensor}: {kind} quaternion {q[index].tolist()} "
            f"({int(bad.sum())} bad rows in all)"
        )
    return q / norm[:, None]


def parse_float(text: str, source: str, line: int, column: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"{source}: line {line}: column {column}: not a number: {text!r}") from None


_CSV_COMPONENTS = ("qw", "qx", "qy", "qz")


def _parse_numeric_rows(lines: list[str], numbers: list[int], header: list[str], source: str) -> np.ndarray:
    """Comma-separated numeric rows (N, len(header)); empty cells are NaN. Fast path with
    numpy; on failure the rows are parsed one by one to name the first bad line and column."""
    width = len(header)
    if not lines:
        return np.empty((0, width))
    try:
        data = np.loadtxt(lines, delimiter=",", dtype=np.float64, ndmin=2)
        if data.shape[1] == width:
            return data
    except ValueError:
        pass
    rows = []
    for number, text in zip(numbers, lines):
        cells = [c.strip() for c in next(csv.reader([text]))]
        if len(cells) != width:
            raise ValueError(f"{source}: line {number}: {len(cells)} fields, the header has {width}")
        rows.append([parse_float(c, source, number, header[i]) if c else math.nan for i, c in enumerate(cells)])
    return np.array(rows, dtype=np.float64)


def read_quaternion_csv(path: str | Path, up_axis: str | None = None) -> QuaternionTable:
    """Read a MimuCap quaternion CSV (``t_s`` and ``<sensor>_qw.._qz`` columns)."""
    path = Path(path)
    source = str(path)
    declared_up = None
    declared_up_line = 0
    header: list[str] | None = None
    data_lines: list[str] = []
    line_numbers: list[int] = []
    with path.open(newline="", encoding="utf-8") as handle:
        for number, raw in enumerate(handle, start=1):
            text = raw.strip()
            if not text:
                continue
            if text.startswith("#"):
                match = re.match(r"#\s*up_axis\s*[:=]\s*(\S+)", text)
                if match:
                    declared_up, declared_up_line = match.group(1), number
                continue
            if header is None:
                header = [c.strip() for c in next(csv.reader([text]))]
                continue
            data_lines.append(text)
            line_numbers.append(number)
    if header is None:
        raise ValueError(f"{source}: empty file (no header line)")
    if "t_s" not in header:
        raise ValueError(f"{source}: no 't_s' column in the header")
    data = _parse_numeric_rows(data_lines, line_numbers, header, source)
    lines = np.array(line_numbers)
    sensors: dict[str, np.ndarray] = {}
    for column in header:
        if column.endswith("_qw"):
            sensor = column[:-3]
            names = [f"{sensor}_{c}" for c in _CSV_COMPONENTS]
            missing = [n for n in names if n not in header]
            if missing:
                raise ValueError(f"{source}: sensor {sensor}: missing column(s) {', '.join(missing)}")
            q = data[:, [header.index(n) for n in names]]
            sensors[sensor] = checked_unit(q, source, sensor, lines)
    orphans = [c for c in header if re.search(r"_q[xyz]$", c) and c[:-3] not in sensors]
    if orphans:
        raise ValueError(f"{source}: quaternion column(s) without '_qw': {', '.join(orphans)}")
    if not sensors:
        raise ValueError(f"{source}: no '<sensor>_qw,_qx,_qy,_qz' columns in the header")
    t = data[:, header.index("t_s")]
    check_time(t, source, lines)
    if up_axis is not None:
        up = axis_vector(up_axis)
    elif declared_up is not None:
        try:
            up = axis_vector(declared_up)
        except ValueError as error:
            raise ValueError(f"{source}: line {declared_up_line}: '# up_axis': {error}") from None
    else:
        up = axis_vector("z")
    return QuaternionTable(t, sensors, up, "ENU" if up[2] == 1.0 else "declared", source)


def write_quaternion_csv(path: str | Path, table: QuaternionTable) -> None:
    """Write ``table`` as a MimuCap quaternion CSV (with its up axis as a comment)."""
    up_name = next(k for k, v in _AXES.items() if np.allclose(v, table.up_world) and len(k) <= 2)
    columns = ["t_s"] + [f"{s}_{c}" for s in table.sensor_ids for c in _CSV_COMPONENTS]
    data = np.column_stack([table.t_s] + [table.q_world_from_sensor[s] for s in table.sensor_ids])
    with Path(path).open("w", encoding="utf-8", newline="") as handle:
        handle.write("# MimuCap quaternion table: q_world_from_sensor (w, x, y, z) per sensor\n")
        handle.write(f"# world frame: {table.world_frame}\n# up_axis: {up_name}\n")
        handle.write(",".join(columns) + "\n")
        np.savetxt(handle, data, fmt="%.10g", delimiter=",")


def check_time(t: np.ndarray, source: str, lines: np.ndarray) -> None:
    if t.size == 0:
        raise ValueError(f"{source}: no data rows")
    bad = ~np.isfinite(t)
    if np.any(bad):
        raise ValueError(f"{source}: line {int(lines[np.argmax(bad)])}: time is not a number")
    step = np.diff(t) <= 0.0
    if np.any(step):
        raise ValueError(
            f"{source}: line {int(lines[np.argmax(step) + 1])}: time does not increase"
        )


def read_opensim_sto(path: str | Path, up_axis: str | None = None) -> QuaternionTable:
    """Read an OpenSim quaternion table (``DataType=Quaternion``); up defaults to +z (see module doc)."""
    path = Path(path)
    source = str(path)
    lines = path.read_text(encoding="utf-8").splitlines()
    try:
        end = next(i for i, line in enumerate(lines) if line.strip().lower() == "endheader")
    except StopIteration:
        raise ValueError(f"{source}: no 'endheader' line: not an OpenSim table") from None
    header_lines = [line.strip() for line in lines[:end]]
    data_type = next((h.split("=", 1)[1] for h in header_lines if h.lower().startswith("datatype=")), None)
    if data_type is not None and data_type.strip().lower() != "quaternion":
        raise ValueError(f"{source}: DataType={data_type} is not Quaternion")
    if end + 1 >= len(lines):
        raise ValueError(f"{source}: no column labels after 'endheader'")
    labels = [c.strip() for c in lines[end + 1].split("\t")]
    if labels[0].lower() != "time":
        raise ValueError(f"{source}: line {end + 2}: first column must be 'time', got {labels[0]!r}")
    sensors = labels[1:]
    if not sensors:
        raise ValueError(f"{source}: no sensor columns")
    times: list[float] = []
    quats: list[list[list[float]]] = []
    numbers: list[int] = []
    for number, line in enumerate(lines[end + 2:], start=end + 3):
        if not line.strip():
            continue
        cells = line.rstrip("\r\n").split("\t")
        if len(cells) != len(labels):
            raise ValueError(f"{source}: line {number}: {len(cells)} cells, expected {len(labels)}")
        times.append(parse_float(cells[0], source, number, "time"))
        row = []
        for label, cell in zip(sensors, cells[1:]):
            parts = cell.split(",")
            if len(parts) != 4:
                raise ValueError(
                    f"{source}: line {number}: sensor {label}: expected 'w,x,y,z', got {cell!r}"
                )
            row.append([parse_float(p, source, number, label) for p in parts])
        quats.append(row)
        numbers.append(number)
    t = np.array(times)
    line_array = np.array(numbers)
    check_time(t, source, line_array)
    q = np.array(quats).reshape(len(times), len(sensors), 4)
    table = {s: checked_unit(q[:, i], source, s, line_array) for i, s in enumerate(sensors)}
    up = axis_vector(up_axis or "z")
    frame = "IMU vendor world (as written by OpenSense readers)" if up_axis is None else "declared"
    return QuaternionTable(t, table, up, frame, source)
