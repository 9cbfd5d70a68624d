"""The magnetometer views' data: thinned samples, colours by time, magnitudes before and
after correction, the ellipsoid's matrix and the framing, all from known calibrations."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core.magcal.fit import fit_ellipsoid
from mimucap.session.views.magcal_display import magcal_display


def _samples(n: int, seed: int = 0):
    """A 50 µT field seen through a known soft/hard iron (h = A·H + B), all directions."""
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(n, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    soft = np.array([[1.1, 0.05, 0.0], [0.05, 0.95, 0.02], [0.0, 0.02, 1.02]])
    offset = np.array([12.0, -7.0, 30.0])
    return 50.0 * directions @ soft.T + offset, np.arange(n) / 100.0, offset


def test_before_a_fit_the_raw_cloud_is_framed_and_coloured_by_time():
    mag, t, _ = _samples(500)
    display = magcal_display(mag, t + 7.0, None)
    assert display.count == 500 and display.fit is None and display.corrected_uT is None
    assert display.t_s[0] == 0.0 and display.t_s[-1] == pytest.approx(4.99)
    assert display.time_fraction[0] == 0.0 and display.time_fraction[-1] == 1.0
    np.testing.assert_allclose(display.raw_norm_uT, np.linalg.norm(mag, axis=1))
    np.testing.assert_allclose(display.centre_uT, mag.mean(axis=0))
    assert 45.0 < display.extent_uT < 75.0


def test_with_a_fit_the_corrected_samples_lie_on_the_field_sphere():
    mag, t, offset = _samples(3000)
    fit = fit_ellipsoid(mag)
    display = magcal_display(mag, t, fit, max_points=800)
    assert display.count == 800  # thinned evenly, first and last kept
    np.testing.assert_allclose(display.raw_uT[[0, -1]], mag[[0, -1]])
    np.testing.assert_allclose(display.corrected_norm_uT, display.field_uT, rtol=1e-6)
    np.testing.assert_allclose(display.centre_uT, offset, atol=1e-6)
    # The matrix maps the unit sphere onto the fitted ellipsoid: raw samples come from it.
    unit = np.linalg.solve(display.ellipsoid_matrix[:3, :3], (display.raw_uT - display.ellipsoid_matrix[:3, 3]).T)
    np.testing.assert_allclose(np.linalg.norm(unit, axis=0), 1.0, atol=1e-6)
    assert display.extent_uT == pytest.approx(float(np.max(fit.ellipsoid.radii)))


def test_bad_input_is_refused_and_empty_input_is_fine():
    mag, t, _ = _samples(10)
    with pytest.raises(ValueError, match="10 magnetometer samples but 9 times"):
        magcal_display(mag, t[:9], None)
    with pytest.raises(ValueError, match="max_points"):
        magcal_display(mag, t, None, max_points=1)
    empty = magcal_display(np.zeros((0, 3)), np.zeros(0), None)
    assert empty.count == 0 and empty.extent_uT == 0.0
