"""One measurement of one sensor (:class:`Sample`), its validation, and its packing into
blocks (:class:`PackedBlock`, unpacked into :class:`~mimucap.core.samples.SensorSamples`).

Units and frames (``docs/conventions.md``): ``acc`` specific force in m/s², ``gyr``
angular rate in rad/s, ``mag_uT`` magnetic field in µT, all in the *sensor* frame;
``q_world_from_sensor`` the on-board orientation, Hamilton, scalar first ``[w, x, y, z]``,
world = ENU. ``calibration`` is the BNO055-style calibration status ``(system, gyr, acc, mag)``
each 0..3. ``battery_pct`` is the remaining charge in percent (0..100).

Time: ``device_time_s`` is the node's own clock (seconds, arbitrary origin); a packed block's
``host_time_s`` (an unpacked record's ``t_s``) is the host's monotonic clock
(``time.monotonic()``, seconds) after clock mapping (see :mod:`mimucap.acquisition.timesync`);
``receive_time_s`` is the host's monotonic clock when the sample reached the host. A missing
channel is ``None`` — never zero-filled.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mimucap.acquisition.rejections import Rejection
from mimucap.core.samples import CHANNELS, SensorSamples
from mimucap.core.sensor_limits import ACC_MAX_M_S2, GYR_MAX_RAD_S, MAG_MAX_UT

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


@dataclass(frozen=True)
class ValueLimits:
    """Physical limits beyond which a measurement is refused as ``out_of_range``.

    Defaults are :mod:`mimucap.core.sensor_limits` (about twice the full scale of MEMS sensors
    used for human motion), the limits the file readers apply too.
    """

    acc_max: float = ACC_MAX_M_S2   #: m/s², per axis (≈ 32 g)
    gyr_max: float = GYR_MAX_RAD_S  #: rad/s, per axis (≈ 4000 °/s)
    mag_max_uT: float = MAG_MAX_UT  #: µT, per axis
    quat_norm_tolerance: float = 0.05  #: a quaternion's norm must be within 1 ± this
    device_time_max_s: float = 1.0e9   #: device clocks beyond ~30 years are corrupt


DEFAULT_LIMITS = ValueLimits()


@dataclass(frozen=True)
class Sample:
    """One decoded measurement of one sensor (see the module docstring for units)."""

    sensor_id: int                   #: the node's numeric id on the wire (0..65534)
    seq: int                         #: the node's sequence number as sent (wraps at 2**32)
    device_time_s: float             #: node clock, seconds
    acc: Vec3 | None = None
    gyr: Vec3 | None = None
    mag_uT: Vec3 | None = None
    q_world_from_sensor: Quat | None = None
    calibration: tuple[int, int, int, int] | None = None
    battery_pct: float | None = None

    def channels(self) -> tuple[str, ...]:
        """Names of the channels this sample carries, in wire order."""
        return tuple(name for name in CHANNELS if getattr(self, name) is not None)


@dataclass(frozen=True)
class RefusedSample:
    """A well-framed sample whose values were refused (NaN, infinity, beyond the limits).

    Its frame passed the checksum, so its sensor and sequence number are trusted: the intake
    counts the refusal against that sensor, and the sequence number it leaves free is a
    rejection with a reason, not a lost packet (see ``refused_in_gaps`` in the worker report).
    """

    sensor_id: int          #: the node's numeric id on the wire
    seq: int                #: the node's sequence number as sent (wraps at 2**32)
    reason: Rejection       #: ``non_finite`` or ``out_of_range``


def validated_or_refused(sample: Sample, limits: ValueLimits = DEFAULT_LIMITS) -> Sample | RefusedSample:
    """``sample`` validated by :func:`validate_sample`, or a :class:`RefusedSample` naming it."""
    result = validate_sample(sample, limits)
    if isinstance(result, Rejection):
        return RefusedSample(sample.sensor_id, sample.seq, result)
    return result


def validate_sample(sample: Sample, limits: ValueLimits = DEFAULT_LIMITS) -> Sample | Rejection:
    """``sample`` (with its quaternion normalised) or the reason it must be refused.

    Refuses NaN/infinity (``non_finite``) and values beyond ``limits`` (``out_of_range``).
    """
    isfinite = math.isfinite
    for values, bound in ((sample.acc, limits.acc_max), (sample.gyr, limits.gyr_max),
                          (sample.mag_uT, limits.mag_max_uT)):
        if values is not None:
            if not all(map(isfinite, values)):
                return Rejection.NON_FINITE
            if max(map(abs, values)) > bound:
                return Rejection.OUT_OF_RANGE
    q = sample.q_world_from_sensor
    if q is not None and not all(map(isfinite, q)):
        return Rejection.NON_FINITE
    if not isfinite(sample.device_time_s):
        return Rejection.NON_FINITE
    if not 0.0 <= sample.device_time_s <= limits.device_time_max_s:
        return Rejection.OUT_OF_RANGE
    if sample.battery_pct is not None:
        if not isfinite(sample.battery_pct):
            return Rejection.NON_FINITE
        if not 0.0 <= sample.battery_pct <= 100.0:
            return Rejection.OUT_OF_RANGE
    if sample.calibration is not None and any(not 0 <= c <= 3 for c in sample.calibration):
        return Rejection.OUT_OF_RANGE
    if q is not None:
        norm = math.sqrt(sum(v * v for v in q))
        if abs(norm - 1.0) > limits.quat_norm_tolerance:
            return Rejection.OUT_OF_RANGE
        sample = Sample(sample.sensor_id, sample.seq, sample.device_time_s, sample.acc,
                        sample.gyr, sample.mag_uT, tuple(v / norm for v in q),
                        sample.calibration, sample.battery_pct)
    return sample


def refused_rows(channels: dict[str, np.ndarray], limits: ValueLimits = DEFAULT_LIMITS) -> np.ndarray:
    """Why :func:`validate_sample` would refuse each row of columnar ``channels``.

    ``channels`` maps channel names of :data:`CHANNELS` to ``(N, ...)`` arrays in the units of
    :class:`~mimucap.core.samples.SensorSamples` (absent channels are left out). Returns an ``(N,)`` array of
    :class:`~mimucap.acquisition.rejections.Rejection` values (``"non_finite"``,
    ``"out_of_range"``), ``""`` for a row that would be accepted; each row gets the first
    reason :func:`validate_sample` would find. The device clock is not checked: a recorded
    row's time is the recording's, which its reader checks.
    """
    n = len(next(iter(channels.values()))) if channels else 0
    reasons = np.full(n, "", dtype=f"<U{max(len(r.value) for r in Rejection)}")

    def refuse(reason: Rejection, bad: np.ndarray) -> None:
        reasons[bad & (reasons == "")] = reason.value

    def values(name: str) -> np.ndarray | None:
        value = channels.get(name)
        return None if value is None else np.asarray(value, dtype=np.float64).reshape(n, -1)

    with np.errstate(invalid="ignore"):
        for name, bound in (("acc", limits.acc_max), ("gyr", limits.gyr_max), ("mag_uT", limits.mag_max_uT)):
            vector = values(name)
            if vector is not None:
                refuse(Rejection.NON_FINITE, ~np.all(np.isfinite(vector), axis=1))
                refuse(Rejection.OUT_OF_RANGE, np.any(np.abs(vector) > bound, axis=1))
        q = values("q_world_from_sensor")
        if q is not None:
            refuse(Rejection.NON_FINITE, ~np.all(np.isfinite(q), axis=1))
        battery = values("battery_pct")
        if battery is not None:
            refuse(Rejection.NON_FINITE, ~np.isfinite(battery[:, 0]))
            refuse(Rejection.OUT_OF_RANGE, (battery[:, 0] < 0.0) | (battery[:, 0] > 100.0))
        calibration = values("calibration")
        if calibration is not None:
            refuse(Rejection.OUT_OF_RANGE, np.any((calibration < 0) | (calibration > 3), axis=1))
        if q is not None:
            norm = np.linalg.norm(q, axis=1)
            refuse(Rejection.OUT_OF_RANGE, np.abs(norm - 1.0) > limits.quat_norm_tolerance)
    return reasons


_CHANNEL_DTYPES = {
    "acc": np.float64, "gyr": np.float64, "mag_uT": np.float64,
    "q_world_from_sensor": np.float64, "calibration": np.int8, "battery_pct": np.float64,
}


@dataclass(frozen=True, eq=False)
class PackedBlock:
    """Samples of several sensors in one set of columns (the worker → supervisor transport).

    Packing many sensors into a few arrays keeps the per-message cost independent of the
    number of sensors; :meth:`unpack` splits it into one
    :class:`~mimucap.core.samples.SensorSamples` per sensor.
    ``sensor_index`` (N,) indexes ``sensor_ids``; every row has the same ``channels``.
    """

    source: str
    sensor_ids: tuple[str, ...]
    sensor_index: np.ndarray
    seq: np.ndarray
    device_time_s: np.ndarray
    host_time_s: np.ndarray
    receive_time_s: np.ndarray
    channels: dict[str, np.ndarray]

    def __len__(self) -> int:
        return int(self.seq.shape[0])

    def unpack(self) -> list[SensorSamples]:
        """One record per sensor, in order of first appearance; rows keep their order; ``t_s``
        is the host time."""
        order = np.argsort(self.sensor_index, kind="stable")
        index = self.sensor_index[order]
        starts = np.flatnonzero(np.r_[True, index[1:] != index[:-1]])
        ends = np.r_[starts[1:], len(index)]
        seq, device = self.seq[order], self.device_time_s[order]
        host, receive = self.host_time_s[order], self.receive_time_s[order]
        present = [self.channels.get(name) for name in CHANNELS]
        present = [None if values is None else values[order] for values in present]
        names, source = self.sensor_ids, self.source
        blocks = []
        # positional arguments: the field order of SensorSamples (t_s, seq, CHANNELS, clocks)
        for start, end, sensor in zip(starts.tolist(), ends.tolist(), index[starts].tolist()):
            blocks.append(SensorSamples(
                names[sensor], host[start:end], seq[start:end],
                *[None if v is None else v[start:end] for v in present],
                device[start:end], receive[start:end], source))
        return blocks


def join_packed_blocks(blocks: Sequence[PackedBlock]) -> list[PackedBlock]:
    """Consecutive packed blocks of one source joined into as few as possible: one per set of
    channels, rows in their order. The supervisor joins what one poll drained, so that each
    sensor comes out of :meth:`PackedBlock.unpack` once per poll, not once per message.

    A worker's sensor list only grows (new sensors are appended), so a block whose
    ``sensor_ids`` extend another's joins it; blocks of other sources or with unrelated
    sensor lists stay apart.
    """
    groups: list[tuple[tuple[str, ...], list[PackedBlock]]] = []  # (longest sensor list, blocks)
    open_groups: dict[tuple, int] = {}  # (source, channels) -> index of its last group
    for block in blocks:
        key = (block.source, tuple(block.channels))
        index = open_groups.get(key)
        if index is not None:
            names, members = groups[index]
            shorter, longer = sorted((names, block.sensor_ids), key=len)
            if longer[: len(shorter)] == shorter:
                members.append(block)
                groups[index] = (longer, members)
                continue
        open_groups[key] = len(groups)
        groups.append((block.sensor_ids, [block]))
    return [members[0] if len(members) == 1 else _join(names, members) for names, members in groups]


def _join(sensor_ids: tuple[str, ...], blocks: list[PackedBlock]) -> PackedBlock:
    """One packed block of ``blocks`` (one source, same channels; indices into ``sensor_ids``)."""
    join = lambda name: np.concatenate([getattr(b, name) for b in blocks])  # noqa: E731
    return PackedBlock(
        source=blocks[0].source, sensor_ids=sensor_ids, sensor_index=join("sensor_index"), seq=join("seq"),
        device_time_s=join("device_time_s"), host_time_s=join("host_time_s"),
        receive_time_s=join("receive_time_s"),
        channels={name: np.concatenate([b.channels[name] for b in blocks]) for name in blocks[0].channels})


class _Group:
    __slots__ = ("channels", "index", "seq", "device", "host", "receive", "values")

    def __init__(self, channels: tuple[str, ...]) -> None:
        self.channels = channels
        self.index: list[int] = []
        self.seq: list[int] = []
        self.device: list[float] = []
        self.host: list[float] = []
        self.receive: list[float] = []
        self.values: list[list] = [[] for _ in channels]


class BlockBuilder:
    """Collects accepted samples of any sensors and packs them into :class:`PackedBlock` s
    (one per set of channels present)."""

    def __init__(self, source: str) -> None:
        self.source = source
        self._names: list[str] = []
        self._name_index: dict[str, int] = {}
        self._groups: dict[tuple[str, ...], _Group] = {}
        self._count = 0
        self.oldest_receive_time_s: float | None = None

    def __len__(self) -> int:
        return self._count

    def add(self, sensor_name: str, seq: int, sample: Sample, host_time_s: float,
            receive_time_s: float) -> None:
        """Append one validated sample (``seq`` already unwrapped)."""
        index = self._name_index.get(sensor_name)
        if index is None:
            index = self._name_index[sensor_name] = len(self._names)
            self._names.append(sensor_name)
        channels = sample.channels()
        group = self._groups.get(channels)
        if group is None:
            group = self._groups[channels] = _Group(channels)
        group.index.append(index)
        group.seq.append(seq)
        group.device.append(sample.device_time_s)
        group.host.append(host_time_s)
        group.receive.append(receive_time_s)
        for values, name in zip(group.values, channels):
            values.append(getattr(sample, name))
        self._count += 1
        if self.oldest_receive_time_s is None:
            self.oldest_receive_time_s = receive_time_s

    def take(self) -> list[PackedBlock]:
        """All pending samples, packed; the builder is empty afterwards."""
        names = tuple(self._names)
        packed = [PackedBlock(
            source=self.source, sensor_ids=names,
            sensor_index=np.asarray(group.index, dtype=np.int32),
            seq=np.asarray(group.seq, dtype=np.int64),
            device_time_s=np.asarray(group.device, dtype=np.float64),
            host_time_s=np.asarray(group.host, dtype=np.float64),
            receive_time_s=np.asarray(group.receive, dtype=np.float64),
            channels={name: np.asarray(values, dtype=_CHANNEL_DTYPES[name])
                      for name, values in zip(group.channels, group.values)})
            for group in self._groups.values()]
        self._groups.clear()
        self._count = 0
        self.oldest_receive_time_s = None
        return packed


class SequenceUnwrapper:
    """Unwraps a per-sensor 32-bit wire sequence number into a monotonic int64.

    A number more than ``2**31`` ahead is read as a wrap-around; a number at or before the
    last one is stale (duplicate or reordered) and refused. After a node restart
    (:meth:`restart`) the new counter continues right after the last number.
    """

    MODULUS = 2**32

    def __init__(self) -> None:
        self._last_wire: int | None = None   # last accepted number, unwrapped in the wire's own count
        self._offset = 0                     # added after a restart of the node's counter

    @property
    def last(self) -> int | None:
        """The last accepted unwrapped sequence number (``None`` before the first)."""
        return None if self._last_wire is None else self._last_wire + self._offset

    def unwrap(self, wire_seq: int) -> int | None:
        """Unwrapped number for ``wire_seq`` or ``None`` if it is stale."""
        if self._last_wire is None:
            self._last_wire = int(wire_seq)
            return self._last_wire + self._offset
        seq = self.peek(wire_seq)
        if seq is not None:
            self._last_wire = seq - self._offset
        return seq

    def peek(self, wire_seq: int) -> int | None:
        """What :meth:`unwrap` would number ``wire_seq`` (``None`` if stale or before the first
        accepted number), without accepting it."""
        if self._last_wire is None:
            return None
        delta = (int(wire_seq) - self._last_wire) % self.MODULUS
        if delta == 0 or delta >= self.MODULUS // 2:
            return None
        return self._last_wire + delta + self._offset

    def restart(self, wire_seq: int) -> int:
        """The node restarted its counter at ``wire_seq``: number it right after the last one."""
        last = self.last
        self._last_wire = int(wire_seq)
        self._offset = 0 if last is None else last + 1 - int(wire_seq)
        return self._last_wire + self._offset
