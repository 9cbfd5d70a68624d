"""One measurement of one sensor (:class:`Sample`), its validation, and blocks of them.

Units and frames (``shared/docs/conventions.md``): ``acc`` specific force in m/s², ``gyr``
angular rate in rad/s, ``mag_uT`` magnetic field in µT, all in the *sensor* frame;
``q_world_from_sensor`` the on-board orientation, Hamilton, scalar first ``[w, x, y, z]``,
world = ENU. ``calibration`` is the BNO055-style calibration status ``(system, gyr, acc, mag)``
each 0..3. ``battery_pct`` is the remaining charge in percent (0..100).

Time: ``device_time_s`` is the node's own clock (seconds, arbitrary origin); ``host_time_s`` is
the host's monotonic clock (``time.monotonic()``, seconds) after clock mapping (see
:mod:`mimucap.acquisition.timesync`); ``receive_time_s`` is the host's monotonic clock when the
sample reached the host. A missing channel is ``None`` — never zero-filled.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mimucap.acquisition.rejections import Rejection

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]

#: Channel names in their wire order (the order of the UDP payload flags).
CHANNELS = ("acc", "gyr", "mag_uT", "q_world_from_sensor", "calibration", "battery_pct")


@dataclass(frozen=True)
class ValueLimits:
    """Physical limits beyond which a measurement is refused as ``out_of_range``.

    Defaults are about twice the full scale of MEMS sensors used for human motion
    (BNO055 / MPU-9250: ±16 g, ±2000 °/s, ±4900 µT).
    """

    acc_max: float = 320.0          #: m/s², per axis (≈ 32 g)
    gyr_max: float = 70.0           #: rad/s, per axis (≈ 4000 °/s)
    mag_max_uT: float = 5000.0      #: µT, per axis
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


def _finite(values: Sequence[float]) -> bool:
    return all(math.isfinite(v) for v in values)


def validate_sample(sample: Sample, limits: ValueLimits = DEFAULT_LIMITS) -> Sample | Rejection:
    """``sample`` (with its quaternion normalised) or the reason it must be refused.

    Refuses NaN/infinity (``non_finite``) and values beyond ``limits`` (``out_of_range``).
    """
    vectors = [sample.acc, sample.gyr, sample.mag_uT, sample.q_world_from_sensor]
    scalars = [sample.device_time_s] + ([sample.battery_pct] if sample.battery_pct is not None else [])
    for values in vectors:
        if values is not None and not _finite(values):
            return Rejection.NON_FINITE
    if not _finite(scalars):
        return Rejection.NON_FINITE
    if not 0.0 <= sample.device_time_s <= limits.device_time_max_s:
        return Rejection.OUT_OF_RANGE
    for values, bound in ((sample.acc, limits.acc_max), (sample.gyr, limits.gyr_max),
                          (sample.mag_uT, limits.mag_max_uT)):
        if values is not None and max(abs(v) for v in values) > bound:
            return Rejection.OUT_OF_RANGE
    if sample.battery_pct is not None and not 0.0 <= sample.battery_pct <= 100.0:
        return Rejection.OUT_OF_RANGE
    if sample.calibration is not None and any(not 0 <= c <= 3 for c in sample.calibration):
        return Rejection.OUT_OF_RANGE
    if sample.q_world_from_sensor is not None:
        norm = math.sqrt(sum(v * v for v in sample.q_world_from_sensor))
        if abs(norm - 1.0) > limits.quat_norm_tolerance:
            return Rejection.OUT_OF_RANGE
        q = tuple(v / norm for v in sample.q_world_from_sensor)
        sample = Sample(sample.sensor_id, sample.seq, sample.device_time_s, sample.acc,
                        sample.gyr, sample.mag_uT, q, sample.calibration, sample.battery_pct)
    return sample


@dataclass(frozen=True, eq=False)
class SampleBlock:
    """Consecutive samples of one sensor, columnar (``N`` samples, time-ordered).

    ``sensor_id`` is the session-wide sensor name (a string). Channel arrays are ``None``
    when the sensor does not send that channel; shapes: ``acc``/``gyr``/``mag_uT`` ``(N, 3)``,
    ``q_world_from_sensor`` ``(N, 4)``, ``calibration`` ``(N, 4)`` int8, ``battery_pct`` ``(N,)``.
    ``seq`` is the unwrapped sequence number (int64, gaps are drops).
    """

    source: str
    sensor_id: str
    seq: np.ndarray
    device_time_s: np.ndarray
    host_time_s: np.ndarray
    receive_time_s: np.ndarray
    acc: np.ndarray | None = None
    gyr: np.ndarray | None = None
    mag_uT: np.ndarray | None = None
    q_world_from_sensor: np.ndarray | None = None
    calibration: np.ndarray | None = None
    battery_pct: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.seq.shape[0])

    def channels(self) -> tuple[str, ...]:
        """Names of the channels present, in wire order."""
        return tuple(name for name in CHANNELS if getattr(self, name) is not None)


_CHANNEL_DTYPES = {
    "acc": np.float64, "gyr": np.float64, "mag_uT": np.float64,
    "q_world_from_sensor": np.float64, "calibration": np.int8, "battery_pct": np.float64,
}


@dataclass
class _Pending:
    channels: tuple[str, ...]
    seq: list[int] = field(default_factory=list)
    device_time_s: list[float] = field(default_factory=list)
    host_time_s: list[float] = field(default_factory=list)
    receive_time_s: list[float] = field(default_factory=list)
    values: dict[str, list] = field(default_factory=dict)


class BlockBuilder:
    """Collects accepted samples per sensor and turns them into :class:`SampleBlock` s.

    A sensor whose channel set changes starts a new block, so every block is rectangular.
    """

    def __init__(self, source: str) -> None:
        self.source = source
        self._pending: dict[str, list[_Pending]] = {}
        self._count = 0
        self.oldest_receive_time_s: float | None = None

    def __len__(self) -> int:
        return self._count

    def add(self, sensor_name: str, seq: int, sample: Sample, host_time_s: float,
            receive_time_s: float) -> None:
        """Append one validated sample (``seq`` already unwrapped)."""
        channels = sample.channels()
        runs = self._pending.setdefault(sensor_name, [])
        if not runs or runs[-1].channels != channels:
            runs.append(_Pending(channels, values={name: [] for name in channels}))
        run = runs[-1]
        run.seq.append(seq)
        run.device_time_s.append(sample.device_time_s)
        run.host_time_s.append(host_time_s)
        run.receive_time_s.append(receive_time_s)
        for name in channels:
            run.values[name].append(getattr(sample, name))
        self._count += 1
        if self.oldest_receive_time_s is None:
            self.oldest_receive_time_s = receive_time_s

    def take(self) -> list[SampleBlock]:
        """All pending samples as blocks; the builder is empty afterwards."""
        blocks = []
        for sensor_name, runs in self._pending.items():
            for run in runs:
                arrays = {name: np.asarray(run.values[name], dtype=_CHANNEL_DTYPES[name])
                          for name in run.channels}
                blocks.append(SampleBlock(
                    source=self.source, sensor_id=sensor_name,
                    seq=np.asarray(run.seq, dtype=np.int64),
                    device_time_s=np.asarray(run.device_time_s, dtype=np.float64),
                    host_time_s=np.asarray(run.host_time_s, dtype=np.float64),
                    receive_time_s=np.asarray(run.receive_time_s, dtype=np.float64),
                    **arrays))
        self._pending.clear()
        self._count = 0
        self.oldest_receive_time_s = None
        return blocks


class SequenceUnwrapper:
    """Unwraps a per-sensor 32-bit wire sequence number into a monotonic int64.

    A number more than ``2**31`` ahead is read as a wrap-around; a number at or before the
    last one is stale (duplicate or reordered) and refused.
    """

    MODULUS = 2**32

    def __init__(self) -> None:
        self._last: int | None = None

    @property
    def last(self) -> int | None:
        """The last accepted unwrapped sequence number (``None`` before the first)."""
        return self._last

    def unwrap(self, wire_seq: int) -> int | None:
        """Unwrapped number for ``wire_seq`` or ``None`` if it is stale."""
        if self._last is None:
            self._last = int(wire_seq)
            return self._last
        delta = (int(wire_seq) - self._last) % self.MODULUS
        if delta == 0 or delta >= self.MODULUS // 2:
            return None
        self._last += delta
        return self._last
