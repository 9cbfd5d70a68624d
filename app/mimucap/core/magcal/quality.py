"""Quality figures and a good / warn / fail verdict for a magnetometer calibration.

Every figure is computed from the samples of the final fit (``EllipsoidFit.used_mask``),
in the samples' unit (µT for calibrated-unit inputs), sensor frame:

* **RMS residual**: RMS of ``|A⁻¹(h − b)| − field`` (µT and % of the field): how well one
  ellipsoid explains the samples (noise, disturbances, non-linearity).
* **Coverage condition**: the 2-norm condition number of the 9-column quadric design matrix
  ``[x², y², z², 2yz, 2xz, 2xy, 2x, 2y, 2z]`` evaluated on the calibrated, unit-sphere samples
  ``u = A⁻¹(h − b) / field``, each column divided by its RMS over a uniformly covered sphere
  (``√(1/5)`` for squares, ``√(4/15)`` for products, ``√(4/3)`` for linear terms) and the
  matrix by ``√N``. A uniformly covered sphere scores about 1.6; one full turn about each of
  the three sensor axes about 10 (14 on the real HMC5883L recordings); turns about two axes
  about 70–150; a single turn (one circle) several hundred. The constant column of the full
  quadric is left out on purpose: on the sphere ``x² + y² + z² = 1`` makes it collinear with
  the squares for *any* coverage, which would hide what we want to measure.
* **Axis coverage**: for each sensor axis, the fraction of 36 azimuth bins (10° each) around
  that axis holding at least two samples (samples within 0.3 of the axis are ignored). A turn
  about an axis fills its bins; the lowest fraction names the turn to repeat.
* **Radii ratio**: longest / shortest fitted radius (soft-iron distortion or a bad fit).
* **Field range**: the Earth's field at the surface is 22–67 µT; a fitted field (the mean
  radius of the raw ellipsoid, checked even when the field is given) outside it means a
  wrong unit or scale, or a disturbed place.
* **Dip scatter** (when accelerometer samples are given): the standard deviation of the angle
  between the calibrated field and the horizontal plane, over quasi-static samples (the
  accelerometer norm within 5 % of its median). In a clean place the dip is constant.

Thresholds are the fields of :class:`QualityThresholds` (documented defaults below).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mimucap.core.magcal.fit import EllipsoidFit

FloatArray = NDArray[np.float64]

VERDICTS = ("good", "warn", "fail")
AXIS_NAMES = ("x", "y", "z")

#: RMS of each design-matrix column over a uniformly covered unit sphere (E[x⁴] = 1/5,
#: E[(2yz)²] = 4/15, E[(2x)²] = 4/3).
_UNIFORM_COLUMN_RMS = np.sqrt(np.array([1 / 5, 1 / 5, 1 / 5, 4 / 15, 4 / 15, 4 / 15, 4 / 3, 4 / 3, 4 / 3]))

#: Azimuth bins per axis for the axis coverage figure.
AZIMUTH_BINS = 36
#: Samples closer than this (on the unit sphere) to an axis carry no azimuth about it.
AZIMUTH_MIN_RADIUS = 0.3
#: An azimuth bin counts as covered with at least this many samples.
AZIMUTH_MIN_COUNT = 2
#: Quasi-static accelerometer samples for the dip figure: norm within this fraction of the median.
DIP_STATIC_TOLERANCE = 0.05
#: Fewer quasi-static samples than this: no dip figure.
DIP_MIN_SAMPLES = 10


@dataclass(frozen=True)
class QualityThresholds:
    """Verdict thresholds (defaults in brackets; "good" at or below, "fail" above).

    residual_good_uT [0.8], residual_fail_uT [2.2]: RMS residual, µT.
    condition_good [15], condition_fail [40]: coverage condition (see module docstring).
    radii_ratio_good [1.3], radii_ratio_fail [2.0]: longest / shortest radius.
    field_min_uT [22], field_max_uT [67]: plausible Earth field; outside → fail.
    dip_std_good_deg [3.0], dip_std_fail_deg [6.0]: dip-angle scatter, degrees. Hand-held
    motion tilts the accelerometer's gravity estimate by a few degrees (linear acceleration:
    2–3° on the real full-sphere recording of a clean HMC5883L), so this figure catches
    disturbances of several degrees, not fine errors.
    """

    residual_good_uT: float = 0.8
    residual_fail_uT: float = 2.2
    condition_good: float = 15.0
    condition_fail: float = 40.0
    radii_ratio_good: float = 1.3
    radii_ratio_fail: float = 2.0
    field_min_uT: float = 22.0
    field_max_uT: float = 67.0
    dip_std_good_deg: float = 3.0
    dip_std_fail_deg: float = 6.0

    def __post_init__(self) -> None:
        pairs = (
            (self.residual_good_uT, self.residual_fail_uT),
            (self.condition_good, self.condition_fail),
            (self.radii_ratio_good, self.radii_ratio_fail),
            (self.field_min_uT, self.field_max_uT),
            (self.dip_std_good_deg, self.dip_std_fail_deg),
        )
        for low, high in pairs:
            if not 0 < low <= high:
                raise ValueError(f"quality thresholds must satisfy 0 < good ≤ fail, got {low}, {high}")


@dataclass(frozen=True)
class Quality:
    """Quality figures of one calibration and the verdict.

    rms_residual_uT, rms_residual_pct: RMS of ``|A⁻¹(h − b)| − field`` (µT, % of field).
    condition: coverage condition (dimensionless). axis_coverage: (3,) fractions in [0, 1].
    radii_ratio: longest / shortest radius. field_uT: the field the calibration maps onto
    (given, or the fitted mean radius). fitted_field_uT: the raw ellipsoid's mean radius.
    dip_mean_deg, dip_std_deg: dip angle (positive below the horizon) and its scatter, or
    ``None`` without accelerometer samples. verdict: "good" / "warn" / "fail".
    reasons: what is not good, each with what to do about it.
    """

    rms_residual_uT: float
    rms_residual_pct: float
    condition: float
    axis_coverage: tuple[float, float, float]
    radii_ratio: float
    field_uT: float
    fitted_field_uT: float
    dip_mean_deg: float | None
    dip_std_deg: float | None
    verdict: str
    reasons: tuple[str, ...]

    def as_dict(self) -> dict:
        """JSON-ready dictionary of every field."""
        return {
            "rms_residual_uT": self.rms_residual_uT,
            "rms_residual_pct": self.rms_residual_pct,
            "condition": self.condition,
            "axis_coverage": list(self.axis_coverage),
            "radii_ratio": self.radii_ratio,
            "field_uT": self.field_uT,
            "fitted_field_uT": self.fitted_field_uT,
            "dip_mean_deg": self.dip_mean_deg,
            "dip_std_deg": self.dip_std_deg,
            "verdict": self.verdict,
            "reasons": list(self.reasons),
        }


def coverage_condition(unit_samples: ArrayLike) -> float:
    """Coverage condition of calibrated unit-sphere samples (N, 3); ``inf`` if rank-deficient."""
    u = np.asarray(unit_samples, dtype=np.float64)
    if len(u) < 9:
        return float("inf")
    x, y, z = u[:, 0], u[:, 1], u[:, 2]
    d = np.column_stack((x * x, y * y, z * z, 2 * y * z, 2 * x * z, 2 * x * y, 2 * x, 2 * y, 2 * z))
    d = d / _UNIFORM_COLUMN_RMS / np.sqrt(len(u))
    eigenvalues = np.linalg.eigvalsh(d.T @ d)  # squared singular values of d, ascending
    if eigenvalues[0] <= eigenvalues[-1] * 1e-24:
        return float("inf")
    return float(np.sqrt(eigenvalues[-1] / eigenvalues[0]))


def axis_coverage(unit_samples: ArrayLike) -> tuple[float, float, float]:
    """Fraction of azimuth bins covered about each sensor axis x, y, z (see module docstring)."""
    u = np.asarray(unit_samples, dtype=np.float64)
    fractions = []
    for axis in range(3):
        j, k = (axis + 1) % 3, (axis + 2) % 3
        radius = np.hypot(u[:, j], u[:, k])
        azimuth = np.arctan2(u[radius > AZIMUTH_MIN_RADIUS, k], u[radius > AZIMUTH_MIN_RADIUS, j])
        counts, _ = np.histogram(azimuth, bins=AZIMUTH_BINS, range=(-np.pi, np.pi))
        fractions.append(float(np.mean(counts >= AZIMUTH_MIN_COUNT)))
    return (fractions[0], fractions[1], fractions[2])


def dip_angles_deg(mag_cal: ArrayLike, acc: ArrayLike) -> FloatArray:
    """Dip angle (degrees, positive below the horizon) of calibrated field samples (N, 3) given
    accelerometer specific force (N, 3, m/s², sensor frame; it points up when at rest)."""
    m = np.asarray(mag_cal, dtype=np.float64)
    a = np.asarray(acc, dtype=np.float64)
    up = a / np.linalg.norm(a, axis=1, keepdims=True)
    sine = -np.sum(m * up, axis=1) / np.linalg.norm(m, axis=1)
    return np.degrees(np.arcsin(np.clip(sine, -1.0, 1.0)))


def assess_quality(
    fit: EllipsoidFit,
    mag_raw: ArrayLike,
    acc: ArrayLike | None = None,
    thresholds: QualityThresholds = QualityThresholds(),
) -> Quality:
    """Quality of ``fit`` on the samples it used.

    mag_raw: the (N, 3) samples given to the fit (same rows, same unit). acc: optional (N, 3)
    accelerometer specific force (m/s², sensor frame) sampled at the same instants; rows with
    NaN are ignored. Returns a :class:`Quality` with the verdict and the reasons.
    """
    mag = np.asarray(mag_raw, dtype=np.float64)
    if mag.shape != (fit.samples_input, 3):
        raise ValueError(
            f"the samples ({mag.shape}) are not the ones fitted ({fit.samples_input} rows of 3)"
        )
    used = mag[fit.used_mask]
    calibrated = fit.apply(used)
    norm = np.linalg.norm(calibrated, axis=1)
    residual = norm - fit.field_uT
    rms = float(np.sqrt(np.mean(residual**2)))
    unit = calibrated / fit.field_uT
    condition = coverage_condition(unit)
    coverage = axis_coverage(unit)
    dip_mean = dip_std = None
    if acc is not None:
        acc_array = np.asarray(acc, dtype=np.float64)
        if acc_array.shape != mag.shape:
            raise ValueError(
                f"accelerometer samples ({acc_array.shape}) must match the magnetometer samples "
                f"({mag.shape}) row by row"
            )
        acc_used = acc_array[fit.used_mask]
        acc_norm = np.linalg.norm(acc_used, axis=1)
        valid = np.isfinite(acc_norm) & (acc_norm > 0)
        if valid.any():
            median = float(np.median(acc_norm[valid]))
            static = valid & (np.abs(acc_norm - median) <= DIP_STATIC_TOLERANCE * median)
            if static.sum() >= DIP_MIN_SAMPLES:
                dips = dip_angles_deg(calibrated[static], acc_used[static])
                dip_mean, dip_std = float(dips.mean()), float(dips.std())
    verdict, reasons = _verdict(
        thresholds, rms, condition, coverage, fit.ellipsoid.radii_ratio, fit.ellipsoid.mean_radius, dip_std,
    )
    return Quality(
        rms_residual_uT=rms,
        rms_residual_pct=100.0 * rms / fit.field_uT,
        condition=condition,
        axis_coverage=coverage,
        radii_ratio=fit.ellipsoid.radii_ratio,
        field_uT=fit.field_uT,
        fitted_field_uT=fit.ellipsoid.mean_radius,
        dip_mean_deg=dip_mean,
        dip_std_deg=dip_std,
        verdict=verdict,
        reasons=tuple(reasons),
    )


def _verdict(
    t: QualityThresholds,
    rms: float,
    condition: float,
    coverage: tuple[float, float, float],
    radii_ratio: float,
    radius: float,
    dip_std: float | None,
) -> tuple[str, list[str]]:
    level = 0
    reasons: list[str] = []

    def flag(severity: int, text: str) -> None:
        nonlocal level
        level = max(level, severity)
        reasons.append(f"{VERDICTS[severity]}: {text}")

    def above(value: float | None, good: float, fail: float, describe) -> None:
        """Warn above ``good``, fail above ``fail``; ``describe(limit)`` says what to do."""
        if value is not None and value > good:
            severity = 2 if value > fail else 1
            flag(severity, describe(fail if severity == 2 else good))

    weakest = AXIS_NAMES[int(np.argmin(coverage))]
    above(condition, t.condition_good, t.condition_fail, lambda limit: (
        f"coverage too low (condition {condition:.0f} > {limit:g}): "
        f"turn the sensor one full turn about its {weakest} axis again"))
    above(rms, t.residual_good_uT, t.residual_fail_uT, lambda limit: (
        f"residual {rms:.2f} µT > {limit:g} µT: the field was disturbed or the sensor moved "
        "near iron; record again away from metal, magnets and electronics"))
    above(radii_ratio, t.radii_ratio_good, t.radii_ratio_fail, lambda limit: (
        f"radii ratio {radii_ratio:.2f} > {limit:g}: strong soft-iron distortion or poor "
        "coverage; check the sensor's mounting and turn about all three axes"))
    if not t.field_min_uT <= radius <= t.field_max_uT:
        flag(
            2,
            f"fitted field {radius:.1f} µT outside the Earth's {t.field_min_uT:g}–"
            f"{t.field_max_uT:g} µT: check the unit and scale of the input, or move away from iron",
        )
    above(dip_std, t.dip_std_good_deg, t.dip_std_fail_deg, lambda limit: (
        f"dip-angle scatter {dip_std:.1f}° > {limit:g}°: the field direction changed during "
        "the recording; record again away from metal"))
    return VERDICTS[level], reasons
