"""Why an orientation may be wrong: per sensor and sample, and for the joint angles built on it
(no I/O, no Qt).

A sensor's attitude error is bounded by the sum of three terms (radians), each from what the
orientation filter (the error-state Kalman filter of Zhang, Gao, Zhou, "Head attitude sensing
algorithm based on IMU in VR device") knows, never from how wrong a result turned out to be:

1. **the filter's own uncertainty**: :attr:`DoubtSettings.sigmas` standard deviations of its
   attitude covariance (the largest of tilt and heading). While the gyroscope integrates
   alone it grows with the gyro noise, the uncertainty of the gyro bias and the bias random
   walk of the filter's settings, so this term says when a magnetometer has been rejected (or
   absent) for longer than the gyroscope can bridge (:func:`bridge_time_s` gives that time
   from the filter's steady state); it is also large before the filter has settled (its
   start, a new magnetometer calibration, a long gap);
2. **a heading taken from a foreign field**: the filter accepts a magnetometer sample whose
   field lies within its tolerances of what it has learned, which may no longer be the field
   the magnetometer was calibrated in (the filter adopts a new steady field after a while).
   Such a sample turns the heading by the filter's gain ``K = P_ψ / (P_ψ + σ_h²)`` times the
   heading residual ``r`` it sees, so the heading error ``ε`` becomes exactly ``ε + K·r``:
   the term grows by ``K·|r|``, and decays by ``1 − K`` with every accepted sample of the
   calibrated field. A field is foreign when the smallest disturbance that explains its
   magnitude and dip (:func:`field_deviation`) exceeds :attr:`DoubtSettings.field_tolerance`
   of the calibrated field. A field turned only about the vertical keeps its magnitude and
   dip: no magnetometer check can see it;
3. **rotation lost with dropped samples** (sequence-number gaps, or intervals longer than the
   filter's ``max_gap_s``): across a gap the filter integrates the rates at its two ends, which
   is wrong by at most half the change of the rate times the gap (a rate that jumps at one
   end); beyond ``max_gap_s`` it integrates nothing and its own gap figure
   (``gap_attitude_rate_rad_s`` times the gap) applies. The error decays like term 2.

A sample is doubtful when the sum exceeds :attr:`DoubtSettings.attitude_budget_rad`; the
reasons named are the terms without which the sum would be within the budget (when no one
term is, every term that takes at least a third of it), and the standing ones (no
orientation yet, magnetometer not calibrated, on-board calibration incomplete). A device
that fuses on board (BNO055) reports its own calibration status ``(system, gyr, acc, mag)``,
0..3: 0 means not calibrated (for the system: magnetic north not found yet), and its
orientation is doubtful while the system, gyroscope or magnetometer status is 0.

The **reprocessed** result is smoothed with future data (Rauch-Tung-Striebel): an error
injected later reaches back in time. A heading that follows a foreign field drifts with it,
and the smoother explains a drift as gyro bias, which it carries back over the bias's
correlation time (:func:`smoother_memory_s`, the slow time constant of the filter's
heading-and-bias loop); a step lost with samples reaches back as it decays forward.

Joint angles inherit the reasons of the sensors of their two segments, at the pose instants
(:func:`at_instants`), plus those of the body calibration (none, a poor verdict, or made from
doubtful orientations); a recording's magnetometer turns take the sensors off the body
(:func:`off_body`), and near its Euler sequence's singularity a joint's first and third
angles amplify any error (:func:`singular`).

Reasons are bits of a ``uint16`` (:data:`REASONS` names them for people and for files).
Times are seconds, angles radians, fields µT, quaternions ``[w, x, y, z]`` world ENU.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from itertools import accumulate

import numpy as np

from mimucap.core import rotation
from mimucap.core.fusion.params import FusionParams
from mimucap.core.fusion.state import (
    FLAG_ACC_REJECTED, FLAG_MAG_MISSING, FLAG_MAG_REJECTED, FLAG_SKIPPED, FLAG_UNINITIALISED,
)
from mimucap.core.magcal import MagCalibration

DOUBT_DTYPE = np.uint16

# Reasons of one sensor's orientation
NO_ORIENTATION = 1 << 0
SETTLING = 1 << 1
MAG_REJECTED = 1 << 2
MAG_MISSING = 1 << 3
NO_MAGNETOMETER = 1 << 4
FIELD_MISMATCH = 1 << 5
LOST_SAMPLES = 1 << 6
MAG_UNCALIBRATED = 1 << 7
ONBOARD_UNCALIBRATED = 1 << 8
ACC_REJECTED = 1 << 9
# Reasons of a joint angle beyond its sensors'
NO_BODY_CALIBRATION = 1 << 10
BODY_CALIBRATION_POOR = 1 << 11
OFF_BODY = 1 << 12
BODY_CALIBRATION_DOUBTFUL = 1 << 13
SINGULAR = 1 << 14

#: Reason bit → (short name for files, words for people), in the order people read them: what
#: to act on first.
REASONS: dict[int, tuple[str, str]] = {
    MAG_UNCALIBRATED: ("mag_uncalibrated", "magnetometer not calibrated"),
    ONBOARD_UNCALIBRATED: ("onboard_uncalibrated", "the sensor's own calibration is incomplete"),
    NO_BODY_CALIBRATION: ("no_body_calibration", "no body calibration"),
    BODY_CALIBRATION_POOR: ("body_calibration_poor", "the body calibration's verdict is poor"),
    BODY_CALIBRATION_DOUBTFUL: ("body_calibration_doubtful",
                                "the body calibration was made from doubtful orientations"),
    OFF_BODY: ("off_body", "sensors off the body (magnetometer calibration)"),
    FIELD_MISMATCH: ("field_mismatch", "heading taken from a magnetic field that differs from the calibrated one"),
    MAG_REJECTED: ("mag_rejected", "magnetometer rejected as disturbed for longer than the gyroscope can bridge"),
    MAG_MISSING: ("mag_missing", "magnetometer samples missing for longer than the gyroscope can bridge"),
    NO_MAGNETOMETER: ("no_magnetometer", "no magnetometer: heading from the gyroscope alone"),
    LOST_SAMPLES: ("lost_samples", "samples lost"),
    ACC_REJECTED: ("acc_rejected", "accelerometer rejected (strong accelerations)"),
    NO_ORIENTATION: ("no_orientation", "no orientation yet"),
    SETTLING: ("settling", "orientation still settling"),
    SINGULAR: ("singular", "near the angle sequence's singularity (gimbal lock)"),
}


def _cause_table(has_mag: bool) -> np.ndarray:
    """Filter flags (uint8) → the reason of a large attitude uncertainty at that sample: what
    the filter lacks there (a table: one lookup per block instead of a test per reason)."""
    table = np.full(256, SETTLING, dtype=DOUBT_DTYPE)
    for value in range(256):
        if value & FLAG_ACC_REJECTED:
            table[value] = ACC_REJECTED
        if not has_mag:
            table[value] = NO_MAGNETOMETER
        elif value & FLAG_MAG_REJECTED:
            table[value] = MAG_REJECTED
        elif value & FLAG_MAG_MISSING:
            table[value] = MAG_MISSING
    return table


#: Status 0 of these on-board calibration columns (system, gyr, acc, mag) makes a device's
#: orientation doubtful: the system has not found north, or the gyroscope or magnetometer is
#: not calibrated. The accelerometer's takes long to reach and the fusion does not wait for it.
_ONBOARD_COLUMNS = (0, 1, 3)


@dataclass(frozen=True)
class DoubtSettings:
    """When an orientation counts as doubtful.

    ``attitude_budget_rad``: the largest attitude error (rad) a trustworthy sample may carry.
    A heading error of a segment is a rotation about its long axis while it hangs, and enters
    the joint's axial rotation one to one; 5° keeps that column within a few degrees.
    ``sigmas``: standard deviations of the filter's covariance counted as its error.
    ``field_tolerance``: the smallest disturbance that explains a field's magnitude and dip,
    as a fraction of the calibrated field, beyond which the field counts as foreign: 0.1 is
    5.7° of dip or 10 % of magnitude, above what a calibrated field shows while walking (the
    dip follows the filter's tilt error, a few degrees; the magnitude the calibration's
    residual, about 1 %).
    """

    attitude_budget_rad: float = math.radians(5.0)
    sigmas: float = 3.0
    field_tolerance: float = 0.1

    def __post_init__(self) -> None:
        for name in ("attitude_budget_rad", "sigmas", "field_tolerance"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"doubt setting {name} must be a positive number, got {value!r}")


DEFAULT_DOUBT_SETTINGS = DoubtSettings()


def reason_names(reasons: int) -> list[str]:
    """The short names (:data:`REASONS`) of the bits set in ``reasons``."""
    return [name for bit, (name, _words) in REASONS.items() if reasons & bit]


def describe(reasons: int) -> str:
    """The reasons set in ``reasons`` in words, joined by "; " ("" when there are none)."""
    return "; ".join(words for bit, (_name, words) in REASONS.items() if reasons & bit)


def field_deviation(mag_world_uT: np.ndarray, field_uT, horizontal_uT, downward_uT) -> np.ndarray:
    """The smallest disturbance that turns the calibrated field into the measured one
    ``mag_world_uT`` (N, 3) (world frame, µT), as a fraction of the calibrated magnitude
    ``field_uT``: ``|B' − B| / |B|`` with both in the same vertical plane, that is
    ``√(|B'|² + |B|² − 2 (h' h + v' v))`` with ``h``, ``v`` the horizontal and downward
    components (``horizontal_uT``, ``downward_uT``; NaN when the calibration measured no dip:
    the magnitudes alone are compared). Scalars or (N,) arrays; returns (N,).
    """
    mag_world = np.asarray(mag_world_uT, dtype=np.float64)
    squared = np.einsum("ij,ij->i", mag_world, mag_world)
    cross = np.hypot(mag_world[:, 0], mag_world[:, 1]) * horizontal_uT - mag_world[:, 2] * downward_uT
    with np.errstate(invalid="ignore"):
        vector = np.sqrt(np.clip(squared + np.square(field_uT) - 2.0 * cross, 0.0, None))
    return np.where(np.isfinite(horizontal_uT), vector, np.abs(np.sqrt(squared) - field_uT)) / field_uT


def calibrated_dip_rad(calibration: MagCalibration) -> float | None:
    """The dip (rad) a magnetometer calibration measured, or None when it had no accelerometer."""
    dip_deg = (calibration.quality or {}).get("dip_mean_deg")
    if dip_deg is None or not np.isfinite(dip_deg):
        return None
    return math.radians(float(dip_deg))


# --------------------------------------------------------------------------------------------
# The filter's heading channel in its steady state
# --------------------------------------------------------------------------------------------

@functools.lru_cache(maxsize=32)
def _heading_loop(fusion: FusionParams, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Steady state of the filter's heading and the gyro bias about the vertical: the prior
    covariance ``P`` (2, 2) (rad², rad²/s, rad²/s²) of ``[heading, bias]`` and the closed-loop
    transition (2, 2) with one heading measurement (noise ``heading_noise_rad``) per sample
    of ``dt_s``; the filter's process noise is the gyro noise density and bias random walk.

    ``P`` solves the filter's discrete algebraic Riccati equation, by the structure-preserving
    doubling algorithm (Chu, Fan, Lin, Wang, "Structure-preserving algorithms for periodic
    discrete-time algebraic Riccati equations", 2004): quadratic convergence, a few dozen 2 × 2
    steps. ``ValueError`` when it does not converge (e.g. no bias random walk: the bias is then
    known ever better, and the steady state is a limit never reached)."""
    transition = np.array([[1.0, -dt_s], [0.0, 1.0]])
    measured = np.array([[1.0, 0.0]])
    variance = fusion.heading_noise_rad ** 2
    a = transition.T
    g = measured.T @ measured / variance
    h = np.diag([fusion.gyr_noise_rad_s_sqrt_hz ** 2 * dt_s, fusion.bias_walk_rad_s_sqrt_s ** 2 * dt_s])
    identity = np.eye(2)
    for _ in range(200):
        inverse = np.linalg.inv(identity + g @ h)
        a, g, h_next = a @ inverse @ a, g + a @ inverse @ g @ a.T, h + a.T @ h @ inverse @ a
        converged = np.allclose(h_next, h, rtol=1e-12, atol=0.0)
        h = h_next
        if converged:
            break
    else:
        raise ValueError("the heading filter's Riccati equation does not converge")
    prior = 0.5 * (h + h.T)
    gain = prior @ measured.T / (prior[0, 0] + variance)
    return prior, (identity - gain @ measured) @ transition


def bridge_time_s(fusion: FusionParams, dt_s: float,
                  settings: DoubtSettings = DEFAULT_DOUBT_SETTINGS) -> float:
    """How long (s) the gyroscope alone keeps a settled filter's heading within the budget
    (``sigmas`` standard deviations): from the steady state of :func:`_heading_loop` the
    heading variance grows by ``σ_g² T + σ_b² T² + q_b T³ / 3`` (gyro noise, bias uncertainty,
    bias random walk). ``inf`` when it never leaves the budget."""
    try:
        prior, _loop = _heading_loop(fusion, dt_s)
    except (ValueError, np.linalg.LinAlgError):
        return math.inf
    q_gyr, q_bias = fusion.gyr_noise_rad_s_sqrt_hz ** 2, fusion.bias_walk_rad_s_sqrt_s ** 2
    limit = (settings.attitude_budget_rad / settings.sigmas) ** 2

    def variance(time_s: float) -> float:
        return (prior[0, 0] - 2.0 * prior[0, 1] * time_s + prior[1, 1] * time_s ** 2
                + q_gyr * time_s + q_bias * time_s ** 3 / 3.0)

    if variance(0.0) >= limit:
        return 0.0
    high = 1.0
    while variance(high) < limit:
        high *= 2.0
        if high > 1e7:
            return math.inf
    low = 0.0
    for _ in range(60):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if variance(middle) < limit else (low, middle)
    return low


def bridge_note(fusion: FusionParams, dt_s: float, settings: DoubtSettings = DEFAULT_DOUBT_SETTINGS) -> str:
    """How long the gyroscope bridges a lost magnetometer (:func:`bridge_time_s`), in words."""
    bridge = bridge_time_s(fusion, dt_s, settings)
    limit = f"{math.degrees(settings.attitude_budget_rad):.0f}°"
    if not math.isfinite(bridge):
        return f"the gyroscope alone keeps a settled heading within {limit} indefinitely (no gyro bias random walk)"
    return (f"the gyroscope alone keeps a settled heading within {limit} for about {bridge:.0f} s "
            f"(the filter's settings at {1.0 / dt_s:.0f} Hz)")


def smoother_memory_s(fusion: FusionParams, dt_s: float) -> float:
    """The time constant (s) over which the smoother carries a heading drift back as gyro
    bias: the slow mode of the steady-state heading-and-bias loop (:func:`_heading_loop`);
    ``inf`` when the bias does not forget (no bias random walk)."""
    try:
        _prior, loop = _heading_loop(fusion, dt_s)
    except (ValueError, np.linalg.LinAlgError):
        return math.inf
    slowest = float(np.max(np.abs(np.linalg.eigvals(loop))))
    return math.inf if slowest >= 1.0 else -dt_s / math.log(slowest)


# --------------------------------------------------------------------------------------------
# One sensor
# --------------------------------------------------------------------------------------------

@dataclass
class DoubtTerms:
    """The error terms of a sensor's samples (N,) each (radians unless said):

    ``attitude``: the filter's ``sigmas`` standard deviations (inf without an orientation);
    ``field``: the heading a foreign field may have turned; ``lost``: rotation lost with
    dropped samples; ``field_pull`` and ``lost_pull``: what each sample adds to those two;
    ``gain``: the filter's heading gain at samples whose magnetometer it accepted (else 0);
    ``foreign``: those samples whose field is foreign (bool);
    ``standing``: reason bits that hold whatever the terms (no orientation, magnetometer not
    calibrated, on-board calibration incomplete); ``cause``: the reason bit of a large
    ``attitude`` term at each sample (what the filter lacks there).
    """

    t_s: np.ndarray
    attitude: np.ndarray
    field: np.ndarray
    lost: np.ndarray
    field_pull: np.ndarray
    lost_pull: np.ndarray
    gain: np.ndarray
    foreign: np.ndarray
    standing: np.ndarray
    cause: np.ndarray

    @classmethod
    def joined(cls, parts: Sequence["DoubtTerms"]) -> "DoubtTerms":
        """The terms of consecutive blocks as one."""
        names = ("t_s", "attitude", "field", "lost", "field_pull", "lost_pull", "gain", "foreign", "standing", "cause")
        if not parts:
            empty = {name: np.zeros(0) for name in names}
            empty["standing"] = empty["cause"] = np.zeros(0, dtype=DOUBT_DTYPE)
            empty["foreign"] = np.zeros(0, dtype=bool)
            return cls(**empty)
        return cls(**{name: np.concatenate([getattr(part, name) for part in parts]) for name in names})

    def reasons(self, settings: DoubtSettings = DEFAULT_DOUBT_SETTINGS) -> np.ndarray:
        """Reason bits (N,) ``uint16``: the standing ones and, where the terms' sum exceeds the
        budget, each term without which it would not (where no one term decides, every term
        that takes at least a third of the budget: one always does)."""
        budget = settings.attitude_budget_rad
        total = self.attitude + self.field + self.lost
        doubtful = total > budget
        if not doubtful.any():  # the usual case, cheaply (a live block is a few samples)
            return self.standing.astype(DOUBT_DTYPE, copy=True)
        terms = ((self.field, FIELD_MISMATCH), (self.lost, LOST_SAMPLES), (self.attitude, self.cause))
        with np.errstate(invalid="ignore"):
            deciding = [doubtful & ((total - value <= budget) | ~np.isfinite(value)) for value, _bit in terms]
            undecided = doubtful & ~np.logical_or.reduce(deciding)
            out = self.standing.astype(DOUBT_DTYPE, copy=True)
            for (value, bit), decides in zip(terms, deciding):
                named = decides | (undecided & (value >= budget / 3.0))
                out |= np.where(named, bit, 0).astype(DOUBT_DTYPE)
        return out

    def smoothed(self, memory_s: float) -> "DoubtTerms":
        """The terms of the reprocessed result (see the module docstring): the field term also
        reaches back from later pulls, decaying with ``memory_s``; the lost term reaches back
        as it decays forward."""
        field_back = _backward(self.field_pull, _decay(self.t_s, memory_s))
        lost_back = _backward(self.lost_pull, 1.0 - self.gain)
        return DoubtTerms(self.t_s, self.attitude, np.maximum(self.field, field_back),
                          np.maximum(self.lost, lost_back), self.field_pull, self.lost_pull, self.gain,
                          self.foreign, self.standing, self.cause)


def _wrapped(angle_rad: np.ndarray) -> np.ndarray:
    """Angles (rad) wrapped into [−π, π)."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


def _recursion(factor: np.ndarray, added: np.ndarray, start: float) -> np.ndarray:
    """``e_k = factor_k · e_{k−1} + added_k`` from ``e_{−1} = start`` (N,)."""
    if start == 0.0 and not np.any(added):
        return np.zeros(len(added))
    steps = accumulate(zip(factor.tolist(), added.tolist()), lambda e, fa: fa[0] * e + fa[1], initial=start)
    return np.fromiter(steps, dtype=np.float64, count=len(added) + 1)[1:]


def _backward(added: np.ndarray, factor: np.ndarray) -> np.ndarray:
    """The recursion of :func:`_recursion` run from the end: ``e_k = factor_{k+1} · e_{k+1} +
    added_k``."""
    if not np.any(added):
        return np.zeros(len(added))
    shifted = np.append(factor[1:], 0.0)
    return _recursion(shifted[::-1], added[::-1], 0.0)[::-1]


def _decay(t_s: np.ndarray, memory_s: float) -> np.ndarray:
    """``exp(−Δt / memory_s)`` per sample (the first: 1)."""
    if not math.isfinite(memory_s):
        return np.ones(len(t_s))
    step = np.diff(np.asarray(t_s, dtype=np.float64), prepend=t_s[0] if len(t_s) else 0.0)
    return np.exp(-np.clip(step, 0.0, None) / memory_s)


class SensorDoubt:
    """The error terms of one sensor's samples, fed block by block as its filter runs (the
    same object serves the live view and a recording's batch processing).

    ``fusion``: the filter's settings; ``mag_calibration``: the sensor's magnetometer
    calibration (None: uncalibrated); ``onboard``: the device fuses on board (no filter here).
    """

    def __init__(self, fusion: FusionParams, mag_calibration: MagCalibration | None = None, *,
                 onboard: bool = False, settings: DoubtSettings = DEFAULT_DOUBT_SETTINGS) -> None:
        self.fusion = fusion
        self.settings = settings
        self.onboard = onboard
        self._field = 0.0
        self._lost = 0.0
        self._last: tuple | None = None  # time, seq, rate, orientation of the last sample used
        self.set_mag_calibration(mag_calibration)

    def set_mag_calibration(self, calibration: MagCalibration | None) -> None:
        """Use ``calibration`` from now on; the filter learns its heading anew from it, which
        its covariance shows (an earlier foreign field is forgotten)."""
        self.mag_calibration = calibration
        self._field = 0.0
        # the calibrated field: magnitude, horizontal and downward components (µT; NaN unknown)
        self._reference = (math.nan,) * 3
        if calibration is not None:
            dip = calibrated_dip_rad(calibration)
            magnitude = calibration.field_uT
            self._reference = ((magnitude, math.nan, math.nan) if dip is None else
                               (magnitude, magnitude * math.cos(dip), magnitude * math.sin(dip)))

    def update(self, t_s: np.ndarray, seq: np.ndarray | None, gyr_rad_s: np.ndarray | None,
               mag_uT: np.ndarray | None, q_world_from_sensor: np.ndarray, flags: np.ndarray,
               cov: np.ndarray | None = None, status: np.ndarray | None = None) -> DoubtTerms:
        """The terms of a block of N samples.

        ``t_s``, ``seq`` (N,); ``gyr_rad_s`` (N, 3) or None; ``mag_uT`` (N, 3) the calibrated
        field the filter was given (None without a magnetometer); ``q_world_from_sensor`` (N, 4)
        and ``flags`` (N,) the filter's outputs; ``cov`` (6, 6) the filter's covariance after
        the block (error state ``[δθ_world, δb]``; None for an on-board orientation);
        ``status`` (N, 4) an on-board calibration status (system, gyr, acc, mag), or None.
        """
        block = DoubtBlock(t_s, seq, gyr_rad_s, mag_uT, q_world_from_sensor, flags, cov, status)
        return update_together([self], [block])

    def _scalars(self, block: "DoubtBlock") -> tuple:
        """What holds for the whole block: the attitude term (rad), the heading gain, whether
        the magnetometer is used (1/0), the calibrated field (magnitude, horizontal and downward
        components, µT; NaN unknown), the field tolerance, the declination (rad) and the block's
        standing reasons."""
        has_mag = block.mag_uT is not None and not self.onboard
        if self.onboard or block.cov is None:
            attitude = gain = 0.0
        else:
            cov = block.cov
            tilt_x, tilt_y, heading = max(float(cov[0, 0]), 0.0), max(float(cov[1, 1]), 0.0), max(float(cov[2, 2]), 0.0)
            attitude = self.settings.sigmas * math.sqrt(max(tilt_x, tilt_y, heading))
            gain = heading / (heading + self.fusion.heading_noise_rad ** 2)
        reference = self._reference if has_mag else (math.nan,) * 3
        standing = MAG_UNCALIBRATED if has_mag and self.mag_calibration is None else 0
        return (attitude, gain, float(has_mag), *reference, self.settings.field_tolerance, self.fusion.declination_rad,
                float(standing))

    def _lost_pull(self, t: np.ndarray, seq: np.ndarray | None, gyr: np.ndarray | None, q: np.ndarray,
                   flags: np.ndarray) -> np.ndarray:
        """The rotation (rad) each sample's step may have lost to the samples dropped before it
        (a sequence gap, or an interval beyond the filter's ``max_gap_s``); 0 elsewhere. The
        step's two ends are the previous sample the filter used and this one."""
        pull = np.zeros(len(t))
        rows = np.flatnonzero((flags & FLAG_SKIPPED) == 0)
        if not len(rows):
            return pull
        times = t[rows]
        numbers = None if seq is None else np.asarray(seq, dtype=np.int64)[rows]
        rates = None if gyr is None else np.asarray(gyr, dtype=np.float64)[rows]
        orientations = q[rows]
        last = self._last
        self._last = (float(times[-1]), None if numbers is None else int(numbers[-1]),
                      None if rates is None else rates[-1].copy(), orientations[-1].copy())
        if last is not None:
            last_t, last_seq, last_rate, last_q = last
            times = np.concatenate([[last_t], times])
            numbers = None if numbers is None or last_seq is None else np.concatenate([[last_seq], numbers])
            rates = None if rates is None or last_rate is None else np.concatenate([last_rate[None], rates])
            orientations = np.concatenate([last_q[None], orientations])
        else:
            rows = rows[1:]
        if len(times) < 2:
            return pull
        interval = np.diff(times)
        # a filter integrates nothing across an interval beyond max_gap_s; a device fusing on
        # board has integrated it (only its dropped samples are missing here)
        beyond = np.zeros(len(interval), dtype=bool) if self.onboard else interval > self.fusion.max_gap_s
        gap = beyond | (np.diff(numbers) > 1) if numbers is not None else beyond
        if not np.any(gap):
            return pull
        if rates is not None:
            lost = 0.5 * np.linalg.norm(np.diff(rates, axis=0), axis=1) * interval
        else:  # an on-board orientation without rates: half the rotation between the two ends
            lost = 0.5 * np.nan_to_num(rotation.angle_between(orientations[:-1], orientations[1:]), nan=math.pi)
        lost = np.where(beyond, np.maximum(lost, self.fusion.gap_attitude_rate_rad_s * interval), lost)
        pull[rows] = np.where(gap, np.minimum(lost, math.pi), 0.0)
        return pull


@dataclass
class DoubtBlock:
    """One block of one sensor for :func:`update_together` (fields as the arguments of
    :meth:`SensorDoubt.update`)."""

    t_s: np.ndarray
    seq: np.ndarray | None
    gyr_rad_s: np.ndarray | None
    mag_uT: np.ndarray | None
    q_world_from_sensor: np.ndarray
    flags: np.ndarray
    cov: np.ndarray | None = None
    status: np.ndarray | None = None


#: Filter flags → the cause of a large attitude term, without and with a magnetometer (2, 256).
_CAUSE_TABLE = np.stack([_cause_table(False), _cause_table(True)])


def update_together(doubts: Sequence[SensorDoubt], blocks: Sequence[DoubtBlock]) -> DoubtTerms:
    """The terms of a block of each sensor, rows in the blocks' order: what
    :meth:`SensorDoubt.update` gives for each, with the per-sample work done once over all of
    them (a live view fuses 17 sensors 60 times a second, a few samples each). A sensor may
    have several blocks, in time order."""
    lengths = [len(block.t_s) for block in blocks]
    total = sum(lengths)
    t = np.concatenate([np.asarray(block.t_s, dtype=np.float64) for block in blocks]) if blocks else np.zeros(0)
    flags = np.concatenate([np.asarray(block.flags, dtype=np.uint8) for block in blocks]) if blocks else np.zeros(0, np.uint8)
    q = (np.concatenate([np.asarray(block.q_world_from_sensor, dtype=np.float64).reshape(-1, 4) for block in blocks])
         if blocks else np.zeros((0, 4)))
    # one row of block-wide values per sample (columns of SensorDoubt._scalars)
    per_row = np.repeat(np.array([doubt._scalars(block) for doubt, block in zip(doubts, blocks)]).reshape(-1, 9),
                        lengths, axis=0)
    oriented = np.isfinite(q).all(axis=1) & ((flags & FLAG_UNINITIALISED) == 0)
    standing = np.where(oriented, 0, NO_ORIENTATION).astype(DOUBT_DTYPE) | per_row[:, 8].astype(DOUBT_DTYPE)
    with_mag = per_row[:, 2] > 0
    cause = _CAUSE_TABLE[with_mag.astype(np.intp), flags]
    used = oriented & with_mag & ((flags & (FLAG_MAG_REJECTED | FLAG_MAG_MISSING | FLAG_SKIPPED)) == 0)
    gain = np.where(used, per_row[:, 1], 0.0)
    foreign = np.zeros(total, dtype=bool)
    field_pull = np.zeros(total)
    checked = used & np.isfinite(per_row[:, 3])
    if checked.any():
        mag = np.concatenate([np.full((n, 3), np.nan) if block.mag_uT is None else np.asarray(block.mag_uT, dtype=np.float64)
                              for n, block in zip(lengths, blocks)])
        field_world = rotation.rotate(q[checked], mag[checked])
        values = per_row[checked]
        deviation = field_deviation(field_world, values[:, 3], values[:, 4], values[:, 5])
        foreign[checked] = deviation > values[:, 6]
        residual = np.abs(_wrapped(np.arctan2(field_world[:, 0], field_world[:, 1]) - values[:, 7]))
        field_pull[checked] = np.where(foreign[checked], gain[checked] * residual, 0.0)
    attitude = np.where(oriented, per_row[:, 0], np.inf)
    gapped = _gapped_blocks(doubts, blocks, lengths, t, flags)
    pulled = np.bincount(np.repeat(np.arange(len(blocks)), lengths), weights=field_pull, minlength=len(blocks)) > 0
    field = np.zeros(total)
    lost = np.zeros(total)
    lost_pull = np.zeros(total)
    start = 0
    for index, (doubt, block, n) in enumerate(zip(doubts, blocks, lengths)):
        rows = slice(start, start + n)
        start += n
        if not n:
            continue
        if doubt.onboard and block.status is not None:
            unknown = (np.asarray(block.status)[:, _ONBOARD_COLUMNS] == 0).any(axis=1)
            standing[rows] |= np.where(unknown, ONBOARD_UNCALIBRATED, 0).astype(DOUBT_DTYPE)
        if gapped[index]:
            lost_pull[rows] = doubt._lost_pull(t[rows], block.seq, block.gyr_rad_s, q[rows], flags[rows])
        else:  # the usual case: the block continues the last without a dropped or skipped sample
            doubt._last = (float(t[start - 1]), None if block.seq is None else int(block.seq[-1]),
                           None if block.gyr_rad_s is None else block.gyr_rad_s[-1], q[start - 1])
        if doubt._field or pulled[index]:
            field[rows] = _recursion(1.0 - np.where(foreign[rows], 0.0, gain[rows]), field_pull[rows], doubt._field)
            doubt._field = float(field[start - 1])
        if doubt._lost or gapped[index]:
            decay = np.zeros(n) if doubt.onboard else 1.0 - gain[rows]
            lost[rows] = _recursion(decay, lost_pull[rows], doubt._lost)
            doubt._lost = float(lost[start - 1])
    return DoubtTerms(t, attitude, field, lost, field_pull, lost_pull, gain, foreign, standing, cause)


def _gapped_blocks(doubts: Sequence[SensorDoubt], blocks: Sequence[DoubtBlock], lengths: Sequence[int],
                   t: np.ndarray, flags: np.ndarray) -> np.ndarray:
    """Per block, whether it may hold a step across dropped samples (a sequence gap, an interval
    beyond the filter's ``max_gap_s`` from the sample before, a skipped sample, no sequence
    numbers or no sample before): those go through :meth:`SensorDoubt._lost_pull`."""
    count = len(blocks)
    if not count:
        return np.zeros(0, dtype=bool)
    first = np.cumsum([0] + list(lengths[:-1]))
    before_t = np.empty(len(t))
    before_t[1:] = t[:-1]
    before_seq = np.zeros(len(t), dtype=np.int64)
    seq = np.concatenate([np.full(n, -2, np.int64) if block.seq is None else np.asarray(block.seq, dtype=np.int64)
                          for n, block in zip(lengths, blocks)])
    before_seq[1:] = seq[:-1]
    unknown = np.zeros(count, dtype=bool)
    limit = np.repeat([math.inf if doubt.onboard else doubt.fusion.max_gap_s for doubt in doubts], lengths)
    for index, (doubt, block, n) in enumerate(zip(doubts, blocks, lengths)):
        if not n:
            continue
        last = doubt._last
        if last is None or last[1] is None or block.seq is None:
            unknown[index] = True
        else:
            before_t[first[index]], before_seq[first[index]] = last[0], last[1]
    odd = (seq - before_seq != 1) | (t - before_t > limit) | ((flags & FLAG_SKIPPED) != 0)
    rows_of = np.repeat(np.arange(count), lengths)
    return unknown | (np.bincount(rows_of, weights=odd, minlength=count) > 0)


# --------------------------------------------------------------------------------------------
# Pose instants and joints
# --------------------------------------------------------------------------------------------

def at_instants(t_query: np.ndarray, t_s: np.ndarray, reasons: np.ndarray, hold_s: float) -> np.ndarray:
    """A sensor's reasons at the instants ``t_query`` (M,) from its samples ``(t_s (N,),
    reasons (N,))``: those of the sample at or before each instant and of the one after (an
    orientation between two samples is interpolated from both); before the first sample
    :data:`NO_ORIENTATION`; more than ``hold_s`` after the last (an orientation held, not
    measured) :data:`LOST_SAMPLES`. (M,) ``uint16``."""
    t_query = np.asarray(t_query, dtype=np.float64)
    out = np.zeros(t_query.shape, dtype=DOUBT_DTYPE)
    if not len(t_s):
        out[:] = NO_ORIENTATION
        return out
    reasons = np.asarray(reasons, dtype=DOUBT_DTYPE)
    before = np.searchsorted(t_s, t_query, side="right") - 1
    after = np.searchsorted(t_s, t_query, side="left")
    known = before >= 0
    out[known] = reasons[before[known]]
    inside = after < len(t_s)
    out[inside] |= reasons[after[inside]]
    out[~known] |= NO_ORIENTATION
    out[t_query > t_s[-1] + hold_s] |= LOST_SAMPLES
    return out


def joint_reasons(joints: Iterable, sensor_of_segment: Mapping[str, str],
                  sensor_reasons: Mapping[str, np.ndarray], shared: np.ndarray) -> dict[str, np.ndarray]:
    """Joint name → its reasons (T,) at the pose instants: those of the sensors of its two
    segments (``sensor_reasons`` sensor → (T,)) and ``shared`` (T,) (the body calibration's and
    the recording's). Joints whose segments do not both carry a sensor are left out."""
    out = {}
    for joint in joints:
        sensors = [sensor_of_segment.get(joint.proximal), sensor_of_segment.get(joint.distal)]
        if any(sensor is None or sensor not in sensor_reasons for sensor in sensors):
            continue
        out[joint.name] = np.asarray(shared, dtype=DOUBT_DTYPE) | sensor_reasons[sensors[0]] | sensor_reasons[sensors[1]]
    return out


def spans(t_s: np.ndarray, reasons: np.ndarray, join_s: float = 1.0) -> list[tuple[float, float, int]]:
    """The spans ``(start_s, end_s, reasons)`` where ``reasons`` (N,) are set, on the time axis
    ``t_s`` (N,) s; spans closer than ``join_s`` (s) are joined, their reasons combined."""
    reasons = np.asarray(reasons)
    doubtful = reasons != 0
    if not np.any(doubtful):
        return []
    edges = np.flatnonzero(np.diff(np.concatenate([[0], doubtful.astype(np.int8), [0]])))
    found: list[tuple[float, float, int]] = []
    for begin, end in zip(edges[::2], edges[1::2]):
        bits = int(np.bitwise_or.reduce(reasons[begin:end]))
        start, stop = float(t_s[begin]), float(t_s[end - 1])
        if found and start - found[-1][1] < join_s:
            found[-1] = (found[-1][0], stop, found[-1][2] | bits)
        else:
            found.append((start, stop, bits))
    return found


def off_body(t_s: np.ndarray, windows: Iterable[tuple[float, float]], gyr_rad_s: np.ndarray | None,
             still_rate_rad_s: float, still_time_s: float) -> np.ndarray:
    """:data:`OFF_BODY` (N,) ``uint16`` at a sensor's samples ``t_s`` (N,) inside any of
    ``windows`` (start, end) s, in which the sensors are turned in the hand, and after each
    until the sensor has turned slower than ``still_rate_rad_s`` for ``still_time_s`` (its
    rates ``gyr_rad_s`` (N, 3); None: until the window's end): a sensor is strapped back on
    after the turns, and where it sits is known once the subject stands still."""
    t_s = np.asarray(t_s, dtype=np.float64)
    out = np.zeros(t_s.shape, dtype=DOUBT_DTYPE)
    still_since = None
    if gyr_rad_s is not None:
        moving = ~(np.linalg.norm(np.asarray(gyr_rad_s, dtype=np.float64), axis=1) < still_rate_rad_s)
        still_since = t_s - np.maximum.accumulate(np.where(moving, t_s, -np.inf))
    for start, end in windows:
        stop = end
        if still_since is not None:
            settled = np.flatnonzero((t_s >= end) & (still_since >= still_time_s))
            stop = float(t_s[settled[0]]) if len(settled) else math.inf
        out[(t_s >= start) & (t_s < stop)] = OFF_BODY
    return out


def singular(middle_deg: np.ndarray, proper: bool) -> np.ndarray:
    """:data:`SINGULAR` (T,) ``uint16`` where a joint's middle Euler angle ``middle_deg`` (T,)
    is within 30° of its sequence's singularity (±90° for Tait-Bryan sequences such as Z-X'-Y'',
    0° and 180° for a ``proper`` one such as Y-X'-Y''): there the first and third angles change
    at least twice as fast as the rotation itself (``1 / cos`` or ``1 / sin`` of the middle
    angle), so a degree of attitude error becomes several in them (gimbal lock)."""
    middle = np.radians(np.asarray(middle_deg, dtype=np.float64))
    conditioning = np.abs(np.sin(middle)) if proper else np.abs(np.cos(middle))
    return np.where(conditioning < 0.5, SINGULAR, 0).astype(DOUBT_DTYPE)
