"""One measurement of one sensor as decoded from the wire (:class:`Sample`), its validation,
and the unwrapping of its sequence number (:class:`SequenceUnwrapper`). Accepted samples are
packed into blocks by :mod:`mimucap.acquisition.packed_blocks`.

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
from dataclasses import dataclass

import numpy as np

from mimucap.acquisition.rejections import Rejection
from mimucap.core.sensor_limits import ACC_MAX_M_S2, GYR_MAX_RAD_S, MAG_MAX_UT
from mimucap.core.sensor_samples import CHANNELS

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
    :class:`~mimucap.core.sensor_samples.SensorSamples` (absent channels are left out). Returns an ``(N,)`` array of
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
