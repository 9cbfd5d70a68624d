"""The gyroscope's scale factors and axis alignment, estimated from the magnetometer-calibration
turns.

A MEMS gyroscope's scale factors are off by about a percent per axis (and its axes by a fraction
of a degree): after a turn the integrated heading is off by that fraction of the angle turned,
which the magnetometer pulls back only over many seconds. The magnetometer calibration's turns
(one full turn about each sensor axis) show the same rotation twice: the gyroscope integrates it,
and the calibrated field vector, constant in the world, turns by it in the sensor frame. In the
sensor frame the field obeys the kinematic equation

    dm/dt = m × ω,   ω = C · ω_raw − b

with ``m`` the calibrated field (µT), ``ω_raw`` the raw rate (rad/s), ``C`` (3, 3) the
gyroscope correction (scale factors on the diagonal, cross-axis terms off it; identity for a
perfect gyroscope) and ``b`` (3,) rad/s the bias in corrected units. Summed over the sample
intervals of a window (the rate sample ω_{k+1} taken as the mean rate over t_k..t_{k+1}, as the
filter takes it, and ``m`` at the interval's middle),

    m(t₁) − m(t₀) = ∫ [m]× (C · ω_raw − b) dt,

which is linear in ``C`` and ``b``; a thirteenth unknown, the rates' lag behind the field
(``−τ ∫ [m]× ω̇ dt``), absorbs a sensor's filter delay and is not applied. The windows (1 s) weigh
their intervals with a weight that rises and falls linearly over half a second: summed by parts,
the left side is the mean field over the falling ramp minus that over the rising one, so the
field's noise is averaged, not differentiated. One least-squares solve over every window of the
turns, with one pass that drops windows whose residual is far out (a knock, a
disturbed sample). Calibrating a gyroscope against the field a calibrated magnetometer measures
is standard (e.g. Papafotis, Sotiriadis, "MAG.I.C.AL. – A Unified Methodology for Magnetic and
Inertial Sensors Calibration and Alignment"); the rotation about the field direction itself is
invisible to the field, which the turns about three axes make up for.

The estimate is applied only when it is well determined (:class:`GyroScaleLimits`): every axis
turned at least most of a full turn, every element's standard error small, every scale factor
plausible. Otherwise the correction stays the identity and :attr:`GyroScaleEstimate.reason` says
why. Frames: sensor frame (the calibrated magnetometer's axes, which are the gyroscope's).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

AXES = ("x", "y", "z")
#: The unknowns: C (9), b (3) and the rates' lag behind the field (1).
UNKNOWNS = 13


@dataclass(frozen=True)
class GyroScaleLimits:
    """When an estimate is applied (defaults in brackets).

    window_s [1]: length of the integration windows, s; ramp_s [0.5]: how long a window's weight
    takes to rise and to fall, s (the field is averaged over that long at either end).
    min_turn_deg [300]: least rotation about each sensor axis in the samples (∫|ω_axis| dt),
    degrees. max_std [0.003]: largest standard error of any element of the correction (0.3 % of
    scale). max_scale_error [0.1]: largest |C_ii − 1| and |C_ij| believed (a larger one is a
    wrong unit, mismatched axes or a disturbed field, not a gyroscope's error). max_gap_s [0.25]:
    a time step longer than this ends an integration window (the turn windows of a session are
    not contiguous, nor are joined recordings). outlier_factor [4]: windows whose residual exceeds this many robust standard deviations are
    dropped before the final solve.
    """

    window_s: float = 1.0
    ramp_s: float = 0.5
    min_turn_deg: float = 300.0
    max_std: float = 0.003
    max_scale_error: float = 0.1
    max_gap_s: float = 0.25
    outlier_factor: float = 4.0


@dataclass(frozen=True)
class GyroScaleEstimate:
    """What :func:`estimate_gyro_scale` found.

    correction: ``C`` (3, 3) to apply, ``ω = C · ω_raw`` (the identity when not applied).
    applied: whether the estimate was good enough to be used. estimated: the least-squares ``C``
    (NaN when there were too few windows), std: its elements' standard errors (3, 3),
    turned_deg: (3,) rotation about each sensor axis, degrees, residual_uT: RMS window residual,
    windows: windows in the final solve. reason: why the estimate is not applied ("" when it is).
    """

    correction: FloatArray
    applied: bool
    estimated: FloatArray
    std: FloatArray
    turned_deg: FloatArray
    residual_uT: float
    windows: int
    reason: str = ""

    def as_dict(self) -> dict:
        """The quality figures stored with the calibration (JSON-ready; NaN as None)."""
        def plain(values: np.ndarray) -> list:
            return [None if not math.isfinite(v) else round(float(v), 8) for v in np.ravel(values)]
        return {
            "applied": self.applied,
            "scale_error_pct": plain(100.0 * (1.0 / np.diag(self.estimated) - 1.0)),
            "scale_std_pct": plain(100.0 * np.diag(self.std)),
            "largest_std_pct": None if not np.isfinite(self.std).all() else round(100.0 * float(self.std.max()), 6),
            "turned_deg": plain(self.turned_deg),
            "residual_uT": None if not math.isfinite(self.residual_uT) else round(self.residual_uT, 6),
            "windows": int(self.windows),
            "reason": self.reason,
        }

    def summary(self) -> str:
        """One line for a person: the scale errors applied, or why none is."""
        if self.applied:
            errors = ", ".join(f"{a} {100.0 * (1.0 / v - 1.0):+.2f} %" for a, v in zip(AXES, np.diag(self.correction)))
            return f"scale off by {errors} (±{100.0 * float(self.std.max()):.2f} %): corrected"
        return f"scale not corrected: {self.reason}"


def identity_estimate(reason: str) -> GyroScaleEstimate:
    """No estimate (no gyroscope, no turns): the identity, with ``reason``."""
    nan = np.full((3, 3), np.nan)
    return GyroScaleEstimate(np.eye(3), False, nan, nan, np.zeros(3), math.nan, 0, reason)


def rates_at(t_field_s: ArrayLike, t_gyr_s: ArrayLike, gyr_raw_rad_s: ArrayLike) -> FloatArray:
    """The raw rates (N, 3) rad/s at a magnetometer's sample times ``t_field_s`` (N,) from a
    gyroscope sampled at other times ``t_gyr_s`` (M,), ``gyr_raw_rad_s`` (M, 3): row k is the mean
    rate over ``t_field_s[k − 1]..t_field_s[k]`` (the integrated angle, interpolated), as
    :func:`estimate_gyro_scale` takes it; NaN for the first row and outside the gyroscope's span.
    Both time series increasing."""
    t_field = np.asarray(t_field_s, dtype=np.float64)
    t_gyr = np.asarray(t_gyr_s, dtype=np.float64)
    gyr = np.asarray(gyr_raw_rad_s, dtype=np.float64)
    if len(t_gyr) < 2 or len(t_field) < 2:
        return np.full((len(t_field), 3), np.nan)
    angle = np.vstack([np.zeros((1, 3)), np.cumsum(gyr[1:] * np.diff(t_gyr)[:, None], axis=0)])
    at = np.column_stack([np.interp(t_field, t_gyr, angle[:, axis], left=np.nan, right=np.nan) for axis in range(3)])
    rates = np.full((len(t_field), 3), np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        rates[1:] = np.diff(at, axis=0) / np.diff(t_field)[:, None]
    return rates


def _skew(v: FloatArray) -> FloatArray:
    """``[v]×`` (..., 3, 3), so that ``[v]× u = v × u``."""
    zero = np.zeros(v.shape[:-1])
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2)


def _window_weights(t_s: FloatArray, window_s: float, ramp_s: float, max_gap_s: float) -> FloatArray:
    """Weights (W, N − 1) of the sample intervals in each integration window, by the time of the
    interval's middle: 0 outside, rising linearly over the first ``ramp_s``, 1 in the middle,
    falling over the last ``ramp_s``. Windows of ``window_s`` follow each other every
    ``window_s − ramp_s`` and hold no step longer than ``max_gap_s`` (nor a step back in time)."""
    steps = np.diff(t_s)
    if len(steps) == 0:
        return np.zeros((0, 0))
    middle = 0.5 * (t_s[:-1] + t_s[1:])
    breaks = np.flatnonzero(~((steps > 0) & (steps <= max_gap_s)))
    rows = []
    first = 0
    for end in [*breaks.tolist(), len(steps)]:  # intervals first..end − 1 hold no gap
        if end > first:
            begin_s, stop_s = t_s[first], t_s[end]
            run = slice(first, end)
            start_s = begin_s
            while start_s + window_s <= stop_s:
                row = np.zeros(len(steps))
                into = middle[run] - start_s
                row[run] = np.clip(np.minimum(into, window_s - into) / ramp_s, 0.0, 1.0)
                rows.append(row)
                start_s += window_s - ramp_s
        first = end + 1
    return np.array(rows).reshape(len(rows), len(steps))


def estimate_gyro_scale(t_s: ArrayLike, gyr_raw_rad_s: ArrayLike, mag_cal_uT: ArrayLike,
                        limits: GyroScaleLimits = GyroScaleLimits()) -> GyroScaleEstimate:
    """The gyroscope correction of one sensor from samples of its magnetometer-calibration turns.

    ``t_s`` (N,) s, increasing; ``gyr_raw_rad_s`` (N, 3) raw rates; ``mag_cal_uT`` (N, 3) the
    field calibrated by the sensor's magnetometer calibration, at the same instants (rows with a
    non-finite value are left out). See the module docstring for the model and the checks.
    """
    t = np.asarray(t_s, dtype=np.float64)
    gyr = np.asarray(gyr_raw_rad_s, dtype=np.float64)
    mag = np.asarray(mag_cal_uT, dtype=np.float64)
    if gyr.shape != (len(t), 3) or mag.shape != (len(t), 3):
        raise ValueError(f"gyroscope ({gyr.shape}) and field ({mag.shape}) samples must be (N, 3) with N = {len(t)}")
    usable = np.isfinite(t) & np.all(np.isfinite(gyr), axis=1)
    t, gyr, mag = t[usable], gyr[usable], mag[usable]
    # The angle each raw axis has turned since the first sample (a rate sample is the mean rate
    # over the interval ending at it, as the filter takes it), read at the field's samples: a
    # magnetometer slower than the gyroscope gets the mean rate over each of its intervals.
    angle = np.vstack([np.zeros((min(len(t), 1), 3)), np.cumsum(gyr[1:] * np.diff(t)[:, None], axis=0)])
    with_field = np.all(np.isfinite(mag), axis=1)
    t, angle, mag = t[with_field], angle[with_field], mag[with_field]
    weights = _window_weights(t, limits.window_s, limits.ramp_s, limits.max_gap_s)
    if len(weights) < 6:
        return identity_estimate("too few samples of the turns with both gyroscope and magnetometer")
    # Per interval k → k+1 between field samples, with ω_k the mean raw rate over it: the field's
    # change and the integrals of [m̄]× ω_j (for each raw axis j, m̄ the field at the interval's
    # middle) and of [m̄]×, so that m_{k+1} − m_k = Σ_j step_axis_j C[:, j] − step_bias b; and of
    # [m̄]× ω̇, the change a lag of the rates behind the field would make (estimated along, not
    # applied).
    dt = np.diff(t)
    span = np.where(dt > 0, dt, np.inf)[:, None]    # a step back in time (joined files) is in no window
    rate = np.diff(angle, axis=0) / span                                # (N − 1, 3)
    skew = _skew(0.5 * (mag[:-1] + mag[1:])) * dt[:, None, None]       # (N − 1, 3, 3)
    step_axis = skew[:, None, :, :] * rate[:, :, None, None]           # (N − 1, 3 axes j, 3, 3)
    step_lag = np.einsum("kri,ki->kr", skew, np.diff(rate, axis=0, prepend=rate[:1]) / span)
    inside = weights.sum(axis=0) > 0                                    # intervals of some window
    turned_deg = np.degrees(np.sum(dt[inside, None] * np.abs(rate[inside]), axis=0))
    # Each window weighs the interval equations; summed by parts, its left side is the mean field
    # over the falling ramp minus that over the rising one, so the field's noise is averaged, not
    # differentiated.
    count = len(weights)
    axis_part = (weights @ step_axis.reshape(len(dt), 27)).reshape(count, 3, 3, 3)   # (W, j, row, i)
    # Column block j of the design multiplies C[:, j]: row r, column 3j + i = (∫[m]× ω_j)[r, i].
    design_c = np.transpose(axis_part, (0, 2, 1, 3)).reshape(count, 3, 9)
    design_b = -(weights @ skew.reshape(len(dt), 9)).reshape(count, 3, 3)
    design_lag = -(weights @ step_lag)[:, :, None]
    design = np.concatenate([design_c, design_b, design_lag], axis=2)  # (W, 3, 13)
    target = weights @ np.diff(mag, axis=0)                             # (W, 3)
    keep = np.ones(count, dtype=bool)
    for _round in range(2):
        solution, *_ = np.linalg.lstsq(design[keep].reshape(-1, UNKNOWNS), target[keep].reshape(-1), rcond=None)
        residual = np.linalg.norm(target - design @ solution, axis=1)
        spread = 1.4826 * float(np.median(residual[keep])) + 1e-12
        keep = residual <= limits.outlier_factor * spread
        if keep.sum() < 6:
            return identity_estimate("the field and the gyroscope disagree on most of the turns")
    a = design[keep].reshape(-1, UNKNOWNS)
    y = target[keep].reshape(-1)
    solution, *_ = np.linalg.lstsq(a, y, rcond=None)
    rms = float(np.sqrt(np.sum(np.square(y - a @ solution)) / max(a.shape[0] - UNKNOWNS, 1)))
    try:
        covariance = rms ** 2 * np.linalg.inv(a.T @ a)
        std = np.sqrt(np.clip(np.diag(covariance)[:9], 0.0, None)).reshape(3, 3, order="F")
    except np.linalg.LinAlgError:
        std = np.full((3, 3), np.inf)
    estimated = solution[:9].reshape(3, 3, order="F")
    reason = _refusal(estimated, std, turned_deg, limits)
    correction = estimated if not reason else np.eye(3)
    return GyroScaleEstimate(correction, not reason, estimated, std, turned_deg, rms, int(keep.sum()), reason)


def _refusal(estimated: FloatArray, std: FloatArray, turned_deg: FloatArray, limits: GyroScaleLimits) -> str:
    """Why ``estimated`` is not to be applied, "" when it may be."""
    short = [f"{a} {v:.0f}°" for a, v in zip(AXES, turned_deg) if v < limits.min_turn_deg]
    if short:
        return (f"too little rotation about {', '.join(short)} (at least {limits.min_turn_deg:.0f}° about each "
                "axis is needed)")
    reversed_axes = [a for a, v in zip(AXES, np.diag(estimated)) if v < 0]
    if reversed_axes and np.all(np.isfinite(std)) and float(std.max()) < 0.1:
        return (f"the gyroscope's {', '.join(reversed_axes)} axis turns opposite to the magnetometer's: the two "
                "sensors' axes do not match (check the axis remapping)")
    deviation = np.abs(estimated - np.eye(3))
    if not np.all(np.isfinite(deviation)) or float(deviation.max()) > limits.max_scale_error:
        return (f"implausible (an element off by {100.0 * float(np.nanmax(deviation)):.1f} %, more than a gyroscope's "
                f"{100.0 * limits.max_scale_error:.0f} %): the field was disturbed or the axes do not match")
    if not np.all(np.isfinite(std)) or float(std.max()) > limits.max_std:
        return (f"poorly determined (standard error up to {100.0 * float(np.nanmax(std)):.2f} %, at most "
                f"{100.0 * limits.max_std:.2f} % is used)")
    return ""
