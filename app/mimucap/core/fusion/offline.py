"""Offline orientation estimate of a recording: forward EKF plus Rauch-Tung-Striebel smoother.

The forward pass is the online filter (:mod:`ekf`) storing, per sample, the predicted state
``x_{k|k-1}``, the predicted and updated covariances and the transition block ``A = −R·dt`` of
``Φ = [[I, A], [0, I]]``. The backward pass runs over the error state
``[δθ (world frame, rad), δb (rad/s)]``:

``C_k = P_{k|k} Φ_{k+1}ᵀ P_{k+1|k}⁻¹``,
``δx_k = C_k · (x_{k+1|N} ⊖ x_{k+1|k})`` with ``q_a ⊖ q_b = log(q_a ⊗ q_b⁻¹)`` and the bias
difference, and ``x_{k|N} = x_{k|k} ⊕ δx_k`` (``q ← exp(δθ) ⊗ q``, ``b ← b + δb``).

So every sample uses the whole recording: gyro bias learned at the end of a recording and
heading corrections after a magnetic disturbance reach back in time. Memory: about 0.7 kB per
sample and sensor during the call.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from mimucap.core.fusion.ekf import FusionResult, OrientationEKF, shaped_inputs
from mimucap.core.fusion.params import DEFAULT_FUSION_PARAMS, FusionParams
from mimucap.core.fusion.state import FusionState
from mimucap.core.fusion.jit import JIT_OPTIONS
from mimucap.core.fusion.propagation import exp_quat, quat_multiply, quat_normalise


@njit(**JIT_OPTIONS)
def _solve6(P, e, out):
    """``out = P⁻¹ e`` for a symmetric positive definite 6×6 ``P`` (Cholesky); False if not PD."""
    L = np.zeros((6, 6))
    for i in range(6):
        for j in range(i + 1):
            s = P[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                if s <= 0.0:
                    return False
                L[i, i] = math.sqrt(s)
            else:
                L[i, j] = s / L[j, j]
    y = np.empty(6)
    for i in range(6):
        s = e[i]
        for k in range(i):
            s -= L[i, k] * y[k]
        y[i] = s / L[i, i]
    for i in range(5, -1, -1):
        s = y[i]
        for k in range(i + 1, 6):
            s -= L[k, i] * out[k]
        out[i] = s / L[i, i]
    return True


@njit(**JIT_OPTIONS)
def rts_smooth(q_post, b_post, q_prior, b_prior, p_prior, p_post, a_blk, out_q, out_b):
    """Backward RTS pass over one sensor's stored forward run (shapes in the module docstring)."""
    n = q_post.shape[0]
    for i in range(4):
        out_q[n - 1, i] = q_post[n - 1, i]
    for i in range(3):
        out_b[n - 1, i] = b_post[n - 1, i]
    e = np.empty(6)
    v = np.empty(6)
    u = np.empty(6)
    for k in range(n - 2, -1, -1):
        if not (math.isfinite(q_post[k, 0]) and math.isfinite(out_q[k + 1, 0])
                and math.isfinite(q_prior[k + 1, 0])):
            for i in range(4):
                out_q[k, i] = q_post[k, i]
            for i in range(3):
                out_b[k, i] = b_post[k, i]
            continue
        # e = x_{k+1|N} ⊖ x_{k+1|k}
        sw, sx, sy, sz = out_q[k + 1, 0], out_q[k + 1, 1], out_q[k + 1, 2], out_q[k + 1, 3]
        dw, dx_, dy_, dz_ = quat_multiply(sw, sx, sy, sz, q_prior[k + 1, 0], -q_prior[k + 1, 1],
                                          -q_prior[k + 1, 2], -q_prior[k + 1, 3])
        if dw < 0.0:
            dw, dx_, dy_, dz_ = -dw, -dx_, -dy_, -dz_
        nv = math.sqrt(dx_ * dx_ + dy_ * dy_ + dz_ * dz_)
        scale = 2.0 * math.atan2(nv, dw) / nv if nv > 1e-12 else 2.0
        e[0], e[1], e[2] = scale * dx_, scale * dy_, scale * dz_
        for i in range(3):
            e[3 + i] = out_b[k + 1, i] - b_prior[k + 1, i]
        if not _solve6(p_prior[k + 1], e, v):
            for i in range(4):
                out_q[k, i] = q_post[k, i]
            for i in range(3):
                out_b[k, i] = b_post[k, i]
            continue
        # u = Φᵀ v = [v_θ ; Aᵀ v_θ + v_b]
        for i in range(3):
            u[i] = v[i]
            u[3 + i] = (v[3 + i] + a_blk[k + 1, 0, i] * v[0] + a_blk[k + 1, 1, i] * v[1]
                        + a_blk[k + 1, 2, i] * v[2])
        P = p_post[k]
        d0 = d1 = d2 = 0.0
        for j in range(6):
            d0 += P[0, j] * u[j]
            d1 += P[1, j] * u[j]
            d2 += P[2, j] * u[j]
        ew, ex, ey, ez = exp_quat(d0, d1, d2)
        w, x, y, z = quat_multiply(ew, ex, ey, ez, q_post[k, 0], q_post[k, 1], q_post[k, 2],
                                   q_post[k, 3])
        w, x, y, z = quat_normalise(w, x, y, z)
        out_q[k, 0], out_q[k, 1], out_q[k, 2], out_q[k, 3] = w, x, y, z
        for i in range(3):
            s = 0.0
            for j in range(6):
                s += P[3 + i, j] * u[j]
            out_b[k, i] = b_post[k, i] + s


def fuse_offline(t_s, gyr_rad_s, acc_m_s2=None, mag_uT=None, *,
                 params: FusionParams = DEFAULT_FUSION_PARAMS, algorithm: str = "ekf-taylor3",
                 use_mag: bool = True, state: FusionState | None = None) -> FusionResult:
    """Smoothed orientation of a whole recording (same inputs and outputs as :func:`ekf.fuse`).

    Sensors are smoothed one after the other, so the forward-pass storage (about 0.7 kB per
    sample) is held for one sensor at a time. The flags and counters are those of the forward
    pass. ``state`` (one sensor's) is the prior at the first sample, e.g. what a filter that ran
    before the recording had learnt (gyro bias, heading, their covariance); a fresh filter
    starts when it is None.
    """
    single, t, gyr3, acc3, mag3 = shaped_inputs(t_s, gyr_rad_s, acc_m_s2, mag_uT)
    n_sensors, n = gyr3.shape[0], gyr3.shape[1]
    out_q = np.empty((n_sensors, n, 4))
    out_b = np.empty((n_sensors, n, 3))
    flags = np.zeros((n_sensors, n), dtype=np.uint8)
    counters = []
    if state is not None and n_sensors != 1:
        raise ValueError("a prior state is given for one sensor at a time")
    for s in range(n_sensors):
        store = (np.empty((1, n, 4)), np.empty((1, n, 3)), np.empty((1, n, 6, 6)),
                 np.empty((1, n, 6, 6)), np.empty((1, n, 3, 3)))
        ekf = OrientationEKF(params, algorithm=algorithm, use_mag=use_mag, state=state)
        forward = ekf.update_batch(t[s], gyr3[s], None if acc3 is None else acc3[s],
                                   None if mag3 is None else mag3[s], _store=store)
        if n:
            rts_smooth(forward.q_world_from_sensor, forward.bias_rad_s, store[0][0], store[1][0],
                       store[2][0], store[3][0], store[4][0], out_q[s], out_b[s])
        flags[s] = forward.flags
        counters.append(forward.counters[0])
    if single:
        return FusionResult(out_q[0], out_b[0], flags[0], tuple(counters))
    return FusionResult(out_q, out_b, flags, tuple(counters))
