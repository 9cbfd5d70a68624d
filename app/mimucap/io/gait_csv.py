"""Gait files: foot-worn IMU samples in the layout of the gaitmap example data, its optical
reference (for evaluation), and the CSV tables gait analysis writes.

**Foot IMU CSV** (the gaitmap layout, Küderle et al. 2024, "Gaitmap — an open ecosystem for
IMU-based human gait analysis", IEEE OJEMB 5:163-172): a first column of sample numbers, then
two header rows: row 1 the sensor (``left_sensor``, ``right_sensor``), row 2 the channel
(``acc_x acc_y acc_z`` m/s², ``gyr_x gyr_y gyr_z`` in °/s or rad/s). Axes are gaitmap's foot
sensor frame: x to the shoe tip, y to the subject's left (both feet), z up in flat-foot stance;
the sagittal (flexion-axis) rate, positive as the foot swings forward (dorsiflexion), is
therefore ``−gyr_y`` for both feet when the file keeps to that frame (``mimucap gait`` does not
rely on it: it finds each sensor's axes in its samples). Time = sample number / rate.

**Tables** are CSV with one header row, after ``#`` lines saying what the input holds (result,
calibrations, software, source file); empty cells are values that could not be estimated;
booleans are ``true``/``false``.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mimucap.core import rotation
from mimucap.io.session import gyro_range_problem

SIDES = {"left_sensor": "left", "right_sensor": "right"}
CHANNELS = ("acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z")
GYR_UNITS = {"deg/s": math.pi / 180.0, "rad/s": 1.0}


@dataclass(frozen=True)
class FootImu:
    """One foot's samples: ``t_s`` (N,) s, ``acc`` (N, 3) m/s², ``gyr`` (N, 3) rad/s in the
    gaitmap foot sensor frame (x forward, y left, z up), ``side`` left or right."""

    side: str
    t_s: np.ndarray
    acc: np.ndarray
    gyr: np.ndarray

    @property
    def sagittal_rate(self) -> np.ndarray:
        """Rate about the foot's mediolateral axis pointing right (N,) rad/s: ``−gyr_y``."""
        return -self.gyr[:, 1]


def read_foot_imu_csv(path: str | Path, rate_hz: float, gyr_unit: str = "deg/s") -> dict[str, FootImu]:
    """Read a foot IMU CSV (module doc); returns side (``left``/``right``) → :class:`FootImu`.

    ``ValueError`` names the file and line of the first problem: a missing sensor or channel,
    a non-numeric or non-finite value, sample numbers that do not increase, a gyroscope that
    is not in ``gyr_unit``.
    """
    source = Path(path)
    if not math.isfinite(rate_hz) or rate_hz <= 0:
        raise ValueError(f"sample rate must be a positive number of Hz, got {rate_hz}")
    if gyr_unit not in GYR_UNITS:
        raise ValueError(f"gyroscope unit must be one of {', '.join(GYR_UNITS)}, got {gyr_unit!r}")
    with open(source, newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    if len(rows) < 3:
        raise ValueError(f"{source}: needs two header rows (sensor, channel) and samples; it has {len(rows)} lines")
    sensors, channels = rows[0], rows[1]
    if len(sensors) != len(channels):
        raise ValueError(f"{source}: line 1 has {len(sensors)} columns, line 2 {len(channels)}")
    columns: dict[tuple[str, str], int] = {}
    for index in range(1, len(sensors)):
        columns[(sensors[index].strip(), channels[index].strip())] = index
    found = [s for s in SIDES if any((s, c) in columns for c in CHANNELS)]
    if not found:
        raise ValueError(f"{source}: line 1 names no sensor {' or '.join(SIDES)}")
    for sensor in found:
        missing = [c for c in CHANNELS if (sensor, c) not in columns]
        if missing:
            raise ValueError(f"{source}: sensor {sensor} lacks channel(s) {', '.join(missing)} (line 2)")
    values = np.empty((len(rows) - 2, len(sensors)))
    for line, row in enumerate(rows[2:], start=3):
        if len(row) != len(sensors):
            raise ValueError(f"{source}: line {line} has {len(row)} columns, the header {len(sensors)}")
        try:
            values[line - 3] = [float(cell) for cell in row]
        except ValueError:
            raise ValueError(f"{source}: line {line}: not a number in {row!r:.80}") from None
    bad = ~np.isfinite(values)
    if np.any(bad):
        line = int(np.argmax(bad.any(axis=1))) + 3
        raise ValueError(f"{source}: line {line}: NaN or infinite value")
    sample = values[:, 0]
    steps = np.diff(sample)
    if np.any(steps <= 0):
        line = int(np.argmax(steps <= 0)) + 4
        raise ValueError(f"{source}: line {line}: sample numbers must increase")
    t_s = sample / float(rate_hz)
    result = {}
    for sensor in found:
        acc = values[:, [columns[(sensor, c)] for c in CHANNELS[:3]]]
        gyr = values[:, [columns[(sensor, c)] for c in CHANNELS[3:]]] * GYR_UNITS[gyr_unit]
        problem = gyro_range_problem(gyr)
        if problem:
            raise ValueError(f"{source}: sensor {sensor}: {problem} (give --gyr-unit)")
        result[SIDES[sensor]] = FootImu(SIDES[sensor], t_s, acc, gyr)
    return result


@dataclass(frozen=True)
class ReferenceStride:
    """One stride of the gaitmap optical reference (times in s): ``pre_ic`` the initial
    contact before the stride, ``tc`` the toe-off, ``ic`` the initial contact ending its
    swing, ``start``/``end`` the mid-stances bounding it, ``length_m`` the heel marker's
    horizontal displacement between them (NaN when the position file is absent),
    ``heading_change_deg`` the heel-to-toe axis's turn between them (NaN when absent)."""

    stride_id: int
    side: str
    pre_ic: float
    tc: float
    ic: float
    start: float
    end: float
    length_m: float
    heading_change_deg: float


def read_gaitmap_reference(folder: str | Path, rate_hz: float = 204.8) -> list[ReferenceStride]:
    """The reference strides of a gaitmap example folder (``stride_events_sample.csv`` in IMU
    samples; ``position_sample.csv`` and ``orientation_sample.csv`` at 100 Hz when present).
    For evaluation only: analysis never reads these."""
    base = Path(folder)
    events_path = base / "stride_events_sample.csv"
    with open(events_path, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    needed = ("s_id", "foot", "start", "end", "ic", "tc", "pre_ic")
    if not rows or any(k not in rows[0] for k in needed):
        raise ValueError(f"{events_path}: needs columns {', '.join(needed)}")
    lengths: dict[int, float] = {}
    headings: dict[int, float] = {}
    position_path = base / "position_sample.csv"
    if position_path.is_file():
        last: dict[int, tuple[float, float]] = {}
        with open(position_path, newline="", encoding="utf-8") as handle:
            for row in csv.DictReader(handle):
                last[int(row["s_id"])] = (float(row["pos_x"]), float(row["pos_y"]))
        lengths = {k: math.hypot(*v) for k, v in last.items()}
    orientation_path = base / "orientation_sample.csv"
    if orientation_path.is_file():
        first_last: dict[int, list] = {}
        with open(orientation_path, newline="", encoding="utf-8") as handle:
            for row in csv.DictReader(handle):
                q = [float(row[k]) for k in ("q_x", "q_y", "q_z", "q_w")]
                entry = first_last.setdefault(int(row["s_id"]), [q, q])
                entry[1] = q
        for key, (q0, q1) in first_last.items():
            headings[key] = _heel_axis_turn_deg(q0, q1)
    result = []
    for row in rows:
        sid = int(row["s_id"])
        t = {k: float(row[k]) / rate_hz for k in ("start", "end", "ic", "tc", "pre_ic")}
        result.append(ReferenceStride(sid, row["foot"], t["pre_ic"], t["tc"], t["ic"], t["start"], t["end"],
                                      lengths.get(sid, float("nan")), headings.get(sid, float("nan"))))
    return result


def _heel_axis_turn_deg(q0_xyzw: Sequence[float], q1_xyzw: Sequence[float]) -> float:
    """Horizontal turn (deg) of the marker frame's x axis (heel direction) between two
    scalar-last quaternions ``q_marker_from_lab`` (they map lab vectors into the marker frame)."""
    def x_axis_in_lab(q):
        x, y, z, w = q
        r_marker_from_lab = rotation.to_matrix([w, x, y, z])
        return r_marker_from_lab[0]  # the marker's x axis in lab coordinates: R⁻¹ e_x = Rᵀ e_x
    a, b = x_axis_in_lab(q0_xyzw), x_axis_in_lab(q1_xyzw)
    angle = math.degrees(math.atan2(b[1], b[0]) - math.atan2(a[1], a[0]))
    return (angle + 180.0) % 360.0 - 180.0


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
