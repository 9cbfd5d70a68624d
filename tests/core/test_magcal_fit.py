"""Ellipsoid fit: exact recovery, noise bounds, symmetric soft iron, robustness and refusals."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core.magcal.fit import FitRefused, FitSettings, apply_correction, fit_ellipsoid, symmetric_sqrt

FIELD_UT = 49.3


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q * np.sign(np.linalg.det(q))


def random_soft_iron(rng: np.random.Generator, symmetric: bool = True) -> np.ndarray:
    """A distortion A with off-diagonal terms: a rotated diagonal scaling (radii 0.75–1.3)."""
    rotation = random_rotation(rng)
    a = rotation @ np.diag(rng.uniform(0.75, 1.3, size=3)) @ rotation.T
    if not symmetric:
        a = a @ random_rotation(rng)
    return a


def unit_vectors(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def angles_deg(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angle between row vectors, accurate near zero."""
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), np.sum(u * v, axis=1)))


@pytest.mark.parametrize("method", ["ellipsoid", "quadric"])
@pytest.mark.parametrize("seed", range(8))
def test_noise_free_random_ellipsoids_are_recovered_exactly(method: str, seed: int) -> None:
    rng = np.random.default_rng(seed)
    a = random_soft_iron(rng)
    b = rng.uniform(-80, 80, size=3)
    h_true = FIELD_UT * unit_vectors(rng, 500)
    raw = h_true @ a.T + b
    fit = fit_ellipsoid(raw, FitSettings(method=method, field_uT=FIELD_UT))
    np.testing.assert_allclose(fit.offset_uT, b, atol=1e-8)
    np.testing.assert_allclose(fit.soft_iron, np.linalg.inv(a), atol=1e-10)
    np.testing.assert_allclose(fit.apply(raw), h_true, atol=1e-8)
    assert fit.samples_used == 500 and fit.samples_rejected == 0


@pytest.mark.parametrize("seed", range(4))
def test_non_symmetric_distortion_is_recovered_up_to_a_rotation(seed: int) -> None:
    # A = S·R cannot be told from S by field magnitudes alone: A⁻ᵀA⁻¹ is what the data fix.
    rng = np.random.default_rng(100 + seed)
    a = random_soft_iron(rng, symmetric=False)
    b = rng.uniform(-50, 50, size=3)
    raw = FIELD_UT * unit_vectors(rng, 400) @ a.T + b
    fit = fit_ellipsoid(raw, FitSettings(field_uT=FIELD_UT))
    a_inv = np.linalg.inv(a)
    np.testing.assert_allclose(fit.soft_iron.T @ fit.soft_iron, a_inv.T @ a_inv, atol=1e-10)
    np.testing.assert_allclose(fit.soft_iron, fit.soft_iron.T, atol=1e-12)


def test_symmetric_root_does_not_rotate_the_frame_but_cholesky_would() -> None:
    rng = np.random.default_rng(7)
    rotation = random_rotation(rng)
    a = rotation @ np.diag([0.8, 1.0, 1.25]) @ rotation.T  # symmetric, strong off-diagonal terms
    b = np.array([12.0, -30.0, 5.0])
    h_true = FIELD_UT * unit_vectors(rng, 300)
    raw = h_true @ a.T + b
    fit = fit_ellipsoid(raw, FitSettings(field_uT=FIELD_UT))
    corrected = fit.apply(raw)
    assert angles_deg(corrected, h_true).max() < 1e-6
    # The Cholesky factor of the same ellipsoid gives the right magnitudes in a rotated frame.
    lower = np.linalg.cholesky(fit.ellipsoid.shape_matrix)
    cholesky_corrected = FIELD_UT * (raw - fit.offset_uT) @ lower
    np.testing.assert_allclose(np.linalg.norm(cholesky_corrected, axis=1), FIELD_UT, rtol=1e-9)
    assert np.median(angles_deg(cholesky_corrected, h_true)) > 1.0


def test_noisy_fit_is_within_the_noise_bounds() -> None:
    # Radial Fisher information of N uniformly spread samples: Σ u uᵀ / σ² = N/(3σ²) I, so the
    # centre's standard error per axis is σ·√(3/N); the RMS residual estimates σ.
    rng = np.random.default_rng(11)
    sigma, n = 0.5, 3000
    a = random_soft_iron(rng)
    b = rng.uniform(-40, 40, size=3)
    raw = FIELD_UT * unit_vectors(rng, n) @ a.T + b
    raw_noisy = raw + rng.normal(scale=sigma, size=raw.shape)
    fit = fit_ellipsoid(raw_noisy, FitSettings(field_uT=FIELD_UT))
    standard_error = sigma * np.sqrt(3.0 / n)
    assert np.all(np.abs(fit.offset_uT - b) < 4.5 * standard_error)
    residual = np.linalg.norm(fit.apply(raw_noisy[fit.used_mask]), axis=1) - FIELD_UT
    assert 0.85 * sigma < np.sqrt(np.mean(residual**2)) < 1.1 * sigma
    # The correction maps the noise-free samples onto the sphere to about σ/√N relative.
    error = np.abs(np.linalg.norm(fit.apply(raw), axis=1) / FIELD_UT - 1.0)
    assert error.max() < 10 * sigma / FIELD_UT / np.sqrt(n) * np.sqrt(3)


def test_field_is_the_geometric_mean_radius_when_not_given() -> None:
    rng = np.random.default_rng(3)
    a = np.diag([0.9, 1.0, 1.2])
    raw = 50.0 * unit_vectors(rng, 300) @ a.T
    fit = fit_ellipsoid(raw)
    assert fit.field_uT == pytest.approx(50.0 * (0.9 * 1.0 * 1.2) ** (1 / 3), rel=1e-9)
    assert not fit.field_given
    assert np.linalg.det(fit.soft_iron) == pytest.approx(1.0, rel=1e-9)  # shape only, no scaling
    np.testing.assert_allclose(fit.ellipsoid.radii, 50.0 * np.array([0.9, 1.0, 1.2]), rtol=1e-9)


def test_nonfinite_rows_are_rejected_and_counted() -> None:
    rng = np.random.default_rng(5)
    raw = 45.0 * unit_vectors(rng, 300) + [10.0, -5.0, 3.0]
    raw[[3, 50, 51]] = np.nan
    raw[100, 1] = np.inf
    fit = fit_ellipsoid(raw)
    assert fit.samples_nonfinite == 4
    assert fit.samples_rejected == 4
    assert not fit.used_mask[[3, 50, 51, 100]].any()
    np.testing.assert_allclose(fit.offset_uT, [10.0, -5.0, 3.0], atol=1e-8)


def test_outliers_are_rejected_iteratively() -> None:
    rng = np.random.default_rng(8)
    b = np.array([20.0, -10.0, 30.0])
    raw = 48.0 * unit_vectors(rng, 600) + b + rng.normal(scale=0.3, size=(600, 3))
    spikes = rng.choice(600, size=30, replace=False)
    raw[spikes] += unit_vectors(rng, 30) * rng.uniform(8, 40, size=(30, 1))
    fit = fit_ellipsoid(raw)
    assert fit.samples_outliers >= 28
    assert not fit.used_mask[spikes].any() or fit.used_mask[spikes].sum() <= 2
    assert np.all(np.abs(fit.offset_uT - b) < 0.15)
    plain = fit_ellipsoid(raw, FitSettings(max_outlier_iterations=0))
    assert np.linalg.norm(plain.offset_uT - b) > np.linalg.norm(fit.offset_uT - b)


def test_repeated_and_crowded_samples_are_thinned() -> None:
    rng = np.random.default_rng(9)
    sphere = 45.0 * unit_vectors(rng, 400)
    still = np.repeat(sphere[:1] + rng.normal(scale=0.01, size=(1, 3)), 500, axis=0) + rng.normal(scale=0.05, size=(500, 3))
    repeats = np.repeat(sphere[1:2], 20, axis=0)
    raw = np.vstack([sphere, still, repeats])
    fit = fit_ellipsoid(raw)
    assert fit.samples_thinned >= 480
    assert fit.samples_used <= 420
    np.testing.assert_allclose(fit.offset_uT, 0.0, atol=2e-3)


def test_too_few_samples_are_refused() -> None:
    rng = np.random.default_rng(1)
    with pytest.raises(FitRefused, match="at least 30"):
        fit_ellipsoid(45.0 * unit_vectors(rng, 20))
    with pytest.raises(FitRefused, match="well-spread"):
        fit_ellipsoid(np.repeat(45.0 * unit_vectors(rng, 10), 10, axis=0))
    with pytest.raises(FitRefused, match="did not move"):
        fit_ellipsoid(np.ones((100, 3)))


def test_planar_samples_are_refused_as_degenerate() -> None:
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    circle = np.column_stack([45 * np.cos(t), 45 * np.sin(t), np.full_like(t, 12.0)])
    for method in ("ellipsoid", "quadric"):
        with pytest.raises(FitRefused, match="three of its axes"):
            fit_ellipsoid(circle, FitSettings(method=method))


def test_a_hyperboloid_is_refused() -> None:
    rng = np.random.default_rng(2)
    u, v = rng.uniform(-1.5, 1.5, size=300), rng.uniform(0, 2 * np.pi, size=300)
    hyperboloid = 40 * np.column_stack([np.cosh(u) * np.cos(v), np.cosh(u) * np.sin(v), np.sinh(u)])
    with pytest.raises(FitRefused):
        fit_ellipsoid(hyperboloid, FitSettings(method="quadric"))


def test_a_recording_with_too_many_outliers_is_refused() -> None:
    rng = np.random.default_rng(4)
    raw = 45.0 * unit_vectors(rng, 400) + rng.normal(scale=0.2, size=(400, 3))
    raw[:140] *= 1.5  # 35 % of the samples taken next to a magnet
    with pytest.raises(FitRefused, match="outliers"):
        fit_ellipsoid(raw)


def test_settings_are_validated() -> None:
    with pytest.raises(ValueError, match="method"):
        FitSettings(method="cholesky")
    with pytest.raises(ValueError, match="field_uT"):
        FitSettings(field_uT=-3.0)
    with pytest.raises(ValueError, match="min_samples"):
        FitSettings(min_samples=5)
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        fit_ellipsoid(np.zeros((10, 2)))


def test_symmetric_sqrt_and_apply_correction() -> None:
    rng = np.random.default_rng(6)
    m = random_soft_iron(rng)
    root = symmetric_sqrt(m @ m)
    np.testing.assert_allclose(root, m, atol=1e-12)
    with pytest.raises(ValueError):
        symmetric_sqrt(-np.eye(3))
    sample = np.array([[1.0, 2.0, 3.0]])
    np.testing.assert_allclose(apply_correction(sample, [1, 1, 1], 2 * np.eye(3)), [[0, 2, 4]])


def test_far_outliers_do_not_break_thinning() -> None:
    rng = np.random.default_rng(12)
    raw = 45.0 * unit_vectors(rng, 500) + [5.0, 6.0, 7.0]
    raw[10] = [1e12, -1e12, 1e12]  # a corrupted sample
    fit = fit_ellipsoid(raw)
    assert not fit.used_mask[10] and fit.samples_outliers == 1
    np.testing.assert_allclose(fit.offset_uT, [5.0, 6.0, 7.0], atol=1e-6)
