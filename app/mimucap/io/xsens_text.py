"""Xsens MT Manager text exports: orientations (and the raw channels) of Xsens sensors.

A single ``.txt`` or a folder of ``<trial>_<DeviceId>.txt``: old (``// Update Rate``) and new
(``// General information``) headers; tab, comma, semicolon or single-space delimiters with
empty fields kept; orientation from ``Quat_q0..q3`` (q_world_from_sensor, w first), else
``Mat[i][j]`` (R_world_from_sensor, written column by column), else ``Roll, Pitch, Yaw`` in
degrees (``R = Rz(yaw)·Ry(pitch)·Rx(roll)``). ``// Coordinate system: NED`` or ``NWU`` exports
are turned into ENU. A packet exported without any orientation value is skipped (and counted).
Time is ``PacketCounter`` (16-bit, unwrapped) divided by the update rate; sensors of one trial
are aligned on their common packet counters (a packet lost by any sensor drops that instant:
:func:`merge_xsens_recordings`, a :class:`~mimucap.io.orientation_tables.QuaternionTable` in
ENU, z up). An OpenSense mapping file (``myIMUMappings.xml``) selects the trial and renames
device ids to ``name_in_model`` (:func:`read_xsens_mapping`).

Accelerations are m/s², rates rad/s, the magnetometer in Xsens arbitrary units (normalised to
the local field); bad input raises ``ValueError`` naming the file, line and sensor.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mimucap.core import rotation
from mimucap.io.orientation_tables import QuaternionTable, checked_unit, parse_float

#: Xsens MTw default update rate, used when an export's header does not state one (Hz).
XSENS_DEFAULT_RATE_HZ = 100.0


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
            math.nan if c == "" or c.lower() == "nan" else parse_float(c, source, number, columns[i])
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
        q = checked_unit(q, source, device_id, line_array)
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
