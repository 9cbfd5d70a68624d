"""Gyro-only propagation against analytic motions: errors scale with the step as theory says.

Motions: a constant rate about a fixed axis (the exponential map is exact there) and classic
coning, ``q(t) = Rz(Ωt)·Rx(β)·Rz(−Ωt)``, whose body rate is
``ω = Ω·[−sin β sin Ωt, sin β cos Ωt, cos β − 1]`` (derived from ``Ṙ = R[ω×]``).
"""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.core.fusion.propagation import integrate_gyro, integrate_increments

OMEGA = 2.0 * np.pi * 2.0  # coning frequency (rad/s)
BETA = np.radians(10.0)  # coning half-angle
DURATION_S = 2.0
STEPS_S = (0.01, 0.005)


def coning_q(t: np.ndarray) -> np.ndarray:
    a = OMEGA * t
    return rot.multiply(rot.multiply(rot.from_axis_angle([0, 0, 1], a),
                                     rot.from_axis_angle([1, 0, 0], np.full_like(a, BETA))),
                        rot.from_axis_angle([0, 0, 1], -a))


def coning_rate(t: np.ndarray) -> np.ndarray:
    a = OMEGA * t
    return OMEGA * np.stack([-np.sin(BETA) * np.sin(a), np.sin(BETA) * np.cos(a),
                             np.full_like(a, np.cos(BETA) - 1.0)], axis=-1)


def coning_increments(t: np.ndarray) -> np.ndarray:
    """Exact integrals of the rate over each step (8-point Gauss-Legendre, exact to 1e-15)."""
    t0, t1 = t[:-1], t[1:]
    nodes, weights = np.polynomial.legendre.leggauss(8)
    total = np.zeros((t0.size, 3))
    for node, weight in zip(nodes, weights):
        total += weight * coning_rate(t0 + (t1 - t0) * (node + 1.0) / 2.0) * ((t1 - t0) / 2.0)[:, None]
    return total


def final_error_rad(q_est: np.ndarray, q_true: np.ndarray) -> float:
    return float(rot.angle_between(q_est[-1], q_true[-1]))


def order(errors: list[float]) -> float:
    """Convergence order from errors at steps dt and dt/2."""
    return float(np.log2(errors[0] / errors[1]))


def test_coning_rate_matches_numerical_derivative():
    t = np.array([0.3])
    h = 1e-6
    q0, q1 = coning_q(t - h), coning_q(t + h)
    numeric = rot.to_rotvec(rot.multiply(rot.conjugate(q0), q1))[0] / (2 * h)
    assert np.allclose(numeric, coning_rate(t)[0], atol=1e-6)


def test_constant_rate_exact_map_is_exact_and_rk4_taylor3_are_fourth_order():
    rate = np.array([1.0, -2.0, 0.5])
    errors = {"exact": [], "rk4": [], "taylor3": []}
    q0 = rot.from_axis_angle([0.2, 0.3, 1.0], 0.7)
    for dt in (0.02, 0.01):
        t = np.arange(0.0, DURATION_S + dt / 2, dt)
        truth = rot.multiply(q0, rot.from_rotvec(np.outer(t, rate)))
        gyr = np.tile(rate, (t.size, 1))
        for method in errors:
            errors[method].append(final_error_rad(integrate_gyro(q0, gyr, t, method), truth))
    assert max(errors["exact"]) < 1e-12
    assert 3.7 < order(errors["rk4"]) < 4.3
    assert 3.7 < order(errors["taylor3"]) < 4.3


def test_coning_increments_taylor3_beats_uncorrected_exponential():
    """Uncorrected exponential of each increment: second order (coning drift ∝ dt²).
    The coning-corrected two-increment Taylor form removes the leading term: at least third order."""
    errors = {"exact": [], "taylor3": []}
    for dt in STEPS_S:
        t = np.arange(0.0, DURATION_S + dt / 2, dt)
        truth = coning_q(t)
        increments = coning_increments(t)
        for method in errors:
            q = integrate_increments(truth[0], increments, method)
            errors[method].append(final_error_rad(q, truth[1:]))
    assert 1.8 < order(errors["exact"]) < 2.2
    assert order(errors["taylor3"]) > 2.8
    assert errors["taylor3"][0] < errors["exact"][0] / 20


def test_coning_rate_samples_rk4_is_second_order():
    """With sampled rates, RK4's midpoint rate is the mean of the end samples: the O(dt²)
    interpolation error limits it to second order, whatever the RK4 stage order."""
    errors = []
    for dt in STEPS_S:
        t = np.arange(0.0, DURATION_S + dt / 2, dt)
        truth = coning_q(t)
        errors.append(final_error_rad(integrate_gyro(truth[0], coning_rate(t), t, "rk4"), truth))
    assert 1.8 < order(errors) < 2.2
    assert errors[-1] < np.radians(0.05)


def test_bad_input_raises():
    with pytest.raises(ValueError, match="strictly increasing"):
        integrate_gyro([1, 0, 0, 0], np.zeros((3, 3)), [0.0, 0.1, 0.1])
    with pytest.raises(ValueError, match="finite"):
        integrate_gyro([1, 0, 0, 0], [[0, 0, np.nan]] * 2, [0.0, 0.1])
    with pytest.raises(ValueError, match="unknown propagation"):
        integrate_gyro([1, 0, 0, 0], np.zeros((2, 3)), [0.0, 0.1], "euler")
    with pytest.raises(ValueError, match="rk4 integrates rates"):
        integrate_increments([1, 0, 0, 0], np.zeros((2, 3)), "rk4")
