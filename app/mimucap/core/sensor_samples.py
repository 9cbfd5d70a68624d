"""One sensor's samples (:class:`SensorSamples`): the record every layer passes on.

The same record carries a sensor's samples from a source (a block of a few samples, thousands
per second), through the pipeline and the calibration procedures, into a recording and back
out of a session file or the simulator. Its columns have ``N`` rows, time-ordered.

Units and frames (``docs/conventions.md``): ``acc`` specific force in m/s², ``gyr``
angular rate in rad/s, ``mag_uT`` magnetic field in µT, all in the *sensor* frame;
``q_world_from_sensor`` an orientation of the sensor, Hamilton, scalar first ``[w, x, y, z]``,
world = ENU (the device's own when it fuses on board); ``calibration`` the BNO055-style
calibration status ``(system, gyr, acc, mag)`` each 0..3 (−1 where a recording lacked it);
``battery_pct`` the remaining charge in percent (0..100; a session file stores it as a
fraction, converted by its reader and writer). A channel the sensor does not send is
``None``: never zero-filled.

Time: ``t_s`` is the host clock in seconds. Its origin is the holder's: blocks from a source
carry the host's monotonic clock (``time.monotonic()``, device clocks mapped onto it by the
time-sync estimate); the pipeline, a recording and a session file count from the session
start; the simulator from its own start. :meth:`SensorSamples.with_times` restamps a record
from one origin to another. ``device_time_s`` is the node's own clock (seconds, arbitrary
origin; a replayed row's recorded time), ``receive_time_s`` the host's monotonic clock when
the sample reached the host; either is ``None`` where it is not known.

Construction checks nothing (a source builds thousands of records per second);
:meth:`SensorSamples.checked` is the validating constructor for data from outside (files,
imports): it converts the arrays to their dtypes and refuses a wrong shape with a
``ValueError`` naming the sensor. :func:`concatenate_samples` joins consecutive records of
one sensor, :func:`join_per_sensor` those of one poll per sensor, :meth:`SensorSamples.rows`
selects rows.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

#: Optional per-sample channels, in their wire order (the order of the UDP payload flags).
CHANNELS = ("acc", "gyr", "mag_uT", "q_world_from_sensor", "calibration", "battery_pct")
#: Optional per-sample clocks besides ``t_s``.
CLOCKS = ("device_time_s", "receive_time_s")
#: Every optional per-sample array: name → trailing shape. Fields of :class:`SensorSamples` in
#: this order follow ``t_s`` and ``seq``.
ROW_SHAPES: dict[str, tuple[int, ...]] = {
    "acc": (3,), "gyr": (3,), "mag_uT": (3,), "q_world_from_sensor": (4,), "calibration": (4,),
    "battery_pct": (), "device_time_s": (), "receive_time_s": (),
}
#: The calibration status is small integers; every other array is float64.
CALIBRATION_DTYPE = np.int8
#: What stands for "not known" where :func:`concatenate_samples` fills a row.
_FILL = {"calibration": -1}


@dataclass(eq=False, slots=True)
class SensorSamples:
    """Consecutive samples of one sensor, columnar (see the module docstring for frames,
    units and clocks). Treat it as read-only; it is not frozen because frozen construction is
    too slow for a source's thousands of blocks per second.

    Shapes: ``t_s`` (N,) float64; ``seq`` (N,) int64 the sensor's unwrapped sequence numbers
    (gaps are dropped samples); ``acc``/``gyr``/``mag_uT`` (N, 3); ``q_world_from_sensor``
    (N, 4); ``calibration`` (N, 4) int8; ``battery_pct``, ``device_time_s``,
    ``receive_time_s`` (N,). ``source`` names the source that delivered the samples ("" when
    none did, e.g. a file), ``segment`` the body segment the sensor is worn on (``None`` if
    unassigned), ``extra`` further per-sample arrays of a recording (name → array with N
    rows; the name carries its unit), ``None`` when there are none.
    """

    sensor_id: str
    t_s: np.ndarray
    seq: np.ndarray
    acc: np.ndarray | None = None
    gyr: np.ndarray | None = None
    mag_uT: np.ndarray | None = None
    q_world_from_sensor: np.ndarray | None = None
    calibration: np.ndarray | None = None
    battery_pct: np.ndarray | None = None
    device_time_s: np.ndarray | None = None
    receive_time_s: np.ndarray | None = None
    source: str = ""
    segment: str | None = None
    # None rather than an empty dict: a default factory would double the cost of building one
    extra: dict[str, np.ndarray] | None = None

    def __len__(self) -> int:
        return int(self.t_s.shape[0])

    def channels(self) -> tuple[str, ...]:
        """Names of the channels present, in wire order (:data:`CHANNELS`)."""
        return tuple(name for name in CHANNELS if getattr(self, name) is not None)

    @classmethod
    def checked(cls, sensor_id: str, t_s: Any, seq: Any, **fields: Any) -> SensorSamples:
        """The validating constructor, for samples from outside the program (files, imports):
        the arrays converted (``t_s`` and the float channels to float64, ``seq`` to int64,
        ``calibration`` to int8) and every shape checked; a ``ValueError`` naming the sensor
        and the array otherwise. ``fields`` are the other fields of :class:`SensorSamples`."""
        return cls(sensor_id, t_s, seq, **fields).validated()

    def validated(self) -> SensorSamples:
        """This record with its arrays converted and checked as :meth:`checked` does."""
        sensor = self.sensor_id
        _check_name(sensor, "sensor id")
        t_s = np.asarray(self.t_s, dtype=np.float64)
        if t_s.ndim != 1:
            raise ValueError(f"sensor {sensor}: t_s must have shape (N,), got {t_s.shape}")
        n = t_s.shape[0]
        seq = np.asarray(self.seq)
        if seq.shape != (n,) or not np.issubdtype(seq.dtype, np.integer):
            raise ValueError(f"sensor {sensor}: seq must be an integer array of shape ({n},), "
                             f"got {seq.dtype} {seq.shape}")
        rows = {}
        for name, trailing in ROW_SHAPES.items():
            value = getattr(self, name)
            if value is None:
                rows[name] = None
                continue
            if name == "calibration":
                array = np.asarray(value)
                if not np.issubdtype(array.dtype, np.integer):
                    raise ValueError(f"sensor {sensor}: calibration must be an integer array, got {array.dtype}")
                array = array.astype(CALIBRATION_DTYPE, copy=False)
            else:
                array = np.asarray(value, dtype=np.float64)
            if array.shape != (n,) + trailing:
                raise ValueError(f"sensor {sensor}: {name} must have shape {(n,) + trailing}, got {array.shape}")
            rows[name] = array
        extra = {}
        for name, value in (self.extra or {}).items():
            _check_name(name, f"sensor {sensor} extra channel")
            array = np.asarray(value)
            if array.ndim == 0 or array.shape[0] != n:
                raise ValueError(f"sensor {sensor}: extra channel {name} must have {n} rows, got {array.shape}")
            extra[name] = array
        return SensorSamples(sensor, t_s, seq.astype(np.int64, copy=False), **rows, source=self.source,
                             segment=self.segment, extra=extra or None)

    def rows(self, index: slice | np.ndarray) -> SensorSamples:
        """The rows ``index`` selects (a slice, a boolean mask or integer indices), every
        per-sample array alike; the rest is kept."""
        picked = [None if (value := getattr(self, name)) is None else value[index] for name in ROW_SHAPES]
        extra = None if self.extra is None else {name: value[index] for name, value in self.extra.items()}
        return SensorSamples(self.sensor_id, self.t_s[index], self.seq[index], *picked, self.source,
                             self.segment, extra)

    def with_times(self, t_s: np.ndarray) -> SensorSamples:
        """The same samples stamped ``t_s`` (N,) s (e.g. session seconds instead of the host's
        monotonic clock); the arrays are shared, not copied."""
        return SensorSamples(self.sensor_id, t_s, self.seq, self.acc, self.gyr, self.mag_uT,
                             self.q_world_from_sensor, self.calibration, self.battery_pct,
                             self.device_time_s, self.receive_time_s, self.source, self.segment, self.extra)


def concatenate_samples(parts: Sequence[SensorSamples],
                        missing: Literal["refuse", "drop", "fill"] = "refuse") -> SensorSamples:
    """One record from consecutive records of one sensor, rows in the order given.

    ``missing`` says what becomes of an optional array (channel or clock) that some parts
    have and others lack: ``"refuse"`` raises ``ValueError``; ``"drop"`` leaves it out (a
    channel is present only where every row has it); ``"fill"`` keeps it, with NaN (−1 for
    the calibration status) in the rows that lacked it, so that a recording keeps every
    sample and says which values were not sent. ``extra`` arrays every part has are joined.
    ``source`` and ``segment`` are the first part's.
    """
    if not parts:
        raise ValueError("no samples to concatenate")
    first = parts[0]
    if len(parts) == 1:
        return first
    sensor = first.sensor_id
    if any(p.sensor_id != sensor for p in parts):
        strangers = sorted({p.sensor_id for p in parts} - {sensor})
        raise ValueError(f"cannot join the samples of sensor {sensor} with those of {', '.join(strangers)}")
    joined = []
    for name in ROW_SHAPES:
        arrays = [getattr(p, name) for p in parts]
        absent = sum(a is None for a in arrays)
        if not absent:
            joined.append(np.concatenate(arrays))
        elif absent == len(arrays):
            joined.append(None)
        elif missing == "refuse":
            raise ValueError(f"sensor {sensor}: {name} is present in some of the samples to join "
                             f"and absent in others")
        elif missing == "drop":
            joined.append(None)
        elif missing == "fill":
            fill = _FILL.get(name, np.nan)
            dtype = CALIBRATION_DTYPE if name == "calibration" else np.float64
            joined.append(np.concatenate([np.full((len(p),) + ROW_SHAPES[name], fill, dtype=dtype) if a is None
                                          else np.asarray(a, dtype=dtype) for p, a in zip(parts, arrays)]))
        else:
            raise ValueError(f"missing must be 'refuse', 'drop' or 'fill', got {missing!r}")
    extra = None
    if any(p.extra for p in parts):
        names = [set(p.extra or ()) for p in parts]
        common = set.intersection(*names)
        if missing == "refuse" and any(n != common for n in names):
            raise ValueError(f"sensor {sensor}: the samples to join have different extra channels")
        extra = {name: np.concatenate([p.extra[name] for p in parts]) for name in first.extra or () if name in common}
        extra = extra or None
    return SensorSamples(first.sensor_id, np.concatenate([p.t_s for p in parts]),
                         np.concatenate([p.seq for p in parts]), *joined, first.source, first.segment, extra)


def join_per_sensor(blocks: Iterable[SensorSamples]) -> list[SensorSamples]:
    """Blocks of many sensors (e.g. one poll of a source) with each sensor's blocks that carry
    the same channels joined into one (:func:`concatenate_samples`), in order of first
    appearance; empty blocks are left out. Wireless nodes deliver a sample or two at a time,
    and what follows (filters, buffers, statistics, the journal) costs the same per call
    whatever a block's length."""
    groups: dict[tuple, list[SensorSamples]] = {}
    for block in blocks:
        if len(block):
            groups.setdefault((block.sensor_id, block.channels()), []).append(block)
    return [concatenate_samples(parts) for parts in groups.values()]


def _check_name(name: Any, what: str) -> None:
    """Refuse a name that cannot name a sensor or a channel (in files, menus, calibrations)."""
    if not isinstance(name, str) or not name or "/" in name or name in (".", ".."):
        raise ValueError(f"{what} {name!r} is not usable as a name (non-empty, no '/')")


__all__ = ["CHANNELS", "CLOCKS", "ROW_SHAPES", "CALIBRATION_DTYPE", "SensorSamples", "concatenate_samples",
           "join_per_sensor"]
