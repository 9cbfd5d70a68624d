"""Read raw magnetometer recordings for calibration.

Formats (``read_mag_files(..., fmt=...)``; ``"auto"`` picks by content):

* ``"csv"``: text, optionally gzipped (``.gz``), ``#`` comment lines skipped.
  - *Plain*: three numeric columns x, y, z, without a header line (or with the header
    ``x,y,z``), separated by commas, semicolons, tabs or spaces. The unit is not stated
    (``unit=None``). Only a file whose first row is numeric is read as plain x, y, z: a
    header naming other columns (``t_s,mx_uT,my_uT``) is an error naming the columns expected.
  - *Headered*: columns named like ``mx``/``mag_x``/``Mag_X`` (and y, z), optionally a time
    column ``t_s``/``time_s``; a unit suffix ``_gauss``, ``_uT`` or ``_counts`` on the
    magnetometer columns sets the unit. The sunsided/sensor-fusion recordings
    (``mag_hmc5883l.csv.gz``: ``t_s,mx_gauss,my_gauss,mz_gauss``) are read this way, and their
    companion ``imu_mpu6050.csv.gz`` (``t_s,ax,ay,az,gx,gy,gz`` in g and °/s) next to them is
    attached as a :class:`~mimucap.core.samples.SensorSamples` record (``acc`` m/s², ``gyr``
    rad/s), converted to this project's conventions following the
    upstream READMEs: set 2 (the default) records the accelerometer as the *gravity*
    direction (−1 g on z when z points up), so specific force = −a; set 1 records the up
    direction with the x axis flipped; in both sets the gyroscope x axis is flipped. In set 2
    the magnetometer axes agree with the accelerometer's (the dip angle stays constant over
    the full-sphere recording); in set 1 the HMC5883L is mounted differently (undocumented),
    so set-1 inertial samples are attached for the gyroscope but not matched to the
    magnetometer frame (``imu_in_mag_frame`` false: no dip figure).
* ``"xsens"``: Xsens MT Manager text exports (``//`` header lines; tab, comma, semicolon or
  space delimited; old and new headers) with ``Mag_X``, ``Mag_Y``, ``Mag_Z`` columns, and
  ``Acc_*`` (m/s²), ``Gyr_*`` (rad/s) when present. Xsens writes the magnetometer in
  arbitrary units normalised to the field at its factory calibration (about 1), so these
  samples are in ``"counts"``: give a scale to µT. The sensor id comes from the
  ``DeviceId`` header or the file name's ``_XXXXXXXX`` suffix. In space-delimited exports
  empty fields are invisible; the values after the packet counter are aligned to the last
  columns (Xsens leaves the time columns, which come first, empty).
* ``"session"``: MimuCap session files (:func:`mimucap.io.session.read_session`), one
  recording per sensor with a magnetometer, in µT.

Every reader returns :class:`MagRecording` objects; :func:`to_microtesla` converts their
samples with the unit rules of ``mimucap magcal fit``. Malformed input raises ``ValueError``
naming the file and line.
"""

from __future__ import annotations

import gzip
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mimucap.core.device_identity import xsens_device_id
from mimucap.core.samples import SensorSamples
from mimucap.io.input_names import FORMATS, MAG_UNITS, SESSION_SUFFIXES

FloatArray = NDArray[np.float64]

UT_PER_GAUSS = 100.0
STANDARD_GRAVITY_MPS2 = 9.80665
SUNSIDED_IMU_FILE = "imu_mpu6050.csv.gz"


@dataclass(frozen=True)
class MagRecording:
    """Magnetometer samples of one sensor from one file.

    source: file (and sensor) they came from. sensor_id: ``None`` if the file does not say.
    mag: (N, 3) samples in ``unit`` ("uT", "gauss", "counts", or ``None`` if the file does not
    state it), sensor frame. t_s: (N,) s or ``None``. imu: companion inertial samples (``acc``
    m/s², ``gyr`` rad/s, sensor frame; either may be ``None``) or ``None``.
    imu_in_mag_frame: whether the inertial samples share the magnetometer's axes. device_id: the
    device the samples came from when the file says (:mod:`mimucap.core.device_identity`: a
    session's recorded device, an Xsens export's device id), else ``None``.
    """

    source: str
    sensor_id: str | None
    mag: FloatArray
    unit: str | None
    t_s: FloatArray | None = None
    imu: SensorSamples | None = None
    imu_in_mag_frame: bool = True
    device_id: str | None = None

    def acc_at_mag_times(self) -> FloatArray | None:
        """Accelerometer samples (N, 3, m/s²) linearly interpolated at the magnetometer times
        (NaN outside the accelerometer's time span), or ``None`` if not available or not in
        the magnetometer's frame."""
        if self.imu is None or self.imu.acc is None or self.t_s is None or not self.imu_in_mag_frame:
            return None
        if len(self.imu.t_s) == len(self.t_s) and np.array_equal(self.imu.t_s, self.t_s):
            return self.imu.acc
        order = np.argsort(self.imu.t_s, kind="stable")
        t = self.imu.t_s[order]
        return np.column_stack(
            [np.interp(self.t_s, t, self.imu.acc[order, i], left=np.nan, right=np.nan) for i in range(3)]
        )


def to_microtesla(mag: FloatArray, unit: str, scale_to_uT: float | None, source: str = "") -> FloatArray:
    """Samples in µT: ``uT`` as is, ``gauss`` × 100, ``counts`` × ``scale_to_uT`` (required).

    A scale given for ``uT`` or ``gauss`` input is refused (the unit already fixes it).
    """
    where = f"{source}: " if source else ""
    if unit not in MAG_UNITS:
        raise ValueError(f"{where}unknown magnetometer unit {unit!r}; use one of {', '.join(MAG_UNITS)}")
    if unit == "counts":
        if scale_to_uT is None:
            raise ValueError(
                f"{where}samples are raw counts (or Xsens arbitrary units): give --scale-to-uT "
                "(µT per count, e.g. 0.15 for an MPU-9250 in 16-bit mode)"
            )
        if not (math.isfinite(scale_to_uT) and scale_to_uT > 0):
            raise ValueError(f"{where}--scale-to-uT must be a positive number, got {scale_to_uT}")
        return mag * scale_to_uT
    if scale_to_uT is not None:
        raise ValueError(f"{where}--scale-to-uT applies to counts only; the samples are in {unit}")
    return mag * (UT_PER_GAUSS if unit == "gauss" else 1.0)


def _open_text(path: Path) -> list[str]:
    try:
        if path.suffix == ".gz":
            with gzip.open(path, "rt", encoding="utf-8", errors="replace") as handle:
                return handle.read().splitlines()
        return path.read_text(encoding="utf-8", errors="replace").splitlines()
    except (gzip.BadGzipFile, EOFError) as error:
        raise ValueError(f"{path}: not a readable gzip file ({error})") from error


def _delimiter(line: str) -> str | None:
    """The delimiter of ``line``: ",", ";", "\\t", or ``None`` for runs of spaces."""
    for candidate in (",", ";", "\t"):
        if candidate in line:
            return candidate
    return None


def _split(line: str, delimiter: str | None) -> list[str]:
    if delimiter is None:
        return line.split()
    return [field.strip() for field in line.split(delimiter)]


def _number(text: str) -> float:
    return float(text) if text else math.nan


_MAG_COLUMN = re.compile(r"^(?:m|mag|magn|magnetometer)[_ ]?([xyz])(?:[_ ]?\(?([a-z]+)\)?)?$", re.IGNORECASE)
#: The header of a plain file: bare axis names ``x,y,z`` (with an optional unit suffix).
_BARE_AXIS_COLUMN = re.compile(r"^([xyz])(?:[_ ]?\(?([a-z]+)\)?)?$", re.IGNORECASE)
_TIME_COLUMNS = ("t_s", "time_s", "t", "time", "timestamp_s")
#: What a magnetometer CSV header must name, for the error that refuses another header.
EXPECTED_COLUMNS = ("mx,my,mz or mag_x,mag_y,mag_z, optionally with a unit suffix (_uT, _gauss, _counts) "
                    "and a t_s column")


def _axis_columns(names: list[str], pattern: re.Pattern) -> dict[str, tuple[int, str | None]]:
    """Axis letter → (column index, unit suffix or None) of the columns matching ``pattern``."""
    found: dict[str, tuple[int, str | None]] = {}
    for index, name in enumerate(names):
        match = pattern.match(name.strip())
        if match:
            found.setdefault(match.group(1).lower(), (index, match.group(2)))
    return found


def _missing_axes_message(names: list[str]) -> str:
    """Why ``names`` is not a magnetometer header: the axis columns it lacks, or that it has none."""
    found = _axis_columns(names, _MAG_COLUMN)
    if found:
        missing = ", ".join(f"m{axis}" for axis in "xyz" if axis not in found)
        return f"the header {','.join(names)} has no {missing} column; expected {EXPECTED_COLUMNS}"
    return (f"no magnetometer columns in the header {','.join(names)}: expected {EXPECTED_COLUMNS}; "
            f"a file without a header holds three numbers x, y, z per line")


def _mag_columns(names: list[str]) -> tuple[list[int], str | None] | None:
    found = _axis_columns(names, _MAG_COLUMN)
    if set(found) != {"x", "y", "z"}:
        found = _axis_columns(names, _BARE_AXIS_COLUMN) if len(names) == 3 else {}
    if set(found) != {"x", "y", "z"}:
        return None
    units = {found[a][1].lower() if found[a][1] else None for a in "xyz"}
    unit = None
    if len(units) == 1:
        suffix = units.pop()
        unit = {"gauss": "gauss", "g": "gauss", "ut": "uT", "counts": "counts", "lsb": "counts"}.get(suffix or "")
    return [found[a][0] for a in "xyz"], unit


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_csv(path: str | Path) -> MagRecording:
    """Read a plain or headered magnetometer CSV (see module docstring)."""
    path = Path(path)
    lines = _open_text(path)
    rows: list[tuple[int, str]] = [(n + 1, line) for n, line in enumerate(lines) if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise ValueError(f"{path}: no samples")
    delimiter = _delimiter(rows[0][1])
    first = _split(rows[0][1], delimiter)
    columns = [0, 1, 2]
    time_column = None
    unit = None
    if all(_is_number(f) for f in first if f):
        data_rows = rows
        if len(first) != 3:
            raise ValueError(
                f"{path}:{rows[0][0]}: a CSV without a header must have exactly 3 columns "
                f"(x, y, z), found {len(first)}"
            )
    else:
        data_rows = rows[1:]
        detected = _mag_columns(first)
        if detected is None:
            raise ValueError(f"{path}:{rows[0][0]}: {_missing_axes_message(first)}")
        columns, unit = detected
        lowered = [name.strip().lower() for name in first]
        for name in _TIME_COLUMNS:
            if name in lowered:
                time_column = lowered.index(name)
                break
    needed = max(columns + ([time_column] if time_column is not None else []))
    values = np.empty((len(data_rows), 3))
    times = np.empty(len(data_rows)) if time_column is not None else None
    for k, (number, line) in enumerate(data_rows):
        fields = _split(line, delimiter)
        if len(fields) <= needed:
            raise ValueError(f"{path}:{number}: expected at least {needed + 1} columns, found {len(fields)}")
        try:
            values[k] = [_number(fields[c]) for c in columns]
            if times is not None:
                times[k] = _number(fields[time_column])
        except ValueError:
            raise ValueError(f"{path}:{number}: not a number in {line.strip()!r}") from None
    if len(values) == 0:
        raise ValueError(f"{path}: no samples after the header")
    imu = None
    companion = path.parent / SUNSIDED_IMU_FILE
    if times is not None and companion.is_file() and companion != path:
        imu = read_sunsided_imu(companion)
    return MagRecording(
        source=str(path), sensor_id=None, mag=values, unit=unit, t_s=times, imu=imu,
        imu_in_mag_frame=imu is None or _sunsided_set(path) == "set-2",
    )


def _sunsided_set(path: Path) -> str:
    return "set-1" if "set-1" in path.parts else "set-2"


def read_sunsided_imu(path: str | Path, variant: str = "auto") -> SensorSamples:
    """The MPU-6050 companion file ``t_s,ax,ay,az,gx,gy,gz`` (g, °/s) in project conventions.

    variant: ``"set-1"``, ``"set-2"`` or ``"auto"`` (from a ``set-1`` folder in the path, else
    set 2). See the module docstring for the sign rules.
    """
    path = Path(path)
    variant = _sunsided_set(path) if variant == "auto" else variant
    if variant not in ("set-1", "set-2"):
        raise ValueError(f"{path}: unknown sunsided variant {variant!r} (set-1 or set-2)")
    lines = _open_text(path)
    if not lines or [c.strip() for c in lines[0].split(",")] != ["t_s", "ax", "ay", "az", "gx", "gy", "gz"]:
        raise ValueError(f"{path}:1: expected the header t_s,ax,ay,az,gx,gy,gz")
    data = np.empty((len(lines) - 1, 7))
    for k, line in enumerate(lines[1:]):
        fields = line.split(",")
        if len(fields) != 7:
            raise ValueError(f"{path}:{k + 2}: expected 7 columns, found {len(fields)}")
        try:
            data[k] = [float(f) for f in fields]
        except ValueError:
            raise ValueError(f"{path}:{k + 2}: not a number in {line.strip()!r}") from None
    acc_g = data[:, 1:4]
    gyr_dps = data[:, 4:7] * np.array([-1.0, 1.0, 1.0])
    if variant == "set-2":
        acc = -acc_g * STANDARD_GRAVITY_MPS2
    else:
        acc = acc_g * np.array([-1.0, 1.0, 1.0]) * STANDARD_GRAVITY_MPS2
    return SensorSamples("mpu6050", data[:, 0], np.arange(len(data)), acc=acc, gyr=np.deg2rad(gyr_dps))


def read_xsens(path: str | Path) -> MagRecording:
    """Read an Xsens MT Manager text export with ``Mag_X..Z`` columns (see module docstring).

    The file is parsed by the one Xsens reader, :func:`mimucap.io.quaternion_tables.read_xsens_file`
    (headers, delimiters, empty fields, packet counters); this keeps its magnetometer (Xsens's
    arbitrary units, normalised to the local field: ``unit="counts"``, to be scaled) and its
    accelerometer and gyroscope as the companion inertial samples."""
    from mimucap.io.quaternion_tables import read_xsens_file

    path = Path(path)
    recording = read_xsens_file(path)
    if recording.mag_au is None:
        raise ValueError(f"{path}: no Mag_X, Mag_Y, Mag_Z columns in this Xsens export")
    t_s = recording.t_s
    imu = None
    if recording.acc is not None or recording.gyr is not None:
        imu = SensorSamples(recording.device_id or path.stem, t_s, np.arange(len(t_s)), acc=recording.acc,
                            gyr=recording.gyr)
    return MagRecording(source=str(path), sensor_id=recording.device_id, mag=recording.mag_au, unit="counts",
                        t_s=t_s, imu=imu, device_id=_xsens_device(recording.device_id))


def _xsens_device(device: str | None) -> str | None:
    """The device id of an Xsens export's ``DeviceId`` (``None`` when it names none usable)."""
    if not device:
        return None
    try:
        return xsens_device_id(device)
    except ValueError:
        return None


def read_session_mag(path: str | Path, sensor_id: str | None = None) -> list[MagRecording]:
    """One recording per sensor with magnetometer samples in a MimuCap session file (µT);
    only ``sensor_id`` if given (a missing sensor raises ``ValueError`` naming the ones present)."""
    from mimucap.io.session import read_session

    session = read_session(path, include_truth=False)
    devices = session.devices()
    recordings = []
    for sid, stream in session.sensors.items():
        if sensor_id is not None and sid != sensor_id:
            continue
        if stream.mag_uT is None:
            if sensor_id is not None:
                raise ValueError(f"{path}: sensor {sid} has no magnetometer samples")
            continue
        recordings.append(
            MagRecording(source=f"{path}#{sid}", sensor_id=sid, mag=np.asarray(stream.mag_uT, dtype=np.float64),
                         unit="uT", t_s=np.asarray(stream.t_s, dtype=np.float64), imu=stream,
                         device_id=devices[sid].device_id)
        )
    if not recordings:
        present = ", ".join(session.sensors) or "none"
        what = f"sensor {sensor_id}" if sensor_id is not None else "any sensor with a magnetometer"
        raise ValueError(f"{path}: no {what} in this session (sensors: {present})")
    return recordings


def detect_format(path: str | Path) -> str:
    """``"session"``, ``"xsens"`` or ``"csv"`` for ``path``, from its suffix and first lines."""
    path = Path(path)
    if path.suffix.lower() in SESSION_SUFFIXES:
        return "session"
    with open(path, "rb") as handle:
        start = handle.read(8)
    if start.startswith(b"\x89HDF"):
        return "session"
    lines = _open_text(path)[:40]
    for line in lines:
        stripped = line.strip()
        if stripped.startswith("//"):
            return "xsens"
        if stripped:
            if "PacketCounter" in stripped or "Mag_X" in stripped:
                return "xsens"
            break
    return "csv"


def read_mag_files(
    paths: Sequence[str | Path], fmt: str = "auto", sensor_id: str | None = None
) -> list[MagRecording]:
    """Read every file in ``paths`` (format ``fmt`` or detected); a directory holding a
    sunsided ``mag_hmc5883l.csv.gz`` stands for that file. ``sensor_id`` selects a session's
    sensor; for other formats it names the samples' sensor, and a file stating another id
    (Xsens) is refused."""
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}; use one of {', '.join(FORMATS)}")
    recordings: list[MagRecording] = []
    for item in paths:
        path = Path(item)
        if path.is_dir():
            candidate = path / "mag_hmc5883l.csv.gz"
            if not candidate.is_file():
                raise ValueError(f"{path}: a folder is accepted only if it holds mag_hmc5883l.csv.gz")
            path = candidate
        if not path.is_file():
            raise FileNotFoundError(f"{path}: no such file")
        kind = detect_format(path) if fmt == "auto" else fmt
        if kind == "session":
            recordings.extend(read_session_mag(path, sensor_id))
            continue
        recording = read_xsens(path) if kind == "xsens" else read_csv(path)
        if sensor_id is not None:
            if recording.sensor_id is not None and recording.sensor_id != sensor_id:
                raise ValueError(
                    f"{path}: the file holds sensor {recording.sensor_id}, not {sensor_id}"
                )
            recording = MagRecording(
                source=recording.source, sensor_id=sensor_id, mag=recording.mag, unit=recording.unit,
                t_s=recording.t_s, imu=recording.imu, imu_in_mag_frame=recording.imu_in_mag_frame,
            )
        recordings.append(recording)
    return recordings
