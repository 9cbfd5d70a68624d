"""Orientation tables from files: one time axis, one ``q_world_from_sensor`` series per sensor.

Every reader returns a :class:`QuaternionTable`: ``t_s`` (N,) seconds as the file gives them
(CSV ``t_s``, ``.sto`` ``time``, session host time; Xsens and APDM files, which count packets
or Unix microseconds, start at 0), and for each sensor ``q_world_from_sensor`` (N, 4), scalar-first Hamilton unit quaternions
mapping sensor coordinates into the table's world frame. The world frame is whatever the file
uses; its **up** direction is declared in ``up_world`` (unit vector in world coordinates),
because body calibration needs to know which way is up and nothing else about the world.

Supported inputs (:func:`read_quaternion_table` picks the reader):

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
* Xsens MT Manager text exports (a single ``.txt`` or a folder of ``<trial>_<DeviceId>.txt``):
  old (``// Update Rate``) and new (``// General information``) headers; tab, comma,
  semicolon or single-space delimiters with empty fields kept; orientation from
  ``Quat_q0..q3`` (q_world_from_sensor, w first), else ``Mat[i][j]`` (R_world_from_sensor,
  written column by column), else ``Roll, Pitch, Yaw`` in degrees
  (``R = Rz(yaw)·Ry(pitch)·Rx(roll)``). ``// Coordinate system: NED`` or ``NWU`` exports are
  turned into ENU. A packet exported without any orientation value is skipped (and
  counted). Time is ``PacketCounter`` (16-bit, unwrapped) divided by the update rate;
  sensors of one trial are aligned on their common packet counters (a packet lost by any
  sensor drops that instant). An OpenSense mapping file (``myIMUMappings.xml``) selects the
  trial and renames device ids to ``name_in_model``.
* APDM ``Format=7`` CSV (found among OpenSense's format samples): one block per sensor with
  ``Orientation S,X,Y,Z`` = q_world_from_sensor in a z-up world; ``Time`` in microseconds.

MimuCap sessions and BROAD trials hold raw samples, not orientations: they are recognised
(:func:`orientation_input_kind`) and refused by :func:`read_quaternion_table`, since their
orientations come from the processing path (:mod:`mimucap.core.pipeline`), never from a reader.

Bad input raises ``ValueError`` naming the file, line and sensor: malformed rows, missing
columns, NaN or zero quaternions, non-increasing time.
"""

from __future__ import annotations

import csv
import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mimucap.core import rotation
from mimucap.io.input_names import (
    APDM_CSV, BROAD_TRIAL, MIMUCAP_SESSION, OPENSIM_STO, QUATERNION_CSV, SESSION_SUFFIXES, XSENS_FILE,
    XSENS_FOLDER,
)

#: A quaternion whose norm is outside ``1 ± QUATERNION_NORM_TOLERANCE`` is rejected as corrupt.
QUATERNION_NORM_TOLERANCE = 0.05

#: Xsens MTw default update rate, used when an export's header does not state one (Hz).
XSENS_DEFAULT_RATE_HZ = 100.0

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
    :mod:`mimucap.core.doubt`), when the orientations come from MimuCap's processing path.
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
            quats[str(sensor)] = _checked_unit(q, self.source, str(sensor))
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


def _checked_unit(q: np.ndarray, source: str, sensor: str, lines: np.ndarray | None = None) -> np.ndarray:
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


def _float(text: str, source: str, line: int, column: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"{source}: line {line}: column {column}: not a number: {text!r}") from None


# --------------------------------------------------------------------------------------------
# MimuCap CSV
# --------------------------------------------------------------------------------------------

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
        rows.append([_float(c, source, number, header[i]) if c else math.nan for i, c in enumerate(cells)])
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
            sensors[sensor] = _checked_unit(q, source, sensor, lines)
    orphans = [c for c in header if re.search(r"_q[xyz]$", c) and c[:-3] not in sensors]
    if orphans:
        raise ValueError(f"{source}: quaternion column(s) without '_qw': {', '.join(orphans)}")
    if not sensors:
        raise ValueError(f"{source}: no '<sensor>_qw,_qx,_qy,_qz' columns in the header")
    t = data[:, header.index("t_s")]
    _check_time(t, source, lines)
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


def _check_time(t: np.ndarray, source: str, lines: np.ndarray) -> None:
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


# --------------------------------------------------------------------------------------------
# OpenSim .sto
# --------------------------------------------------------------------------------------------

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
        times.append(_float(cells[0], source, number, "time"))
        row = []
        for label, cell in zip(sensors, cells[1:]):
            parts = cell.split(",")
            if len(parts) != 4:
                raise ValueError(
                    f"{source}: line {number}: sensor {label}: expected 'w,x,y,z', got {cell!r}"
                )
            row.append([_float(p, source, number, label) for p in parts])
        quats.append(row)
        numbers.append(number)
    t = np.array(times)
    line_array = np.array(numbers)
    _check_time(t, source, line_array)
    q = np.array(quats).reshape(len(times), len(sensors), 4)
    table = {s: _checked_unit(q[:, i], source, s, line_array) for i, s in enumerate(sensors)}
    up = axis_vector(up_axis or "z")
    frame = "IMU vendor world (as written by OpenSense readers)" if up_axis is None else "declared"
    return QuaternionTable(t, table, up, frame, source)


# --------------------------------------------------------------------------------------------
# Xsens MT Manager text exports
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class XsensRecording:
    """One Xsens export file.

    ``packet_counter`` (N,) int64 unwrapped; ``q_world_from_sensor`` (N, 4) in ENU, or
    ``None`` for an export without orientation columns (e.g. accelerations only);
    ``acc`` m/s², ``gyr`` rad/s and ``mag_au`` (Xsens arbitrary units, normalised to the
    local field) are (N, 3) in the sensor frame or ``None`` when not exported; NaN where a
    row had no value; ``rate_hz`` the update rate (from the header, else the default);
    ``rows_without_orientation`` the number of packets skipped because they had no orientation.
    """

    device_id: str
    path: Path
    packet_counter: np.ndarray
    q_world_from_sensor: np.ndarray | None
    rate_hz: float
    rate_from_header: bool
    coordinate_system: str
    orientation_source: str
    acc: np.ndarray | None
    gyr: np.ndarray | None
    mag_au: np.ndarray | None
    rows_without_orientation: int = 0

    @property
    def t_s(self) -> np.ndarray:
        """Seconds since the first packet (N,)."""
        return (self.packet_counter - self.packet_counter[0]) / self.rate_hz


#: R_ENU_from_X for the other coordinate systems MT Manager can export.
_ENU_FROM = {
    "ENU": np.eye(3),
    "NED": np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]),
    "NWU": np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
}


def _split(line: str, delimiter: str) -> list[str]:
    return [c.strip() for c in line.rstrip("\r\n").split(delimiter)]


def _detect_delimiter(header: str) -> str:
    for delimiter in ("\t", ";", ","):
        if delimiter in header:
            return delimiter
    return " "


def read_xsens_file(path: str | Path, rate_hz: float | None = None) -> XsensRecording:
    """Read one MT Manager text export (any layout listed in the module docstring)."""
    path = Path(path)
    source = str(path)
    lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    header_rate = None
    device_id = None
    coordinate_system = "ENU"
    header_index = None
    for index, line in enumerate(lines):
        text = line.strip()
        if not text:
            continue
        if text.startswith("//"):
            match = re.search(r"Update Rate:\s*([0-9.]+)\s*Hz", text, re.IGNORECASE)
            if match:
                header_rate = float(match.group(1))
            match = re.search(r"DeviceId:\s*(\S+)", text)
            if match:
                device_id = match.group(1)
            match = re.search(r"Coordinate system:\s*(\S+)", text)
            if match:
                coordinate_system = match.group(1).upper()
            continue
        header_index = index
        break
    if header_index is None:
        raise ValueError(f"{source}: no column header line: not an Xsens export")
    if coordinate_system not in _ENU_FROM:
        raise ValueError(f"{source}: unsupported coordinate system {coordinate_system}")
    delimiter = _detect_delimiter(lines[header_index])
    columns = [c for c in _split(lines[header_index], delimiter)]
    while columns and columns[-1] == "":
        columns.pop()
    if "PacketCounter" not in columns:
        raise ValueError(f"{source}: line {header_index + 1}: no PacketCounter column")
    if device_id is None:
        match = re.search(r"_([0-9A-Fa-f]{8})$", path.stem)
        if not match:
            raise ValueError(f"{source}: no DeviceId in the header nor at the end of the file name")
        device_id = match.group(1)
    index_of = {c: i for i, c in enumerate(columns)}
    rows: list[list[float]] = []
    numbers: list[int] = []
    for number, line in enumerate(lines[header_index + 1:], start=header_index + 2):
        if not line.strip():
            continue
        cells = _split(line, delimiter)
        if len(cells) > len(columns) and all(c == "" for c in cells[len(columns):]):
            cells = cells[: len(columns)]
        if len(cells) != len(columns):
            raise ValueError(
                f"{source}: line {number}: {len(cells)} fields, the header has {len(columns)}"
            )
        rows.append([
            math.nan if c == "" or c.lower() == "nan" else _float(c, source, number, columns[i])
            for i, c in enumerate(cells)
        ])
        numbers.append(number)
    if not rows:
        raise ValueError(f"{source}: no data rows")
    data = np.array(rows)
    line_array = np.array(numbers)

    def block(names: Sequence[str]) -> np.ndarray | None:
        if all(n in index_of for n in names):
            return data[:, [index_of[n] for n in names]]
        if any(n in index_of for n in names):
            missing = [n for n in names if n not in index_of]
            raise ValueError(f"{source}: incomplete column group, missing {', '.join(missing)}")
        return None

    quat = block([f"Quat_q{i}" for i in range(4)])
    mat = block([f"Mat[{i}][{j}]" for j in (1, 2, 3) for i in (1, 2, 3)])
    euler = block(["Roll", "Pitch", "Yaw"])
    orientation = next((b for b in (quat, mat, euler) if b is not None), None)
    skipped = 0
    if orientation is not None:
        # A packet exported without any orientation value (lost by the filter) is skipped and
        # counted; the packet counter keeps the time axis right. Partly missing values are an error.
        empty = np.all(np.isnan(orientation), axis=1)
        skipped = int(empty.sum())
        if skipped == len(rows):
            raise ValueError(f"{source}: sensor {device_id}: every row lacks its orientation")
        if skipped:
            keep = ~empty
            data, line_array = data[keep], line_array[keep]
            quat, mat, euler = (None if b is None else b[keep] for b in (quat, mat, euler))
    if quat is not None:
        q, orientation_source = quat, "Quat_q0..q3"
    elif mat is not None:
        # Columns are Mat[1][1], Mat[2][1], Mat[3][1], Mat[1][2], ... : column-major.
        bad = ~np.all(np.isfinite(mat), axis=1)
        if np.any(bad):
            _raise_nan(source, line_array, bad, device_id, "Mat[i][j]")
        matrices = mat.reshape(-1, 3, 3).transpose(0, 2, 1)
        _check_rotation_matrices(matrices, source, line_array, device_id)
        q, orientation_source = rotation.from_matrix(matrices), "Mat[1][1]..Mat[3][3]"
    elif euler is not None:
        bad = ~np.all(np.isfinite(euler), axis=1)
        if np.any(bad):
            _raise_nan(source, line_array, bad, device_id, "Roll/Pitch/Yaw")
        roll, pitch, yaw = np.radians(euler).T
        q = rotation.multiply(
            rotation.multiply(
                rotation.from_axis_angle(np.array([0.0, 0.0, 1.0]), yaw),
                rotation.from_axis_angle(np.array([0.0, 1.0, 0.0]), pitch),
            ),
            rotation.from_axis_angle(np.array([1.0, 0.0, 0.0]), roll),
        )
        orientation_source = "Roll/Pitch/Yaw (deg)"
    else:
        q, orientation_source = None, "none"
    if q is not None:
        q = _checked_unit(q, source, device_id, line_array)
    if q is not None and coordinate_system != "ENU":
        q_enu_from_file = rotation.from_matrix(_ENU_FROM[coordinate_system])
        q = rotation.multiply(q_enu_from_file, q)
    counter = data[:, index_of["PacketCounter"]]
    bad = ~np.isfinite(counter)
    if np.any(bad):
        _raise_nan(source, line_array, bad, device_id, "PacketCounter")
    counter = _unwrap_counter(counter.astype(np.int64), 65536)
    step = np.diff(counter) <= 0
    if np.any(step):
        raise ValueError(
            f"{source}: line {int(line_array[np.argmax(step) + 1])}: PacketCounter does not increase"
        )
    if rate_hz is not None and not (math.isfinite(rate_hz) and rate_hz > 0.0):
        raise ValueError(f"{source}: the update rate must be a positive number of Hz, got {rate_hz:g}")
    rate = header_rate or rate_hz or XSENS_DEFAULT_RATE_HZ
    if rate <= 0.0:
        raise ValueError(f"{source}: update rate must be positive, got {rate}")
    acc = block(["Acc_X", "Acc_Y", "Acc_Z"])
    gyr = block(["Gyr_X", "Gyr_Y", "Gyr_Z"])
    mag = block(["Mag_X", "Mag_Y", "Mag_Z"])
    return XsensRecording(
        device_id=device_id, path=path, packet_counter=counter, q_world_from_sensor=q,
        rate_hz=float(rate), rate_from_header=header_rate is not None,
        coordinate_system=coordinate_system, orientation_source=orientation_source,
        acc=acc, gyr=gyr, mag_au=mag, rows_without_orientation=skipped,
    )


def _raise_nan(source: str, lines: np.ndarray, bad: np.ndarray, sensor: str, what: str) -> None:
    raise ValueError(
        f"{source}: line {int(lines[np.argmax(bad)])}: sensor {sensor}: {what} is NaN or empty "
        f"({int(bad.sum())} bad rows in all)"
    )


def _check_rotation_matrices(m: np.ndarray, source: str, lines: np.ndarray, sensor: str) -> None:
    error = np.linalg.norm(m @ np.swapaxes(m, -1, -2) - np.eye(3), axis=(-2, -1))
    det = np.linalg.det(m)
    bad = (error > 0.05) | (det < 0.9)
    if np.any(bad):
        raise ValueError(
            f"{source}: line {int(lines[np.argmax(bad)])}: sensor {sensor}: Mat[i][j] is not a "
            f"rotation matrix (|R·Rᵀ − I| = {error[np.argmax(bad)]:.3g}, det {det[np.argmax(bad)]:.3g})"
        )


def _unwrap_counter(counter: np.ndarray, modulus: int) -> np.ndarray:
    """Undo the wrap-around of an unsigned counter (a drop of more than half the range = wrap)."""
    step = np.diff(counter)
    wraps = np.concatenate(([0], np.cumsum(step < -modulus // 2)))
    return counter + wraps * modulus


@dataclass(frozen=True)
class XsensMapping:
    """An OpenSense ``XsensDataReaderSettings`` file: trial prefix and device id → name."""

    trial_prefix: str | None
    names: Mapping[str, str]


def read_xsens_mapping(path: str | Path) -> XsensMapping:
    """Read an OpenSense mapping (``myIMUMappings.xml``); device ids lose their leading ``_``."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as error:
        raise ValueError(f"{path}: malformed XML: {error}") from None
    settings = root if root.tag == "XsensDataReaderSettings" else root.find(".//XsensDataReaderSettings")
    if settings is None:
        raise ValueError(f"{path}: no XsensDataReaderSettings element")
    prefix_node = settings.find("trial_prefix")
    prefix = prefix_node.text.strip() if prefix_node is not None and prefix_node.text else None
    names: dict[str, str] = {}
    for sensor in settings.iter("ExperimentalSensor"):
        raw = (sensor.get("name") or "").strip()
        name_node = sensor.find("name_in_model")
        if not raw or name_node is None or not (name_node.text or "").strip():
            raise ValueError(f"{path}: an ExperimentalSensor lacks a name or name_in_model")
        device = raw.lstrip("_")
        if device in names:
            raise ValueError(f"{path}: sensor {device} is listed twice")
        names[device] = name_node.text.strip()
    if not names:
        raise ValueError(f"{path}: no ExperimentalSensor entries")
    return XsensMapping(prefix, names)


def _xsens_trials(folder: Path) -> dict[str, dict[str, Path]]:
    """Files of a folder grouped as {trial prefix: {device id: path}}."""
    trials: dict[str, dict[str, Path]] = {}
    for path in sorted(folder.glob("*.txt")):
        match = re.match(r"^(.*)_([0-9A-Fa-f]{8})$", path.stem)
        if match:
            trials.setdefault(match.group(1), {})[match.group(2)] = path
    return trials


def read_xsens_folder(
    folder: str | Path,
    mapping: XsensMapping | str | Path | None = None,
    trial_prefix: str | None = None,
    rate_hz: float | None = None,
) -> QuaternionTable:
    """Read every sensor of one trial in a folder of MT Manager exports into one table.

    The trial is ``trial_prefix``, else the mapping's, else the only one present. With a
    mapping only its sensors are read and they are named ``name_in_model``; without one the
    sensors are named by device id. World: ENU, up +z.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder}: not a folder")
    if mapping is not None and not isinstance(mapping, XsensMapping):
        mapping = read_xsens_mapping(mapping)
    trials = _xsens_trials(folder)
    if not trials:
        raise ValueError(f"{folder}: no '<trial>_<DeviceId>.txt' Xsens exports")
    prefix = trial_prefix or (mapping.trial_prefix if mapping else None)
    if prefix is None:
        if len(trials) != 1:
            raise ValueError(
                f"{folder}: several trials ({', '.join(sorted(trials))}); name one with trial_prefix"
            )
        prefix = next(iter(trials))
    if prefix not in trials:
        raise ValueError(f"{folder}: no files for trial {prefix!r} (found {', '.join(sorted(trials))})")
    files = trials[prefix]
    if mapping is not None:
        missing = [d for d in mapping.names if d not in files]
        if missing:
            raise ValueError(
                f"{folder}: trial {prefix}: no file for mapped sensor(s) {', '.join(missing)}"
            )
        selected = {mapping.names[d]: files[d] for d in mapping.names}
    else:
        selected = {d: p for d, p in files.items()}
    recordings = {name: read_xsens_file(p, rate_hz) for name, p in selected.items()}
    return merge_xsens_recordings(recordings, source=str(folder / prefix))


def merge_xsens_recordings(recordings: Mapping[str, XsensRecording], source: str) -> QuaternionTable:
    """Align recordings on their common packet counters (they must share one update rate)."""
    rates = {r.rate_hz for r in recordings.values()}
    if len(rates) != 1:
        raise ValueError(f"{source}: sensors have different update rates {sorted(rates)}")
    rate = rates.pop()
    for name, rec in recordings.items():
        if rec.q_world_from_sensor is None:
            raise ValueError(
                f"{rec.path}: sensor {name}: no orientation columns (Quat_q0..q3, Mat[i][j] or "
                "Roll/Pitch/Yaw): export orientations from MT Manager"
            )
    common = None
    for rec in recordings.values():
        common = rec.packet_counter if common is None else np.intersect1d(common, rec.packet_counter)
    if common is None or common.size == 0:
        raise ValueError(f"{source}: the sensors share no packet counter")
    quats = {}
    for name, rec in recordings.items():
        index = np.searchsorted(rec.packet_counter, common)
        quats[name] = rec.q_world_from_sensor[index]
    t = (common - common[0]) / rate
    return QuaternionTable(t, quats, np.array([0.0, 0.0, 1.0]), "ENU", source)


# --------------------------------------------------------------------------------------------
# APDM Format=7 CSV
# --------------------------------------------------------------------------------------------

def read_apdm_csv(path: str | Path) -> QuaternionTable:
    """Read an APDM ``Format=7`` CSV: sensors named by their label (else id), world z up."""
    path = Path(path)
    source = str(path)
    with path.open(newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    if len(rows) < 4 or not rows[0] or not rows[0][0].startswith("Format="):
        raise ValueError(f"{source}: not an APDM 'Format=' CSV")
    ids, groups, axes = rows[0], rows[1], rows[2]
    width = len(groups)
    starts = [i for i in range(1, len(ids)) if re.fullmatch(r"\d+", ids[i].strip())]
    if not starts:
        raise ValueError(f"{source}: line 1: no sensor ids")
    if groups[0].strip().lower() != "time":
        raise ValueError(f"{source}: line 2: first column must be Time")
    sensors: dict[str, int] = {}
    for k, start in enumerate(starts):
        end = starts[k + 1] if k + 1 < len(starts) else width
        label = ids[start + 3].strip() if start + 3 < len(ids) and ids[start + 3].strip() else ids[start].strip()
        cols = [i for i in range(start, end) if groups[i].strip().lower() == "orientation"]
        if not cols or cols[0] + 4 > width or [a.strip().upper() for a in axes[cols[0]:cols[0] + 4]] != ["S", "X", "Y", "Z"]:
            raise ValueError(f"{source}: sensor {label}: no 'Orientation S,X,Y,Z' columns")
        sensors[label] = cols[0]
    data_rows = rows[3:]
    lines = np.arange(4, 4 + len(data_rows))
    values = []
    for number, row in zip(lines, data_rows):
        if len(row) != width:
            raise ValueError(f"{source}: line {number}: {len(row)} fields, expected {width}")
        values.append([_float(c, source, number, groups[i] or f"col{i}") if c.strip() else math.nan
                       for i, c in enumerate(row)])
    data = np.array(values)
    t = (data[:, 0] - data[0, 0]) * 1e-6
    _check_time(t, source, lines)
    quats = {label: _checked_unit(data[:, c:c + 4], source, label, lines) for label, c in sensors.items()}
    return QuaternionTable(t, quats, np.array([0.0, 0.0, 1.0]), "APDM world (z up)", source)


# --------------------------------------------------------------------------------------------
# Dispatcher
# --------------------------------------------------------------------------------------------

# The kinds of orientation input (XSENS_FOLDER, ... QUATERNION_CSV) are named in
# mimucap.io.input_names, which the command line reads without loading numpy.


def orientation_input_kind(path: str | Path) -> str:
    """Which kind of input ``path`` is (one of the constants above), as
    :func:`read_quaternion_table` tells them apart: a folder is an Xsens export folder, then
    the suffix decides (``.sto``, ``.txt``, ``.h5``/``.hdf5``/``.mimucap``, ``.csv`` whose first
    line ``Format=`` marks APDM). An HDF5 file laid out as a BROAD trial is a BROAD trial.
    ``FileNotFoundError`` for a missing path, ``ValueError`` for an unknown suffix."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file or folder")
    if path.is_dir():
        return XSENS_FOLDER
    suffix = path.suffix.lower()
    if suffix == ".sto":
        return OPENSIM_STO
    if suffix in SESSION_SUFFIXES:
        from mimucap.io.broad import is_broad_file

        return BROAD_TRIAL if is_broad_file(path) else MIMUCAP_SESSION
    if suffix == ".txt":
        return XSENS_FILE
    if suffix == ".csv":
        with path.open(encoding="utf-8") as handle:
            first = handle.readline()
        return APDM_CSV if first.startswith("Format=") else QUATERNION_CSV
    raise ValueError(
        f"{path}: unknown orientation file type {suffix!r} (use .csv, .sto, an Xsens .txt or "
        "folder, or a MimuCap session .h5)"
    )


#: Why an up axis cannot be chosen for some inputs.
_FIXED_UP = "Xsens exports and APDM files are z up"


def _refuse_up_axis(path: Path, up_axis: str | None) -> None:
    """``ValueError`` when an up axis other than +z is given for an input whose world is z up
    (it would otherwise be ignored without a word)."""
    if up_axis is not None and not np.allclose(axis_vector(up_axis), (0.0, 0.0, 1.0)):
        raise ValueError(f"{path}: up axis {up_axis} cannot apply: {_FIXED_UP}")


def read_quaternion_table(
    path: str | Path,
    up_axis: str | None = None,
    sensor_names: str | Path | None = None,
    trial_prefix: str | None = None,
    rate_hz: float | None = None,
) -> QuaternionTable:
    """Read any supported orientation file or folder (see the module docstring).

    ``up_axis`` overrides the up axis the format implies (only for CSV and ``.sto``: Xsens,
    APDM and sessions are always z up, and another up axis given for them is refused rather
    than ignored). ``sensor_names`` (an OpenSense mapping XML), ``trial_prefix`` and
    ``rate_hz`` (used when a header gives no rate; a positive number) apply to Xsens exports.
    """
    path = Path(path)
    kind = orientation_input_kind(path)
    if kind == XSENS_FOLDER:
        _refuse_up_axis(path, up_axis)
        return read_xsens_folder(path, sensor_names, trial_prefix, rate_hz)
    if kind == OPENSIM_STO:
        return read_opensim_sto(path, up_axis)
    if kind in (MIMUCAP_SESSION, BROAD_TRIAL):
        raise ValueError(f"{path}: {kind} hold raw samples, not orientations: their orientations come from "
                         "the processing path (mimucap bodycal, angles and fuse read them)")
    if kind == XSENS_FILE:
        _refuse_up_axis(path, up_axis)
        rec = read_xsens_file(path, rate_hz)
        name = rec.device_id
        if sensor_names is not None:
            name = read_xsens_mapping(sensor_names).names.get(rec.device_id, rec.device_id)
        return merge_xsens_recordings({name: rec}, source=str(path))
    if kind == APDM_CSV:
        _refuse_up_axis(path, up_axis)
        return read_apdm_csv(path)
    return read_quaternion_csv(path, up_axis)
