"""A hard-iron offset that appears during a recording, learned from the field samples themselves.

A magnet or a phone fixed to the sensor adds a constant field ``o`` (µT, sensor frame) to every
sample: ``m = R_world_from_sensorᵀ·m_earth + o``. The calibration made beforehand does not
know it, and the field then fails the norm and dip checks (:mod:`.disturbance`) at most
orientations, or, when the offset is small, passes them with a heading error that depends on
the orientation. Yet such a field still holds the heading: once ``o`` is known, ``m − o`` is
the earth's field again.

The offset is found as in the attitude-independent calibration of Crassidis, Lai, Harman,
"Real-time attitude-independent three-axis magnetometer calibration" (2005): the corrected
field has a constant norm ``B``, so ``‖m‖² = 2·m·o + (B² − ‖o‖²)``, linear in ``o`` and
``c₁ = B² − ‖o‖²``. A second equation uses the tilt, which the accelerometer gives without the
magnetometer: with ``u`` the world's up direction in the sensor frame, the corrected field's
vertical component is constant, ``u·m = u·o + c₂``. Both are fitted by least squares with
exponential forgetting (time constant ``mag_offset_tau_s``) over every valid field sample;
each equation is scaled to read in µT (the first divided by ``2·B_ref``).

The fit's offset is used only when all of these hold (otherwise the current choice stays):

* the fit is well conditioned: the sensor turned enough for the offset's standard deviation
  (residual rms times the root of the trace of the offset block of the inverse normal matrix)
  to stay below ``mag_offset_std_uT``;
* the model holds: the residual rms is at most ``mag_offset_fit_uT`` (a field that changes
  with position, like a magnet lying beside the path, does not fit a constant offset);
* the field it leaves is the earth's: the fitted norm ``√(c₁ + ‖o‖²)`` and dip
  ``asin(−c₂ / B)`` agree with the learned reference within ``mag_norm_tol`` and
  ``mag_dip_tol_rad``.

Then the offset is applied if it explains at least ``mag_offset_min_uT`` of the field's
variation (the rms by which the residual of the fit without an offset, ``c₁`` and ``c₂``
alone, exceeds that of the fit with it), else the calibration stands (no offset). Below
that the calibration's own residue and the field's variation over the room are as large as
the offset, and a fitted offset would follow them. So an attached magnet is learned within
a few time constants of turning the sensor, and forgotten the same way once it is gone.

The fit is updated with every sample and the choice made every :data:`DECIDE_INTERVAL_S`.
State in the filter's auxiliary vector (:mod:`.state`, ``AX_HI_*``): the offset in use
(``AX_HI_ON`` whether one is), the time since the last choice, the forgetting sums: weight ``W``, ``Σy²``, ``Σa·y`` (5,) and
the upper triangle of ``Σa·aᵀ`` (15,), with the unknowns ``[o (3), c₁, c₂]``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from mimucap.core.fusion.disturbance import lowpass_gain
from mimucap.core.fusion.jit import JIT_OPTIONS, LAYOUT_FINGERPRINT, refresh_if_stale
from mimucap.core.fusion.params import (
    PI_MAG_DIP_TOL, PI_MAG_NORM_TOL, PI_MAG_OFFSET_FIT, PI_MAG_OFFSET_MIN, PI_MAG_OFFSET_STD,
    PI_MAG_OFFSET_TAU,
)
from mimucap.core.fusion.state import (
    AX_HI_G, AX_HI_H, AX_HI_ON, AX_HI_O, AX_HI_T, AX_HI_W, AX_HI_YY, AX_MAG_DIP_REF, AX_MAG_NORM_REF,
    AX_MAG_REF_OK, AX_N_MAG_OFFSET_NEW, HI_UNKNOWNS,
)


#: Time (s) between two decisions on the offset: far below the fit's forgetting time.
DECIDE_INTERVAL_S = 0.05


@njit(inline="always", **JIT_OPTIONS)
def _tri(i, j):
    """Index of entry (i, j) of a symmetric 5×5 matrix in its packed upper triangle."""
    if i > j:
        i, j = j, i
    return i * HI_UNKNOWNS - i * (i - 1) // 2 + (j - i)


@njit(inline="always", **JIT_OPTIONS)
def _add_equation(aux, a, y):
    """Add the equation ``a·θ = y`` (``a`` (5,)) to the forgetting sums."""
    for i in range(HI_UNKNOWNS):
        aux[AX_HI_G + i] += a[i] * y
        for j in range(i, HI_UNKNOWNS):
            aux[AX_HI_H + _tri(i, j)] += a[i] * a[j]
    aux[AX_HI_YY] += y * y
    aux[AX_HI_W] += 1.0


@njit(inline="always", **JIT_OPTIONS)
def _cholesky(H, n, L):
    """Lower Cholesky factor of the leading ``n×n`` block of ``H`` into ``L``; False if that
    block is not positive definite (to working precision)."""
    for i in range(n):
        for j in range(i + 1):
            s = H[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                if s <= 1e-12 * max(H[i, i], 1e-300):
                    return False
                L[i, i] = math.sqrt(s)
            else:
                L[i, j] = s / L[j, j]
    return True


@njit(inline="always", **JIT_OPTIONS)
def _solve(L, n, g, out, y):
    """``out = H⁻¹ g`` from the Cholesky factor ``L`` of ``H`` (leading ``n×n``); ``y`` scratch."""
    for i in range(n):
        s = g[i]
        for k in range(i):
            s -= L[i, k] * y[k]
        y[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):
        s = y[i]
        for k in range(i + 1, n):
            s -= L[k, i] * out[k]
        out[i] = s / L[i, i]


@njit(**JIT_OPTIONS)
def _decide(p, aux, mats, vecs):
    """Fit the offset to the forgetting sums and choose the offset in use (module docstring).
    ``mats`` (3, 5, 5) and ``vecs`` (8, 5) are scratch space."""
    n = HI_UNKNOWNS
    H, L, L0 = mats[0], mats[1], mats[2]
    g, theta, y, e, col, g0, theta0 = vecs[0], vecs[1], vecs[2], vecs[3], vecs[4], vecs[6], vecs[7]
    for i in range(n):
        g[i] = aux[AX_HI_G + i]
        for j in range(n):
            H[i, j] = aux[AX_HI_H + _tri(i, j)]
    if not _cholesky(H, n, L):
        return
    _solve(L, n, g, theta, y)
    w = aux[AX_HI_W]
    s1 = aux[AX_HI_YY]
    for i in range(n):
        s1 -= theta[i] * g[i]
    rms = math.sqrt(max(s1, 0.0) / w)
    if rms > p[PI_MAG_OFFSET_FIT]:
        return
    # the offset's variances: the first three diagonal entries of H⁻¹ (times the rms²)
    trace = 0.0
    for k in range(3):
        for i in range(n):
            e[i] = 0.0
        e[k] = 1.0
        _solve(L, n, e, col, y)
        trace += col[k]
    if rms * math.sqrt(max(trace, 0.0)) > p[PI_MAG_OFFSET_STD]:
        return
    ox, oy, oz = theta[0], theta[1], theta[2]
    norm2 = theta[3] + ox * ox + oy * oy + oz * oz
    if not norm2 > 0.0:
        return
    norm = math.sqrt(norm2)
    sin_dip = -theta[4] / norm
    ref_n = aux[AX_MAG_NORM_REF]
    if (abs(norm - ref_n) > p[PI_MAG_NORM_TOL] * ref_n or abs(sin_dip) > 1.0
            or abs(math.asin(sin_dip) - aux[AX_MAG_DIP_REF]) > p[PI_MAG_DIP_TOL]):
        return
    # the same data without an offset: c₁ and c₂ alone (the trailing 2×2 block)
    for i in range(2):
        g0[i] = g[3 + i]
        for j in range(2):
            H[i, j] = H[3 + i, 3 + j]
    if not _cholesky(H, 2, L0):
        return
    _solve(L0, 2, g0, theta0, y)
    s0 = aux[AX_HI_YY] - theta0[0] * g0[0] - theta0[1] * g0[1]
    if math.sqrt(max(s0 - s1, 0.0) / w) >= p[PI_MAG_OFFSET_MIN]:
        if aux[AX_HI_ON] == 0.0:
            aux[AX_N_MAG_OFFSET_NEW] += 1.0
        aux[AX_HI_ON] = 1.0
        aux[AX_HI_O], aux[AX_HI_O + 1], aux[AX_HI_O + 2] = ox, oy, oz
    else:
        reset_offset(aux)


@njit(inline="always", **JIT_OPTIONS)
def reset_offset(aux):
    """No offset in use (the calibration stands); the fit goes on."""
    aux[AX_HI_ON] = 0.0
    aux[AX_HI_O] = aux[AX_HI_O + 1] = aux[AX_HI_O + 2] = 0.0


@njit(**JIT_OPTIONS)
def offset_update(p, aux, mx, my, mz, ux, uy, uz, dt, mats, vecs):
    """Feed one valid field sample ``m`` (µT, sensor frame, before any offset) with the world's
    up direction ``u`` in the sensor frame (unit vector, from the current attitude) and the
    time ``dt`` (s) since the previous sample; update the offset in use (``AX_HI_*``).
    ``mats`` (3, 5, 5) and ``vecs`` (8, 5) are scratch space (:func:`scratch`).

    Does nothing while the hard-iron tracking is off (``mag_offset_tau_s`` 0) or before the
    filter has a field reference (norm and dip) to compare the fit with.
    """
    tau = p[PI_MAG_OFFSET_TAU]
    if tau <= 0.0 or aux[AX_MAG_REF_OK] <= 0.0:
        return
    keep = 1.0 - lowpass_gain(dt, tau)
    for i in range(AX_HI_W, AX_HI_H + HI_UNKNOWNS * (HI_UNKNOWNS + 1) // 2):
        aux[i] *= keep
    scale = 1.0 / aux[AX_MAG_NORM_REF]
    a = vecs[5]
    a[0], a[1], a[2], a[3], a[4] = mx * scale, my * scale, mz * scale, 0.5 * scale, 0.0
    _add_equation(aux, a, 0.5 * (mx * mx + my * my + mz * mz) * scale)
    a[0], a[1], a[2], a[3], a[4] = ux, uy, uz, 0.0, 1.0
    _add_equation(aux, a, ux * mx + uy * my + uz * mz)
    # two equations a sample; decide once the sums hold at least half their steady weight, and
    # then every DECIDE_INTERVAL_S (the fit changes over the forgetting time, not per sample)
    aux[AX_HI_T] += dt
    if dt > 0.0 and aux[AX_HI_W] >= tau / dt and aux[AX_HI_T] >= DECIDE_INTERVAL_S:
        aux[AX_HI_T] = 0.0
        _decide(p, aux, mats, vecs)


@njit(inline="always", **JIT_OPTIONS)
def scratch():
    """The scratch arrays :func:`offset_update` works in (allocated once per block)."""
    return np.empty((3, HI_UNKNOWNS, HI_UNKNOWNS)), np.empty((8, HI_UNKNOWNS))


@njit(**JIT_OPTIONS)
def _compiled_layout():
    return LAYOUT_FINGERPRINT


# last statement of the module: every kernel above exists when a stale cache is emptied
refresh_if_stale(globals(), _compiled_layout())
