"""Gyroscope propagation of an orientation: RK4, third-order Taylor with coning correction, exact.

Quaternions are scalar-first Hamilton ``q_world_from_sensor``; the angular rate ``ω`` is in the
sensor frame (rad/s), so the kinematics are ``q̇ = ½ q ⊗ [0, ω]`` and one step right-multiplies
an incremental rotation: ``q_k = q_{k-1} ⊗ Δq_k``.

Sample conventions (one step goes from ``t_{k-1}`` to ``t_k``, ``dt = t_k − t_{k-1}``):

* ``exact``: ``Δq = exp(Δθ_k)`` with the angle increment ``Δθ_k = ω_k·dt`` (the rate sample
  ``ω_k`` is the mean rate over the interval ending at ``t_k``). Exact for a rotation about a
  fixed axis; it ignores the non-commutativity (coning) inside the interval.
* ``taylor3`` (Zhang, Gao, Zhou, "Head attitude sensing algorithm based on IMU in VR
  device", equation 7; the standard coning-corrected form): the rotation vector
  ``φ = Δθ_k + (1/12)·Δθ_{k-1} × Δθ_k`` from two successive increments, and
  ``Δq = [1 − |φ|²/8, φ/2·(1 − |φ|²/24)]`` (third-order Taylor series of the exponential),
  then normalised.
* ``rk4`` (Zhang et al., equations 5–6): classical Runge-Kutta on ``q̇ = ½ q ⊗ [0, ω(t)]`` with
  ``ω(t_{k-1}) = ω_{k-1}``, ``ω(t_k) = ω_k`` and their mean at the midpoint (rate samples taken
  as instantaneous), then normalised.

The step functions are numba-compiled so that the filter kernels call them without overhead;
:func:`integrate_gyro` and :func:`integrate_increments` are the vectorised gyro-only API.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from mimucap.core.fusion.jit import JIT_OPTIONS
from mimucap.core.fusion.params import PROPAGATION_METHODS


@njit(inline="always", **JIT_OPTIONS)
def quat_multiply(aw, ax, ay, az, bw, bx, by, bz):
    """Hamilton product ``a ⊗ b`` of two quaternions given component-wise."""
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


@njit(inline="always", **JIT_OPTIONS)
def quat_normalise(w, x, y, z):
    n = 1.0 / math.sqrt(w * w + x * x + y * y + z * z)
    return w * n, x * n, y * n, z * n


@njit(inline="always", **JIT_OPTIONS)
def exp_quat(px, py, pz):
    """Exact exponential map of the rotation vector ``p`` (rad)."""
    n = math.sqrt(px * px + py * py + pz * pz)
    if n < 1e-8:
        s = 0.5 - n * n / 48.0
        return 1.0 - n * n / 8.0, s * px, s * py, s * pz
    s = math.sin(0.5 * n) / n
    return math.cos(0.5 * n), s * px, s * py, s * pz


@njit(inline="always", **JIT_OPTIONS)
def step_exact(qw, qx, qy, qz, dx, dy, dz):
    """``q ⊗ exp(Δθ)`` for the angle increment ``Δθ`` (rad, sensor frame)."""
    ew, ex, ey, ez = exp_quat(dx, dy, dz)
    w, x, y, z = quat_multiply(qw, qx, qy, qz, ew, ex, ey, ez)
    return quat_normalise(w, x, y, z)


@njit(inline="always", **JIT_OPTIONS)
def step_taylor3(qw, qx, qy, qz, px_, py_, pz_, dx, dy, dz):
    """Coning-corrected third-order Taylor step from the previous increment ``p`` and ``Δθ``."""
    fx = dx + (py_ * dz - pz_ * dy) / 12.0
    fy = dy + (pz_ * dx - px_ * dz) / 12.0
    fz = dz + (px_ * dy - py_ * dx) / 12.0
    n2 = fx * fx + fy * fy + fz * fz
    s = 0.5 * (1.0 - n2 / 24.0)
    w, x, y, z = quat_multiply(qw, qx, qy, qz, 1.0 - n2 / 8.0, s * fx, s * fy, s * fz)
    return quat_normalise(w, x, y, z)


@njit(inline="always", **JIT_OPTIONS)
def _qdot(qw, qx, qy, qz, wx, wy, wz):
    # ½ q ⊗ [0, ω]
    return (
        0.5 * (-qx * wx - qy * wy - qz * wz),
        0.5 * (qw * wx + qy * wz - qz * wy),
        0.5 * (qw * wy - qx * wz + qz * wx),
        0.5 * (qw * wz + qx * wy - qy * wx),
    )


@njit(inline="always", **JIT_OPTIONS)
def step_rk4(qw, qx, qy, qz, ax, ay, az, bx, by, bz, dt):
    """RK4 step with rate ``a`` at the start, ``b`` at the end and their mean at mid-step."""
    mx = 0.5 * (ax + bx)
    my = 0.5 * (ay + by)
    mz = 0.5 * (az + bz)
    h = 0.5 * dt
    k1w, k1x, k1y, k1z = _qdot(qw, qx, qy, qz, ax, ay, az)
    k2w, k2x, k2y, k2z = _qdot(qw + h * k1w, qx + h * k1x, qy + h * k1y, qz + h * k1z, mx, my, mz)
    k3w, k3x, k3y, k3z = _qdot(qw + h * k2w, qx + h * k2x, qy + h * k2y, qz + h * k2z, mx, my, mz)
    k4w, k4x, k4y, k4z = _qdot(qw + dt * k3w, qx + dt * k3x, qy + dt * k3y, qz + dt * k3z, bx, by, bz)
    c = dt / 6.0
    return quat_normalise(
        qw + c * (k1w + 2.0 * k2w + 2.0 * k3w + k4w),
        qx + c * (k1x + 2.0 * k2x + 2.0 * k3x + k4x),
        qy + c * (k1y + 2.0 * k2y + 2.0 * k3y + k4y),
        qz + c * (k1z + 2.0 * k2z + 2.0 * k3z + k4z),
    )


@njit(**JIT_OPTIONS)
def _integrate_rates(q0, gyr, t, method, out):
    qw, qx, qy, qz = q0[0], q0[1], q0[2], q0[3]
    out[0, 0], out[0, 1], out[0, 2], out[0, 3] = qw, qx, qy, qz
    px = py = pz = 0.0
    for k in range(1, gyr.shape[0]):
        dt = t[k] - t[k - 1]
        dx, dy, dz = gyr[k, 0] * dt, gyr[k, 1] * dt, gyr[k, 2] * dt
        if method == 0:
            if k == 1:
                px, py, pz = dx, dy, dz
            qw, qx, qy, qz = step_taylor3(qw, qx, qy, qz, px, py, pz, dx, dy, dz)
            px, py, pz = dx, dy, dz
        elif method == 1:
            qw, qx, qy, qz = step_rk4(qw, qx, qy, qz, gyr[k - 1, 0], gyr[k - 1, 1], gyr[k - 1, 2],
                                      gyr[k, 0], gyr[k, 1], gyr[k, 2], dt)
        else:
            qw, qx, qy, qz = step_exact(qw, qx, qy, qz, dx, dy, dz)
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = qw, qx, qy, qz


@njit(**JIT_OPTIONS)
def _integrate_increments(q0, dtheta, method, out):
    qw, qx, qy, qz = q0[0], q0[1], q0[2], q0[3]
    px = py = pz = 0.0
    for k in range(dtheta.shape[0]):
        dx, dy, dz = dtheta[k, 0], dtheta[k, 1], dtheta[k, 2]
        if method == 0:
            if k == 0:
                px, py, pz = dx, dy, dz
            qw, qx, qy, qz = step_taylor3(qw, qx, qy, qz, px, py, pz, dx, dy, dz)
            px, py, pz = dx, dy, dz
        else:
            qw, qx, qy, qz = step_exact(qw, qx, qy, qz, dx, dy, dz)
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = qw, qx, qy, qz


def _method_code(method: str) -> int:
    if method not in PROPAGATION_METHODS:
        raise ValueError(f"unknown propagation method {method!r}; choose one of {sorted(PROPAGATION_METHODS)}")
    return PROPAGATION_METHODS[method]


def integrate_gyro(q0_world_from_sensor, gyr_rad_s, t_s, method: str = "taylor3") -> np.ndarray:
    """Gyro-only orientation ``q_world_from_sensor`` (N, 4) from rate samples.

    ``q0_world_from_sensor`` (4,) is the orientation at ``t_s[0]``; ``gyr_rad_s`` (N, 3) are
    sensor-frame rates (rad/s) at the time stamps ``t_s`` (N,) in seconds (strictly
    increasing). Row 0 of the result is ``q0``.
    """
    gyr = np.ascontiguousarray(gyr_rad_s, dtype=np.float64)
    t = np.ascontiguousarray(t_s, dtype=np.float64)
    q0 = np.asarray(q0_world_from_sensor, dtype=np.float64)
    if gyr.ndim != 2 or gyr.shape[1] != 3 or t.shape != (gyr.shape[0],) or q0.shape != (4,):
        raise ValueError("integrate_gyro needs q0 (4,), gyr (N, 3) and t_s (N,)")
    if not (np.all(np.isfinite(gyr)) and np.all(np.isfinite(t))):
        raise ValueError("integrate_gyro: gyro samples and time stamps must be finite")
    if gyr.shape[0] > 1 and np.any(np.diff(t) <= 0.0):
        raise ValueError("integrate_gyro: time stamps must be strictly increasing")
    out = np.empty((gyr.shape[0], 4))
    if gyr.shape[0]:
        _integrate_rates(q0 / np.linalg.norm(q0), gyr, t, _method_code(method), out)
    return out


def integrate_increments(q0_world_from_sensor, dtheta_rad, method: str = "taylor3") -> np.ndarray:
    """Orientation after each angle increment: ``(N, 4)`` from ``dtheta_rad`` (N, 3).

    ``dtheta_rad[k]`` is the integrated sensor-frame rate over step ``k`` (what an
    incremental-angle gyroscope delivers); ``method`` is ``"taylor3"`` (coning corrected) or
    ``"exact"`` (exponential of each increment alone). Row ``k`` is the orientation after
    increment ``k``.
    """
    dtheta = np.ascontiguousarray(dtheta_rad, dtype=np.float64)
    q0 = np.asarray(q0_world_from_sensor, dtype=np.float64)
    if dtheta.ndim != 2 or dtheta.shape[1] != 3 or q0.shape != (4,):
        raise ValueError("integrate_increments needs q0 (4,) and dtheta (N, 3)")
    code = _method_code(method)
    if code == PROPAGATION_METHODS["rk4"]:
        raise ValueError("rk4 integrates rates, not increments: use integrate_gyro")
    out = np.empty((dtheta.shape[0], 4))
    _integrate_increments(q0 / np.linalg.norm(q0), dtheta, code, out)
    return out
