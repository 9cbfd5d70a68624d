"""MimuCap session files: HDF5, versioned, read back by this module only.

A session holds what was recorded (each sensor's raw samples, a
:class:`~mimucap.core.samples.SensorSamples`), what is known about it (metadata,
markers, optional ground truth of a simulation) and what was computed from it (calibrations
and results). The layout is documented in ``docs/session-format.md``; this module is its
only reader and writer.

Frames and units follow ``docs/conventions.md``: ``acc`` in m/s² (specific force,
sensor frame), ``gyr`` in rad/s (sensor frame), ``mag_uT`` in µT (sensor frame),
``q_world_from_sensor`` scalar-first Hamilton quaternions (world = ENU), times ``t_s`` in
seconds on the host clock since session start. Every dataset carries its unit as the HDF5
attribute ``unit``. Two channels are stored in the file's own form: the record's
``battery_pct`` (percent) as the dataset ``battery`` (a fraction 0..1), its ``calibration``
status as the extra channel ``calibration_status`` (N, 4) int8; a record's ``source`` and
``receive_time_s`` are not stored.

A file that is not a MimuCap session, is truncated or damaged, or was written by a newer
format version raises :class:`SessionFormatError` naming the file and what is wrong. So does
a sensor whose ``t_s`` is not finite and strictly increasing (:func:`time_stamp_problem`) or
whose gyroscope exceeds :data:`~mimucap.core.sensor_limits.GYR_MAX_RAD_S`, the limit live
acquisition applies too (:func:`gyro_range_problem`: most likely °/s stored as rad/s); the message names the sensor and the first offending row.
"""

from __future__ import annotations

import json
import os
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, TypeVar

import h5py
import numpy as np

from mimucap import __version__
from mimucap.core.device_identity import SensorDevice, devices_from_json
from mimucap.core.samples import SensorSamples
from mimucap.core.sensor_limits import GYR_MAX_RAD_S

#: Value of the root attribute ``format``.
SESSION_FORMAT = "mimucap-session"
#: The version this module writes; files with a higher ``format_version`` are refused.
SESSION_FORMAT_VERSION = 1

#: Optional per-sensor datasets: name → (trailing shape, unit). ``t_s`` and ``seq`` are required.
SENSOR_CHANNELS: dict[str, tuple[tuple[int, ...], str]] = {
    "acc": ((3,), "m/s^2"),
    "gyr": ((3,), "rad/s"),
    "mag_uT": ((3,), "uT"),
    "q_world_from_sensor": ((4,), "1 (quaternion w,x,y,z)"),
    "battery": ((), "1 (fraction 0..1)"),
    "device_time_s": ((), "s (device clock)"),
}

#: Dataset → the :class:`~mimucap.core.samples.SensorSamples` field it holds, where they differ.
_FIELD_OF_DATASET = {"battery": "battery_pct"}
#: A stored fraction × this = the record's percent.
_PERCENT_PER_FRACTION = 100.0
#: The extra channel that holds the record's ``calibration`` status.
CALIBRATION_STATUS = "calibration_status"

_COMPRESS_MIN_ELEMENTS = 4096
#: Why a sensor of a session has no device id when the session does not name one.
DEVICE_NOT_RECORDED = "the recording does not say which device it was (made before MimuCap recorded devices)"

#: :data:`~mimucap.core.sensor_limits.GYR_MAX_RAD_S` in °/s: a larger number is not a rate in
#: either unit.
_MAX_GYRO_DPS = float(np.rad2deg(GYR_MAX_RAD_S))
_AXES = "xyz"


class SessionFormatError(ValueError):
    """A file is not a readable MimuCap session (foreign, damaged, truncated or too new)."""


@dataclass(frozen=True)
class Marker:
    """A labelled instant (``t_s`` on the session's host clock, seconds)."""

    t_s: float
    label: str


@dataclass
class SensorTruth:
    """Ground truth of one simulated sensor, sampled on :attr:`SessionTruth.t_s` (T samples).

    ``q_world_from_sensor`` (T,4); ``q_segment_from_sensor`` (4,) mounting rotation;
    ``position_in_segment_m`` (3,) sensor origin in the segment frame relative to the
    segment's proximal point; ``mag_A`` (3,3) soft-iron matrix and ``mag_b_uT`` (3,) hard-iron
    offset of ``mag_raw = A·mag_true + b + noise``; ``gyr_bias_rad_s`` (T,3) gyroscope bias;
    ``field_world_uT`` (T,3) magnetic field at the sensor in the world frame (earth field plus
    disturbances); ``clock_offset_s``/``clock_drift`` of ``device_time = (1+drift)·t + offset``;
    ``parameters`` further scalar or array truths (e.g. ``gyr_scale``, ``acc_bias_mps2``).
    """

    sensor_id: str
    q_world_from_sensor: np.ndarray
    segment: str | None = None
    q_segment_from_sensor: np.ndarray | None = None
    position_in_segment_m: np.ndarray | None = None
    mag_A: np.ndarray | None = None
    mag_b_uT: np.ndarray | None = None
    gyr_bias_rad_s: np.ndarray | None = None
    field_world_uT: np.ndarray | None = None
    clock_offset_s: float | None = None
    clock_drift: float | None = None
    parameters: dict[str, Any] = field(default_factory=dict)


@dataclass
class SessionTruth:
    """Ground truth of a simulated session on its own time grid ``t_s`` (T,) seconds.

    ``q_world_from_segment`` segment name → (T,4); ``joint_angles_deg`` column name (as in
    ``skeleton.joint_angle_columns``) → (T,) degrees; ``sensors`` sensor id → :class:`SensorTruth`;
    ``field_world_uT`` (3,) undisturbed earth field (ENU, µT); ``extra`` name → array with T rows
    (e.g. ``mag_axis_turned``) or any array; ``attributes`` JSON-serialisable notes;
    ``protocol`` the true results of a clinical test (written as the attribute ``protocol_json``).
    """

    t_s: np.ndarray
    q_world_from_segment: dict[str, np.ndarray] = field(default_factory=dict)
    joint_angles_deg: dict[str, np.ndarray] = field(default_factory=dict)
    sensors: dict[str, SensorTruth] = field(default_factory=dict)
    field_world_uT: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    attributes: dict[str, Any] = field(default_factory=dict)
    protocol: dict[str, Any] | None = None


@dataclass
class Session:
    """One recording: ``metadata`` (JSON-serialisable dict, see ``docs/session-format.md``:
    ``source``, ``created_utc``, ``mimucap_version``, ``subject`` with ``id``, ``height_m``,
    ``dominance``, ``notes``), ``sensors`` (id → :class:`~mimucap.core.samples.SensorSamples`,
    ``t_s`` since the session start), ``markers``,
    ``truth`` (simulations only), ``calibrations`` (name → JSON-serialisable value, e.g.
    ``"magnetometer"`` → {sensor id → calibration dict}, ``"body"`` → dict) and ``results``
    (nested dict of name → array, number, string or dict).
    """

    metadata: dict[str, Any] = field(default_factory=dict)
    sensors: dict[str, SensorSamples] = field(default_factory=dict)
    markers: list[Marker] = field(default_factory=list)
    truth: SessionTruth | None = None
    calibrations: dict[str, Any] = field(default_factory=dict)
    results: dict[str, Any] = field(default_factory=dict)

    def sensor_segments(self) -> dict[str, str | None]:
        """Sensor id → segment name (``None`` when unassigned)."""
        return {sensor_id: stream.segment for sensor_id, stream in self.sensors.items()}

    def devices(self) -> dict[str, SensorDevice]:
        """Sensor id → its device as the recording says (metadata ``devices``,
        :mod:`mimucap.core.device_identity`); a sensor it does not name has none,
        :data:`DEVICE_NOT_RECORDED` saying why. ``ValueError`` for a malformed entry."""
        stored = devices_from_json(self.metadata.get("devices"), "the session's devices")
        return {sid: stored.get(sid, SensorDevice(None, DEVICE_NOT_RECORDED)) for sid in self.sensors}


@dataclass(frozen=True)
class SessionSummary:
    """What describes a session file without its samples (:func:`read_summary`): ``metadata``,
    ``segments`` sensor id → segment (None when unassigned), ``duration_s`` the time span (s)
    covered by the sensor streams (as :func:`session_duration_s`), ``markers`` and
    ``calibrations`` (as in :class:`Session`)."""

    metadata: dict[str, Any]
    segments: dict[str, str | None]
    duration_s: float
    markers: list[Marker]
    calibrations: dict[str, Any]


#: The sexes a subject record may name (the clinical norms differ by sex); "" when not given.
SEXES = ("female", "male", "")


def make_subject(
    subject_id: str = "", height_m: float = 1.75, dominance: str = "right", notes: str = "",
    age_years: float | None = None, sex: str = "", weight_kg: float | None = None,
) -> dict[str, Any]:
    """A subject record for ``metadata["subject"]``; ``dominance`` is ``"right"``, ``"left"``
    or ``"unknown"``; ``height_m`` must lie in (0.5, 2.5) m. Optional, for the clinical tests'
    reference values: ``age_years`` (0-120), ``sex`` one of :data:`SEXES`, ``weight_kg``
    (10-400); a value not given is left out of the record."""
    if not 0.5 < float(height_m) < 2.5:
        raise ValueError(f"subject height {height_m} m is outside 0.5..2.5 m")
    if dominance not in ("right", "left", "unknown"):
        raise ValueError(f"subject dominance must be right, left or unknown, got {dominance!r}")
    record: dict[str, Any] = {"id": str(subject_id), "height_m": float(height_m), "dominance": dominance,
                              "notes": str(notes)}
    if age_years is not None:
        if not 0.0 <= float(age_years) <= 120.0:
            raise ValueError(f"subject age {age_years} years is outside 0..120")
        record["age_years"] = float(age_years)
    if sex not in SEXES:
        raise ValueError(f"subject sex must be female or male (or empty), got {sex!r}")
    if sex:
        record["sex"] = sex
    if weight_kg is not None:
        if not 10.0 <= float(weight_kg) <= 400.0:
            raise ValueError(f"subject weight {weight_kg} kg is outside 10..400 kg")
        record["weight_kg"] = float(weight_kg)
    return record


# --------------------------------------------------------------------------------------------
# Plausibility of recorded samples
# --------------------------------------------------------------------------------------------

def time_stamp_problem(t_s: np.ndarray) -> str | None:
    """Why ``t_s`` (N,) s cannot be one sensor's sample times, or ``None`` when it can.

    Sample times must be finite and strictly increasing (the replay source, the filters and
    the joint-angle grid rely on it); the answer names the first bad row (0-based), e.g.
    ``"t_s goes back from 9.990 s to 5.000 s at row 1000"``, ``"t_s repeats 4.000 s at row
    401"`` or ``"t_s is NaN at row 400"``.
    """
    t = np.asarray(t_s, dtype=np.float64)
    not_finite = np.flatnonzero(~np.isfinite(t))
    not_increasing = np.flatnonzero(np.diff(t) <= 0.0) + 1    # NaN steps are caught above
    candidates = [int(rows[0]) for rows in (not_finite, not_increasing) if rows.size]
    if not candidates:
        return None
    row = min(candidates)
    if np.isnan(t[row]):
        return f"t_s is NaN at row {row}"
    if np.isinf(t[row]):
        return f"t_s is {t[row]:+} at row {row}"
    if t[row] == t[row - 1]:
        return f"t_s repeats {t[row]:.3f} s at row {row}"
    return f"t_s goes back from {t[row - 1]:.3f} s to {t[row]:.3f} s at row {row}"


def gyro_range_problem(gyr_rad_s: np.ndarray) -> str | None:
    """Why the gyroscope samples ``gyr_rad_s`` (N, 3) cannot be in rad/s, or ``None``.

    A component beyond :data:`~mimucap.core.sensor_limits.GYR_MAX_RAD_S` is refused (the
    fusion filter skips single samples beyond its own ``gyr_range_rad_s``; this refuses a whole
    file whose unit is wrong); the answer names the largest one,
    its axis and row (0-based) and the likely cause. NaN and infinite values are left to the
    filters, which skip and count them.
    """
    gyr = np.asarray(gyr_rad_s, dtype=np.float64)
    if gyr.size == 0:
        return None
    # fmin/fmax skip NaN and copy nothing: the usual case (all in range) costs two passes,
    # not three temporary arrays (hours of samples are hundreds of MB).
    if -GYR_MAX_RAD_S <= np.fmin.reduce(gyr, axis=None) and np.fmax.reduce(gyr, axis=None) <= GYR_MAX_RAD_S:
        return None
    rate = np.abs(gyr)
    rate = np.where(np.isfinite(rate), rate, 0.0)
    if rate.size == 0 or rate.max() <= GYR_MAX_RAD_S:
        return None
    row, axis = np.unravel_index(int(np.argmax(rate)), rate.shape)
    peak = float(rate[row, axis])
    cause = ("is it in °/s? MimuCap expects rad/s" if peak <= _MAX_GYRO_DPS
             else "not a plausible rate in rad/s or °/s (a damaged or wrongly scaled value?)")
    return (f"gyroscope reaches {peak:.4g} rad/s about its {_AXES[axis]} axis at row {row}, beyond the "
            f"range of motion-sensor gyroscopes (±{GYR_MAX_RAD_S:g} rad/s ≈ ±{_MAX_GYRO_DPS:.0f} °/s): {cause}")


# --------------------------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------------------------

def _check_name(name: str, what: str) -> None:
    if not isinstance(name, str) or not name or "/" in name or name in (".", ".."):
        raise ValueError(f"{what} {name!r} is not usable as a name (non-empty, no '/')")


def _dataset(group: h5py.Group, name: str, data: Any, unit: str | None = None) -> h5py.Dataset:
    array = np.asarray(data)
    if array.dtype.kind in ("U", "O"):
        strings = np.asarray(array, dtype=object)
        dataset = group.create_dataset(
            name, data=strings, dtype=h5py.string_dtype("utf-8"), track_times=False
        )
    elif array.size >= _COMPRESS_MIN_ELEMENTS and array.ndim >= 1:
        dataset = group.create_dataset(
            name, data=array, compression="gzip", compression_opts=4, shuffle=True,
            track_times=False,
        )
    else:
        dataset = group.create_dataset(name, data=array, track_times=False)
    if unit is not None:
        dataset.attrs["unit"] = unit
    return dataset


def _group(parent: h5py.Group, name: str) -> h5py.Group:
    return parent.create_group(name, track_order=True)


def _json(value: Any, what: str) -> str:
    try:
        return json.dumps(value, sort_keys=True, allow_nan=False, default=_json_default)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{what} is not JSON-serialisable: {error}") from error


def _json_default(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.integer, np.floating, np.bool_)):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON-serialisable")


def _write_nested(group: h5py.Group, values: Mapping[str, Any], what: str) -> None:
    for name, value in values.items():
        _check_name(name, what)
        if isinstance(value, Mapping):
            _write_nested(_group(group, name), value, f"{what}/{name}")
        elif isinstance(value, str):
            _dataset(group, name, np.array(value, dtype=object))
        else:
            array = np.asarray(value)
            if array.dtype.kind not in "biuf" and array.dtype.kind not in "UO":
                raise ValueError(f"{what}/{name}: cannot store values of type {array.dtype}")
            _dataset(group, name, array)


def _write_sensor(group: h5py.Group, stream: SensorSamples) -> None:
    """Write one sensor's samples (already :meth:`~mimucap.core.samples.SensorSamples.validated`)."""
    g = _group(group, stream.sensor_id)
    g.attrs["sensor_id"] = stream.sensor_id
    if stream.segment is not None:
        g.attrs["segment"] = stream.segment
    _dataset(g, "t_s", stream.t_s, "s")
    _dataset(g, "seq", stream.seq, "1")
    for name, (_trailing, unit) in SENSOR_CHANNELS.items():
        value = getattr(stream, _FIELD_OF_DATASET.get(name, name))
        if value is not None:
            _dataset(g, name, value / _PERCENT_PER_FRACTION if name == "battery" else value, unit)
    extras = dict(stream.extra or {})
    if stream.calibration is not None:
        if CALIBRATION_STATUS in extras:
            raise ValueError(f"sensor {stream.sensor_id}: the extra channel {CALIBRATION_STATUS} would hide "
                             f"the calibration channel")
        extras = {CALIBRATION_STATUS: stream.calibration, **extras}
    if extras:
        extra = _group(g, "extra")
        for name, value in extras.items():
            _dataset(extra, name, value)


_SENSOR_TRUTH_FIELDS: dict[str, str] = {
    "q_world_from_sensor": "1 (quaternion w,x,y,z)",
    "q_segment_from_sensor": "1 (quaternion w,x,y,z)",
    "position_in_segment_m": "m",
    "mag_A": "1",
    "mag_b_uT": "uT",
    "gyr_bias_rad_s": "rad/s",
    "field_world_uT": "uT",
}


def _write_truth(group: h5py.Group, truth: SessionTruth) -> None:
    g = _group(group, "truth")
    g.attrs["attributes_json"] = _json(truth.attributes, "truth attributes")
    if truth.protocol is not None:
        g.attrs["protocol_json"] = _json(truth.protocol, "truth protocol")
    _dataset(g, "t_s", np.asarray(truth.t_s, dtype=np.float64), "s")
    if truth.field_world_uT is not None:
        _dataset(g, "field_world_uT", np.asarray(truth.field_world_uT, dtype=np.float64), "uT")
    segments = _group(g, "q_world_from_segment")
    for name, q in truth.q_world_from_segment.items():
        _check_name(name, "truth segment")
        _dataset(segments, name, np.asarray(q, dtype=np.float64), "1 (quaternion w,x,y,z)")
    angles = _group(g, "joint_angles_deg")
    for name, values in truth.joint_angles_deg.items():
        _check_name(name, "truth joint angle column")
        _dataset(angles, name, np.asarray(values, dtype=np.float64), "deg")
    sensors = _group(g, "sensors")
    for sensor_id, sensor in truth.sensors.items():
        _check_name(sensor_id, "truth sensor id")
        s = _group(sensors, sensor_id)
        if sensor.segment is not None:
            s.attrs["segment"] = sensor.segment
        for name, unit in _SENSOR_TRUTH_FIELDS.items():
            value = getattr(sensor, name)
            if value is not None:
                _dataset(s, name, np.asarray(value, dtype=np.float64), unit)
        if sensor.clock_offset_s is not None:
            s.attrs["clock_offset_s"] = float(sensor.clock_offset_s)
        if sensor.clock_drift is not None:
            s.attrs["clock_drift"] = float(sensor.clock_drift)
        if sensor.parameters:
            _write_nested(_group(s, "parameters"), sensor.parameters, f"truth/sensors/{sensor_id}/parameters")
    if truth.extra:
        _write_nested(_group(g, "extra"), truth.extra, "truth/extra")


def write_session(path: str | os.PathLike[str], session: Session,
                  progress: Callable[[float], None] | None = None) -> Path:
    """Write ``session`` to the HDF5 file ``path`` (replaced atomically) and return the path;
    ``progress`` (optional) is called with the fraction of the sensors written (0..1).

    ``metadata`` gains ``created_utc`` (ISO 8601) and ``mimucap_version`` when missing. The
    file is first written beside the target and then renamed, so a crash never leaves a
    half-written session under the final name. Datasets carry no timestamps: the same session
    gives the same dataset bytes.
    """
    target = Path(path)
    metadata = dict(session.metadata)
    metadata.setdefault("created_utc", datetime.now(timezone.utc).isoformat(timespec="seconds"))
    metadata.setdefault("mimucap_version", __version__)
    metadata_json = _json(metadata, "session metadata")
    calibrations_json = {name: _json(value, f"calibration {name!r}") for name, value in session.calibrations.items()}
    sensors = [stream.validated() for stream in session.sensors.values()]
    for sensor_id, stream in zip(session.sensors, sensors):
        if sensor_id != stream.sensor_id:
            raise ValueError(f"session sensors: key {sensor_id!r} holds the samples of {stream.sensor_id!r}")
    directory = target.parent if str(target.parent) else Path(".")
    if not directory.is_dir():
        raise OSError(f"cannot write session {target}: folder {directory} does not exist")
    temporary = str(directory / f".{target.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.part")
    try:
        with h5py.File(temporary, "w", track_order=True) as h5:
            h5.attrs["format"] = SESSION_FORMAT
            h5.attrs["format_version"] = SESSION_FORMAT_VERSION
            h5.attrs["created_utc"] = str(metadata["created_utc"])
            h5.attrs["mimucap_version"] = str(metadata["mimucap_version"])
            h5.attrs["metadata_json"] = metadata_json
            sensors_group = _group(h5, "sensors")
            for index, stream in enumerate(sensors):
                _write_sensor(sensors_group, stream)
                if progress is not None:
                    progress((index + 1) / len(sensors))
            markers = _group(h5, "markers")
            _dataset(markers, "t_s", np.array([m.t_s for m in session.markers], dtype=np.float64), "s")
            _dataset(markers, "label", np.array([m.label for m in session.markers], dtype=object))
            calibrations = _group(h5, "calibrations")
            for name, text in calibrations_json.items():
                _check_name(name, "calibration name")
                _dataset(calibrations, name, np.array(text, dtype=object), "json")
            _write_nested(_group(h5, "results"), session.results, "results")
            if session.truth is not None:
                _write_truth(h5, session.truth)
        os.replace(temporary, target)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise
    return target


# --------------------------------------------------------------------------------------------
# Reading
# --------------------------------------------------------------------------------------------

class _Reader:
    """Reads one open file and turns every surprise into a :class:`SessionFormatError`."""

    def __init__(self, path: Path, h5: h5py.File) -> None:
        self.path = path
        self.h5 = h5

    def error(self, message: str) -> SessionFormatError:
        return SessionFormatError(f"{self.path}: {message}")

    def _item(self, parent: h5py.Group, name: str, kind: type, required: bool):
        """``parent[name]`` if it is a ``kind`` (h5py Group or Dataset); None if absent and
        not required; a :class:`SessionFormatError` naming it otherwise."""
        noun = "group" if kind is h5py.Group else "dataset"
        if name not in parent:
            if required:
                raise self.error(f"missing {noun} {parent.name.rstrip('/')}/{name}")
            return None
        item = parent[name]
        if not isinstance(item, kind):
            raise self.error(f"{item.name} should be a {noun}")
        return item

    def group(self, parent: h5py.Group, name: str, required: bool = True) -> h5py.Group | None:
        return self._item(parent, name, h5py.Group, required)

    def array(self, parent: h5py.Group, name: str, shape_tail: tuple[int, ...] | None = None,
              rows: int | None = None, required: bool = True, dtype: Any = np.float64) -> np.ndarray | None:
        item = self._item(parent, name, h5py.Dataset, required)
        if item is None:
            return None
        try:
            value = np.asarray(item[()], dtype=dtype)
        except (OSError, ValueError, TypeError) as error:
            raise self.error(f"cannot read {item.name} ({error})") from error
        if shape_tail is not None and value.shape[1:] != shape_tail:
            expected = ", ".join(["N", *map(str, shape_tail)])
            raise self.error(f"{item.name} has shape {value.shape}, expected ({expected})")
        if rows is not None and (value.ndim == 0 or value.shape[0] != rows):
            raise self.error(f"{item.name} has {value.shape[0] if value.ndim else 0} rows, expected {rows}")
        return value

    def text(self, dataset: h5py.Dataset) -> str:
        try:
            value = dataset[()]
        except (OSError, ValueError) as error:
            raise self.error(f"cannot read {dataset.name} ({error})") from error
        return value.decode("utf-8") if isinstance(value, bytes) else str(value)

    def json(self, text: str, where: str) -> Any:
        try:
            return json.loads(text)
        except json.JSONDecodeError as error:
            raise self.error(f"{where} is not valid JSON ({error})") from error

    def check_header(self) -> dict[str, Any]:
        attrs = self.h5.attrs
        if "format" not in attrs:
            raise self.error("not a MimuCap session (no 'format' attribute; foreign HDF5 file?)")
        fmt = attrs["format"]
        fmt = fmt.decode() if isinstance(fmt, bytes) else str(fmt)
        if fmt != SESSION_FORMAT:
            raise self.error(f"not a MimuCap session (format is {fmt!r}, expected {SESSION_FORMAT!r})")
        try:
            version = int(attrs["format_version"])
        except (KeyError, TypeError, ValueError) as error:
            raise self.error("missing or invalid 'format_version' attribute") from error
        if version > SESSION_FORMAT_VERSION:
            raise self.error(
                f"session format version {version} is newer than this MimuCap ({__version__}) "
                f"can read (up to {SESSION_FORMAT_VERSION}); update MimuCap"
            )
        if version < 1:
            raise self.error(f"invalid session format version {version}")
        if "metadata_json" not in attrs:
            raise self.error("missing 'metadata_json' attribute")
        metadata = self.json(str(attrs["metadata_json"]), "metadata_json")
        if not isinstance(metadata, dict):
            raise self.error("metadata_json must hold a JSON object")
        return metadata

    def sensor(self, g: h5py.Group) -> SensorSamples:
        sensor_id = g.name.rsplit("/", 1)[-1]
        t_s = self.array(g, "t_s")
        if t_s.ndim != 1:
            raise self.error(f"{g.name}/t_s must be one-dimensional, has shape {t_s.shape}")
        n = t_s.shape[0]
        seq = self.array(g, "seq", rows=n, dtype=np.int64)
        channels = {}
        for name, (trailing, _unit) in SENSOR_CHANNELS.items():
            value = self.array(g, name, rows=n, required=False)
            if value is not None and value.shape[1:] != trailing:
                raise self.error(f"{g.name}/{name} has shape {value.shape}, expected {(n,) + trailing}")
            channels[_FIELD_OF_DATASET.get(name, name)] = value
        if channels["battery_pct"] is not None:
            channels["battery_pct"] = channels["battery_pct"] * _PERCENT_PER_FRACTION
        extra = {}
        extra_group = self.group(g, "extra", required=False)
        if extra_group is not None:
            for name in extra_group:
                extra[name] = self.array(extra_group, name, rows=n, dtype=None)
        calibration = extra.pop(CALIBRATION_STATUS, None)
        if calibration is not None and (calibration.shape[1:] != (4,) or calibration.dtype.kind not in "iu"):
            raise self.error(f"{g.name}/extra/{CALIBRATION_STATUS} has shape {calibration.shape} of "
                             f"{calibration.dtype}, expected ({n}, 4) integers")
        problem = time_stamp_problem(t_s)
        if problem is None and channels["gyr"] is not None:
            problem = gyro_range_problem(channels["gyr"])
        if problem is not None:
            raise self.error(f"sensor {sensor_id}: {problem}")
        segment = g.attrs.get("segment")
        return SensorSamples.checked(
            sensor_id, t_s, seq, calibration=calibration, segment=None if segment is None else str(segment),
            extra=extra, **channels,
        )

    def nested(self, g: h5py.Group) -> dict[str, Any]:
        values: dict[str, Any] = {}
        for name, item in g.items():
            if isinstance(item, h5py.Group):
                values[name] = self.nested(item)
            elif item.dtype.kind == "O" or h5py.check_string_dtype(item.dtype) is not None:
                if item.shape == ():
                    values[name] = self.text(item)
                else:
                    values[name] = np.array([v.decode("utf-8") if isinstance(v, bytes) else v
                                             for v in item[()]], dtype=object)
            else:
                values[name] = self.array(g, name, dtype=None)
        return values

    def truth(self, g: h5py.Group) -> SessionTruth:
        t_s = self.array(g, "t_s")
        n = t_s.shape[0]
        field_world = self.array(g, "field_world_uT", required=False)
        segments = {name: self.array(self.group(g, "q_world_from_segment"), name, (4,), n)
                    for name in self.group(g, "q_world_from_segment")}
        angles_group = self.group(g, "joint_angles_deg")
        angles = {name: self.array(angles_group, name, rows=n) for name in angles_group}
        sensors = {}
        sensors_group = self.group(g, "sensors")
        for sensor_id, s in sensors_group.items():
            if not isinstance(s, h5py.Group):
                raise self.error(f"{s.name} should be a group")
            values = {name: self.array(s, name, required=(name == "q_world_from_sensor"))
                      for name in _SENSOR_TRUTH_FIELDS}
            if values["q_world_from_sensor"].shape != (n, 4):
                raise self.error(f"{s.name}/q_world_from_sensor has shape "
                                 f"{values['q_world_from_sensor'].shape}, expected ({n}, 4)")
            parameters_group = self.group(s, "parameters", required=False)
            segment = s.attrs.get("segment")
            sensors[sensor_id] = SensorTruth(
                sensor_id=sensor_id,
                segment=None if segment is None else str(segment),
                clock_offset_s=_optional_float(s.attrs.get("clock_offset_s")),
                clock_drift=_optional_float(s.attrs.get("clock_drift")),
                parameters={} if parameters_group is None else self.nested(parameters_group),
                **values,
            )
        extra_group = self.group(g, "extra", required=False)
        attributes = self.json(str(g.attrs.get("attributes_json", "{}")), "truth attributes_json")
        protocol = g.attrs.get("protocol_json")
        return SessionTruth(
            t_s=t_s, q_world_from_segment=segments, joint_angles_deg=angles, sensors=sensors,
            field_world_uT=field_world, extra={} if extra_group is None else self.nested(extra_group),
            attributes=attributes,
            protocol=None if protocol is None else self.json(str(protocol), "truth protocol_json"),
        )

    def session(self, include_truth: bool) -> Session:
        metadata = self.check_header()
        sensors_group = self.group(self.h5, "sensors")
        sensors = {}
        for sensor_id, g in sensors_group.items():
            if not isinstance(g, h5py.Group):
                raise self.error(f"{g.name} should be a group")
            sensors[sensor_id] = self.sensor(g)
        results = self.nested(self.group(self.h5, "results"))
        truth = None
        if include_truth and "truth" in self.h5:
            truth = self.truth(self.group(self.h5, "truth"))
        return Session(metadata=metadata, sensors=sensors, markers=self.markers(), truth=truth,
                       calibrations=self.calibrations(), results=results)

    def markers(self) -> list[Marker]:
        markers_group = self.group(self.h5, "markers")
        marker_t = self.array(markers_group, "t_s")
        labels = self.nested(markers_group).get("label")
        if labels is None or np.shape(labels) != marker_t.shape:
            raise self.error("/markers/label is missing or does not match /markers/t_s")
        return [Marker(float(t), str(label)) for t, label in zip(marker_t, labels)]

    def calibrations(self) -> dict[str, Any]:
        calibrations = {}
        for name, item in self.group(self.h5, "calibrations").items():
            if not isinstance(item, h5py.Dataset):
                raise self.error(f"{item.name} should be a JSON string dataset")
            calibrations[name] = self.json(self.text(item), item.name)
        return calibrations

    def summary(self) -> SessionSummary:
        """What describes the file, without its samples: of each sensor only the first and
        last time stamp are read."""
        metadata = self.check_header()
        segments: dict[str, str | None] = {}
        starts, ends = [], []
        for sensor_id, g in self.group(self.h5, "sensors").items():
            if not isinstance(g, h5py.Group):
                raise self.error(f"{g.name} should be a group")
            t_s = self._item(g, "t_s", h5py.Dataset, True)
            if len(t_s.shape) != 1:
                raise self.error(f"{g.name}/t_s must be one-dimensional, has shape {t_s.shape}")
            n = t_s.shape[0]
            if n:
                try:
                    starts.append(float(t_s[0]))
                    ends.append(float(t_s[n - 1]))
                except (OSError, ValueError, TypeError) as error:
                    raise self.error(f"cannot read {t_s.name} ({error})") from error
            segment = g.attrs.get("segment")
            segments[sensor_id] = None if segment is None else str(segment)
        duration_s = float(max(ends) - min(starts)) if starts else 0.0
        return SessionSummary(metadata, segments, duration_s, self.markers(), self.calibrations())


def _optional_float(value: Any) -> float | None:
    return None if value is None else float(value)


def _open(path: Path) -> h5py.File:
    if not path.exists():
        raise FileNotFoundError(f"session file not found: {path}")
    if not h5py.is_hdf5(path):
        raise SessionFormatError(f"{path}: not an HDF5 file (a MimuCap session is HDF5)")
    try:
        return h5py.File(path, "r")
    except OSError as error:
        raise SessionFormatError(f"{path}: damaged or truncated HDF5 file ({error})") from error


_T = TypeVar("_T")


def _read(path: str | os.PathLike[str], read: Callable[[_Reader], _T]) -> _T:
    """``read`` of a :class:`_Reader` on the open file ``path``; every surprise of the file a
    :class:`SessionFormatError` naming it."""
    source = Path(path)
    h5 = _open(source)
    try:
        return read(_Reader(source, h5))
    except SessionFormatError:
        raise
    except (OSError, KeyError, ValueError, RuntimeError) as error:
        raise SessionFormatError(f"{source}: damaged session file ({error})") from error
    finally:
        h5.close()


def read_session(path: str | os.PathLike[str], include_truth: bool = True) -> Session:
    """Read the session file ``path`` written by :func:`write_session`.

    ``include_truth=False`` skips the (possibly large) ground-truth group. Raises
    ``FileNotFoundError`` for a missing file and :class:`SessionFormatError` (naming the file
    and the problem) for a foreign, damaged, truncated or newer-version file.
    """
    return _read(path, lambda reader: reader.session(include_truth))


def read_summary(path: str | os.PathLike[str]) -> SessionSummary:
    """The :class:`SessionSummary` of the session file ``path``: its attributes, markers and
    calibrations, and of the samples only each sensor's first and last time stamp (h5py reads
    no more), so that listing many files costs little. Same errors as :func:`read_session` for
    a foreign, truncated or newer-version file, bad metadata, markers or calibrations, or a
    sensor without time stamps; the samples (their shapes and values) are checked when the
    file is read whole."""
    return _read(path, _Reader.summary)


def read_metadata(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Only the metadata of the session file ``path`` (fast; same errors as :func:`read_session`)."""
    return _read(path, _Reader.check_header)


def update_metadata(path: str | os.PathLike[str], changes: Mapping[str, Any]) -> dict[str, Any]:
    """Set the top-level metadata keys ``changes`` of session file ``path``; return the new metadata.

    The file is copied beside itself, the copy changed and renamed over the original (as
    :func:`write_session` does), so a crash leaves either the old or the new file, never a
    half-changed one. Same errors as :func:`read_metadata` for a file that is not a session.
    """
    import shutil

    source = Path(path)
    metadata = read_metadata(source)
    metadata.update(changes)
    metadata_json = _json(metadata, "session metadata")
    temporary = source.parent / f".{source.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.part"
    try:
        shutil.copy2(source, temporary)
        with h5py.File(temporary, "r+") as h5:
            h5.attrs["metadata_json"] = metadata_json
        with open(temporary, "rb+") as handle:
            os.fsync(handle.fileno())
        os.replace(temporary, source)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return metadata


def session_duration_s(session: Session) -> float:
    """Time span (s) covered by the sensor streams (0 when there are no samples)."""
    starts = [s.t_s[0] for s in session.sensors.values() if len(s)]
    ends = [s.t_s[-1] for s in session.sensors.values() if len(s)]
    return float(max(ends) - min(starts)) if starts else 0.0


def session_from_simulation(result: Any, subject: dict[str, Any] | None = None, include_truth: bool = True) -> Session:
    """A :class:`Session` holding a :class:`mimucap.core.simulate.suit.SimulationResult`.

    Sensors keep the simulated samples (dropped packets absent); ``metadata["source"]``
    records the scenario, seed, rate, sensor count, model, error model and earth field so the
    file says how to reproduce it; ``metadata["devices"]`` each unit's device id (the suit's
    fingerprint and the unit, :meth:`~mimucap.core.simulate.SimulationConfig.device_ids`); markers are the activity changes; ``truth`` (unless
    ``include_truth`` is False) holds segment and sensor orientations, mounting, magnetometer
    distortion, gyroscope bias, field, joint angles and the hand-held calibration axis.
    """
    from dataclasses import asdict

    config = result.config
    errors = config.error_settings()
    sensors = {sid: s.validated() for sid, s in result.samples.items()}
    source = {
        "kind": "simulated", "scenario": config.scenario, "scenario_params": dict(config.scenario_params),
        "duration_s": config.duration_s, "n_sensors": config.n_sensors, "rate_hz": config.rate_hz,
        "seed": config.seed, "model": result.model_name, "height_m": result.height_m,
        "errors": asdict(errors), "earth_field": asdict(config.earth_field),
        "disturbances": [asdict(d) for d in config.disturbances], "random_mounting": config.random_mounting,
        "magcal_turns": config.magcal_turns, "room": config.room,
    }
    metadata = {
        "source": source,
        "subject": subject if subject is not None else make_subject("simulated", result.height_m, "right", "simulated subject"),
        "sensor_segments": {sid: s.segment for sid, s in result.samples.items()},
        "devices": {sid: {"device_id": device_id} for sid, device_id in config.device_ids().items()},
        "skeleton_model": result.model_name,
        "height_m": result.height_m,
    }
    truth = None
    if include_truth:
        tr = result.truth
        sensor_truth = {}
        for sid, mounting in result.mounting.items():
            params = result.parameters[sid]
            sensor_truth[sid] = SensorTruth(
                sensor_id=sid, q_world_from_sensor=tr.q_world_from_sensor[sid], segment=mounting.segment,
                q_segment_from_sensor=mounting.q_segment_from_sensor,
                position_in_segment_m=mounting.position_in_segment_m, mag_A=params.mag_A, mag_b_uT=params.mag_b_uT,
                gyr_bias_rad_s=tr.gyr_bias_rad_s[sid], field_world_uT=tr.field_world_uT[sid],
                clock_offset_s=params.clock_offset_s, clock_drift=params.clock_drift,
                parameters={"gyr_scale": params.gyr_scale, "acc_bias_mps2": params.acc_bias_mps2,
                            "acc_scale": params.acc_scale, "position_m": tr.position_m[sid], "held": tr.held[sid]},
            )
        truth = SessionTruth(
            t_s=tr.t_s, q_world_from_segment=dict(tr.q_world_from_segment), joint_angles_deg=dict(tr.joint_angles_deg),
            sensors=sensor_truth, field_world_uT=np.asarray(result.field_world_uT),
            extra={"root_position_m": tr.root_position_m, "mag_axis_turned": tr.mag_axis_turned,
                   "foot_contact": tr.foot_contact},
            attributes={"joint_angle_sequence": "ZXY", "model": result.model_name, "height_m": result.height_m,
                        "room": config.room},
            protocol=getattr(result, "protocol", None),
        )
    return Session(
        metadata=metadata, sensors=sensors, markers=[Marker(float(t), label) for t, label in result.markers],
        truth=truth,
    )


__all__ = [
    "SESSION_FORMAT", "SESSION_FORMAT_VERSION", "SENSOR_CHANNELS", "SessionFormatError",
    "time_stamp_problem", "gyro_range_problem",
    "CALIBRATION_STATUS", "DEVICE_NOT_RECORDED", "SEXES", "Marker", "SensorTruth", "SessionTruth", "Session",
    "SessionSummary", "make_subject",
    "write_session", "read_session", "read_metadata", "read_summary", "update_metadata", "session_duration_s",
    "session_from_simulation",
]
