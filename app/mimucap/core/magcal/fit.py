"""Ellipsoid fit of raw magnetometer samples: hard-iron offset and soft-iron correction.

Model (``docs/conventions.md``): ``mag_raw = A · mag_true + b + noise`` with
``|mag_true| = field_uT`` in every orientation, so the raw samples lie on the ellipsoid
``(h − b)ᵀ Q (h − b) = 1`` with ``Q = A⁻ᵀ A⁻¹ / field²``. The fit returns

* ``offset_uT`` = ``b`` (3,), in the sensor frame, µT (or whatever unit the samples are in);
* ``soft_iron`` = ``A⁻¹`` (3, 3), the **symmetric** positive-definite square root
  ``field · Q^½`` (never a Cholesky factor, which would rotate the sensor frame);
* ``field_uT``: the field given by the caller or, if none is given, the geometric mean of
  the fitted radii (so that ``det A = 1``: the correction changes shape, not size).

Calibrated samples are ``mag_cal = soft_iron @ (mag_raw − offset_uT)``, of norm ``field_uT``.

Two estimators, both run on normalised data (centred on the middle of the samples' 0.5–99.5 %
range per axis and divided by half its largest extent, so that a few wild samples do not
matter), with the design matrix rows ``[x², y², z², 2yz, 2xz, 2xy, 2x, 2y, 2z, 1]``:

* ``"ellipsoid"`` (default): Li & Griffiths (2004), "Least squares ellipsoid specific
  fitting", minimising the algebraic residual under ``k·J − I² = 1`` with ``k = 4``, solved
  as a reduced 6×6 eigenproblem; the result is an ellipsoid whenever its shortest radius is
  at least half its longest one, which every real magnetometer satisfies;
* ``"quadric"``: the general least-squares quadric of Choe et al.
  ("Study of calibration method of low-cost MEMS magnetometer") (the constant term fixed to −1,
  a linear least-squares problem); it may return a non-ellipsoid, which is then refused.

Robustness (:class:`FitSettings`): rows with NaN or ±inf are dropped and counted; exact
repeats of the previous row (a sensor polled faster than it updates) and samples crowding
one small cell of space (a sensor held still) are thinned; samples far outside the range of
the others are dropped as corrupted; the remaining, well-spread samples must number at least
``min_samples``; outliers of the radial residual are rejected with a
robust scale (1.4826 · MAD), iterated until nothing changes. A fit that is not an ellipsoid,
or is degenerate, raises :class:`FitRefused` whose message tells the user what to do.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

FIT_METHODS = ("ellipsoid", "quadric")

#: The Li & Griffiths constraint parameter: ``4J − I² > 0`` admits ellipsoids whose shortest
#: radius is at least half the longest.
LI_GRIFFITHS_K = 4.0

#: Normalisation uses the samples' range between these quantiles (robust to a few wild samples).
NORMALISATION_QUANTILE = 0.005

#: MAD → standard deviation for normally distributed residuals.
MAD_TO_SIGMA = 1.4826


class FitRefused(ValueError):
    """The samples do not determine a trustworthy ellipsoid; the message says why and what to do."""


@dataclass(frozen=True)
class FitSettings:
    """Settings of :func:`fit_ellipsoid` (defaults in brackets).

    method: ``"ellipsoid"`` (Li & Griffiths) or ``"quadric"`` (general least squares)
        [``"ellipsoid"``].
    field_uT: known magnitude of the local field in the samples' unit; ``None`` takes the
        geometric mean of the fitted radii [None].
    thin_cell_fraction: edge of the cubic cells used to thin crowded samples, as a fraction
        of the normalisation scale (about the field's radius) [0.01].
    max_per_cell: samples kept per cell; the rest are thinned [2].
    min_samples: minimum number of well-spread (kept) samples [30].
    gross_outlier_factor: a sample further than this many normalisation scales from the
        normalisation centre is rejected before any fit (a corrupted reading) [4.0].
    outlier_sigmas: a sample whose radial residual is further than this many robust sigmas
        from the median residual is rejected [4.0].
    outlier_scale_floor: the robust sigma is never taken below this fraction of the field,
        so that noise-free data loses nothing [1e-3].
    max_outlier_iterations: refits after rejecting outliers [6].
    max_rejected_fraction: more outliers than this fraction of the kept samples refuses the
        fit (the recording is disturbed, not the sensor) [0.3].
    max_radii_ratio: a longest/shortest radius ratio above this is refused as degenerate:
        soft iron never distorts a field that much [3.0].
    """

    method: str = "ellipsoid"
    field_uT: float | None = None
    thin_cell_fraction: float = 0.01
    max_per_cell: int = 2
    min_samples: int = 30
    gross_outlier_factor: float = 4.0
    outlier_sigmas: float = 4.0
    outlier_scale_floor: float = 1e-3
    max_outlier_iterations: int = 6
    max_rejected_fraction: float = 0.3
    max_radii_ratio: float = 3.0

    def __post_init__(self) -> None:
        if self.method not in FIT_METHODS:
            raise ValueError(f"unknown fit method {self.method!r}; choose one of {FIT_METHODS}")
        if self.field_uT is not None and not (np.isfinite(self.field_uT) and self.field_uT > 0):
            raise ValueError(f"field_uT must be a positive number, got {self.field_uT}")
        if self.thin_cell_fraction < 0 or self.max_per_cell < 1:
            raise ValueError("thin_cell_fraction must be ≥ 0 and max_per_cell ≥ 1")
        if self.min_samples < 10:
            raise ValueError("min_samples must be at least 10 (an ellipsoid has 9 parameters)")
        if self.gross_outlier_factor <= 1 or self.outlier_sigmas <= 0 or self.max_outlier_iterations < 0:
            raise ValueError("gross_outlier_factor must be > 1, outlier_sigmas > 0, max_outlier_iterations ≥ 0")
        if not 0 <= self.max_rejected_fraction < 1:
            raise ValueError("max_rejected_fraction must be in [0, 1)")
        if self.max_radii_ratio <= 1:
            raise ValueError("max_radii_ratio must be > 1")


@dataclass(frozen=True)
class Ellipsoid:
    """An ellipsoid ``(h − centre)ᵀ Q (h − centre) = 1`` in the samples' unit.

    centre: (3,); shape_matrix: ``Q`` (3, 3) symmetric positive definite;
    radii: (3,) semi-axes, ascending; axes: (3, 3) unit semi-axis directions as columns, in
    the order of ``radii``.
    """

    centre: FloatArray
    shape_matrix: FloatArray
    radii: FloatArray
    axes: FloatArray

    @property
    def radii_ratio(self) -> float:
        """Longest over shortest radius (1 for a sphere)."""
        return float(self.radii[-1] / self.radii[0])

    @property
    def mean_radius(self) -> float:
        """Geometric mean of the radii (the radius of the sphere of equal volume)."""
        return float(np.prod(self.radii) ** (1.0 / 3.0))


@dataclass(frozen=True)
class EllipsoidFit:
    """Result of :func:`fit_ellipsoid` (units: those of the samples, normally µT).

    offset_uT: hard-iron offset ``b`` (3,). soft_iron: ``A⁻¹`` (3, 3), symmetric.
    field_uT: field magnitude the correction maps onto; field_given: whether it was given.
    ellipsoid: the fitted :class:`Ellipsoid`. method: the estimator used.
    used_mask: (N,) bool over the input rows, true for the samples of the final fit.
    samples_input, samples_nonfinite, samples_thinned, samples_outliers, samples_used: counts
    (``samples_input = nonfinite + thinned + outliers + used``).
    """

    offset_uT: FloatArray
    soft_iron: FloatArray
    field_uT: float
    field_given: bool
    ellipsoid: Ellipsoid
    method: str
    used_mask: NDArray[np.bool_]
    samples_input: int
    samples_nonfinite: int
    samples_thinned: int
    samples_outliers: int

    @property
    def samples_used(self) -> int:
        return int(self.used_mask.sum())

    @property
    def samples_rejected(self) -> int:
        """Samples dropped as invalid (NaN/inf) or as outliers (thinned ones not included)."""
        return self.samples_nonfinite + self.samples_outliers

    def apply(self, mag_raw: ArrayLike) -> FloatArray:
        """Calibrated field ``soft_iron @ (mag_raw − offset_uT)``, shape (..., 3)."""
        return apply_correction(mag_raw, self.offset_uT, self.soft_iron)


def apply_correction(mag_raw: ArrayLike, offset_uT: ArrayLike, soft_iron: ArrayLike) -> FloatArray:
    """``mag_cal = soft_iron @ (mag_raw − offset_uT)`` for samples of shape (..., 3)."""
    mag = np.asarray(mag_raw, dtype=np.float64)
    if mag.shape[-1:] != (3,):
        raise ValueError(f"magnetometer samples must have shape (..., 3), got {mag.shape}")
    return (mag - np.asarray(offset_uT, dtype=np.float64)) @ np.asarray(soft_iron, dtype=np.float64).T


def symmetric_sqrt(matrix: ArrayLike) -> FloatArray:
    """The symmetric positive-definite square root of a symmetric positive-definite (3, 3) matrix."""
    m = np.asarray(matrix, dtype=np.float64)
    m = 0.5 * (m + m.T)
    eigenvalues, vectors = np.linalg.eigh(m)
    if eigenvalues[0] <= 0:
        raise ValueError("the matrix is not positive definite")
    return (vectors * np.sqrt(eigenvalues)) @ vectors.T


def design_matrix(points: FloatArray) -> FloatArray:
    """Quadric design matrix (N, 10): rows ``[x², y², z², 2yz, 2xz, 2xy, 2x, 2y, 2z, 1]``."""
    x, y, z = points[:, 0], points[:, 1], points[:, 2]
    return np.column_stack(
        (x * x, y * y, z * z, 2 * y * z, 2 * x * z, 2 * x * y, 2 * x, 2 * y, 2 * z, np.ones_like(x))
    )


def _li_griffiths_constraint(k: float = LI_GRIFFITHS_K) -> FloatArray:
    c1 = np.zeros((6, 6))
    c1[:3, :3] = k / 2.0 - 1.0
    np.fill_diagonal(c1[:3, :3], -1.0)
    c1[3:, 3:] = np.diag([-k, -k, -k])
    return c1


_C1_INV = np.linalg.inv(_li_griffiths_constraint())


def quadric_coefficients(points: FloatArray, method: str) -> FloatArray:
    """Quadric coefficients ``v`` (10,) of the design-matrix order, fitted to ``points`` (N, 3).

    ``points`` should be normalised (centred, of unit RMS radius). Raises :class:`FitRefused`
    if the normal equations are singular (the samples lie on a plane, line or point).
    """
    d = design_matrix(points)
    s = d.T @ d
    if method == "quadric":
        # Normal equations of ``D[:, :9] w = 1`` (well conditioned on normalised data).
        gram = s[:9, :9]
        if np.linalg.cond(gram) > 1e12:
            raise FitRefused(_DEGENERATE_MESSAGE)
        return np.append(np.linalg.solve(gram, d[:, :9].sum(axis=0)), -1.0)
    s11, s12, s22 = s[:6, :6], s[:6, 6:], s[6:, 6:]
    if np.linalg.cond(s22) > 1e12:
        raise FitRefused(_DEGENERATE_MESSAGE)
    s22_inv_s21 = np.linalg.solve(s22, s12.T)
    reduced = s11 - s12 @ s22_inv_s21
    eigenvalues, vectors = np.linalg.eig(_C1_INV @ reduced)
    real = np.abs(eigenvalues.imag) <= 1e-9 * max(1.0, float(np.abs(eigenvalues).max()))
    if not real.any():
        raise FitRefused(_DEGENERATE_MESSAGE)
    candidates = np.flatnonzero(real)
    best = candidates[np.argmax(eigenvalues.real[candidates])]
    v1 = vectors[:, best].real
    v2 = -s22_inv_s21 @ v1
    return np.concatenate((v1, v2))


_DEGENERATE_MESSAGE = (
    "the samples do not determine an ellipsoid (they lie on a plane or a curve): "
    "turn the sensor about all three of its axes"
)


def ellipsoid_from_quadric(v: FloatArray) -> Ellipsoid:
    """Centre, shape matrix, radii and axes of the quadric ``v`` (10,); refuses non-ellipsoids."""
    a, b, c, f, g, h, p, q, r, d = v
    m = np.array([[a, h, g], [h, b, f], [g, f, c]])
    u = np.array([p, q, r])
    try:
        centre = -np.linalg.solve(m, u)
    except np.linalg.LinAlgError as error:
        raise FitRefused(_DEGENERATE_MESSAGE) from error
    scale = centre @ m @ centre - d
    if not np.isfinite(scale) or scale == 0:
        raise FitRefused(_DEGENERATE_MESSAGE)
    shape = m / scale
    shape = 0.5 * (shape + shape.T)
    eigenvalues, vectors = np.linalg.eigh(shape)
    if eigenvalues[0] <= 0:
        raise FitRefused(
            "the fitted surface is not an ellipsoid (a hyperboloid or a cylinder): the samples "
            "cover too few orientations; turn the sensor about all three of its axes"
        )
    radii = 1.0 / np.sqrt(eigenvalues[::-1])
    return Ellipsoid(centre=centre, shape_matrix=shape, radii=radii, axes=vectors[:, ::-1])


def thin_samples(points: FloatArray, cell: float, max_per_cell: int) -> NDArray[np.bool_]:
    """Mask (N,) keeping every sample except exact repeats of the previous one and samples beyond
    ``max_per_cell`` in any cubic cell of edge ``cell`` (first ones kept). ``cell = 0`` only
    removes the repeats."""
    keep = np.ones(len(points), dtype=bool)
    if len(points) > 1:
        keep[1:] = np.any(points[1:] != points[:-1], axis=1)
    if cell > 0:
        index = np.flatnonzero(keep)
        cells = np.floor(points[index] / cell).astype(np.int64)
        cells -= cells.min(axis=0)
        span = cells.max(axis=0) + 1
        if float(np.prod(span.astype(np.float64))) < 2.0**62:
            key = (cells[:, 0] * span[1] + cells[:, 1]) * span[2] + cells[:, 2]
        else:  # far outliers: too many cells to number, label the occupied ones instead
            key = np.unique(cells, axis=0, return_inverse=True)[1].reshape(-1)
        order = np.argsort(key, kind="stable")
        sorted_keys = key[order]
        starts = np.r_[0, np.flatnonzero(np.diff(sorted_keys)) + 1]
        rank = np.arange(len(order)) - np.repeat(starts, np.diff(np.r_[starts, len(order)]))
        crowded = order[rank >= max_per_cell]
        keep[index[crowded]] = False
    return keep


def radial_residual(points: FloatArray, centre: FloatArray, shape_matrix: FloatArray) -> FloatArray:
    """``|Q^½ (h − c)| − 1`` per sample (N,): the relative radial distance from the ellipsoid."""
    root = symmetric_sqrt(shape_matrix)
    return np.linalg.norm((points - centre) @ root.T, axis=1) - 1.0


def _fit_normalised(points: FloatArray, method: str) -> Ellipsoid:
    return ellipsoid_from_quadric(quadric_coefficients(points, method))


def fit_ellipsoid(mag_raw: ArrayLike, settings: FitSettings = FitSettings()) -> EllipsoidFit:
    """Fit the hard- and soft-iron model to raw magnetometer samples ``mag_raw`` (N, 3).

    Returns an :class:`EllipsoidFit`; raises :class:`FitRefused` (a ``ValueError``) with a
    reason a user can act on when the samples are too few, too poorly spread, too disturbed
    or do not describe an ellipsoid.
    """
    mag = np.asarray(mag_raw, dtype=np.float64)
    if mag.ndim != 2 or mag.shape[1] != 3:
        raise ValueError(f"magnetometer samples must have shape (N, 3), got {mag.shape}")
    n_input = len(mag)
    finite = np.all(np.isfinite(mag), axis=1)
    n_nonfinite = int(n_input - finite.sum())
    finite_index = np.flatnonzero(finite)
    if len(finite_index) < settings.min_samples:
        raise FitRefused(
            f"only {len(finite_index)} valid samples ({n_nonfinite} NaN/inf rows dropped); "
            f"at least {settings.min_samples} are needed: record a longer rotation"
        )
    points = mag[finite_index]
    low, high = np.quantile(points, [NORMALISATION_QUANTILE, 1.0 - NORMALISATION_QUANTILE], axis=0)
    centre0 = 0.5 * (low + high)
    scale = 0.5 * float(np.max(high - low))
    if not scale > 0:
        raise FitRefused("the samples do not change: the sensor did not move or is not responding")
    normalised = (points - centre0) / scale
    gross = np.linalg.norm(normalised, axis=1) > settings.gross_outlier_factor
    n_gross = int(gross.sum())
    kept = np.zeros(len(points), dtype=bool)
    kept[~gross] = thin_samples(normalised[~gross], settings.thin_cell_fraction, settings.max_per_cell)
    n_thinned = int(len(points) - n_gross - kept.sum())
    n_kept = int(kept.sum())
    if n_kept < settings.min_samples:
        raise FitRefused(
            f"only {n_kept} well-spread samples after thinning {n_thinned} repeated or crowded "
            f"ones; at least {settings.min_samples} are needed: keep turning the sensor"
        )
    inliers = kept.copy()
    ellipsoid = _fit_normalised(normalised[inliers], settings.method)
    for _ in range(settings.max_outlier_iterations):
        residual = radial_residual(normalised, ellipsoid.centre, ellipsoid.shape_matrix)
        kept_residual = residual[kept]
        median = float(np.median(kept_residual))
        sigma = MAD_TO_SIGMA * float(np.median(np.abs(kept_residual - median)))
        sigma = max(sigma, settings.outlier_scale_floor)
        new_inliers = kept & (np.abs(residual - median) <= settings.outlier_sigmas * sigma)
        if np.array_equal(new_inliers, inliers):
            break
        inliers = new_inliers
        n_outliers = int(n_kept - inliers.sum()) + n_gross
        if n_outliers > settings.max_rejected_fraction * (n_kept + n_gross):
            raise FitRefused(
                f"{n_outliers} of {n_kept + n_gross} samples are outliers: the field was disturbed during "
                "the recording; move away from iron, magnets and electronics and record again"
            )
        if inliers.sum() < settings.min_samples:
            raise FitRefused(
                f"only {int(inliers.sum())} samples remain after rejecting outliers; "
                f"at least {settings.min_samples} are needed: record again"
            )
        ellipsoid = _fit_normalised(normalised[inliers], settings.method)
    n_outliers = int(n_kept - inliers.sum()) + n_gross
    if ellipsoid.radii_ratio > settings.max_radii_ratio:
        raise FitRefused(
            f"the fitted ellipsoid is degenerate (radii ratio {ellipsoid.radii_ratio:.1f} > "
            f"{settings.max_radii_ratio:g}): the samples cover too few orientations; "
            "turn the sensor about all three of its axes"
        )
    centre = centre0 + scale * ellipsoid.centre
    shape_matrix = ellipsoid.shape_matrix / scale**2
    world = Ellipsoid(
        centre=centre, shape_matrix=shape_matrix, radii=ellipsoid.radii * scale, axes=ellipsoid.axes
    )
    field_given = settings.field_uT is not None
    field = float(settings.field_uT) if field_given else world.mean_radius
    soft_iron = field * symmetric_sqrt(shape_matrix)
    used_mask = np.zeros(n_input, dtype=bool)
    used_mask[finite_index[inliers]] = True
    return EllipsoidFit(
        offset_uT=centre,
        soft_iron=soft_iron,
        field_uT=field,
        field_given=field_given,
        ellipsoid=world,
        method=settings.method,
        used_mask=used_mask,
        samples_input=n_input,
        samples_nonfinite=n_nonfinite,
        samples_thinned=n_thinned,
        samples_outliers=n_outliers,
    )
