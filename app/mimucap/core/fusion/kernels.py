"""Numba kernels of the error-state EKF (one sensor, a block of samples, state updated in
place) and of its Rauch-Tung-Striebel backward pass (:mod:`.offline` describes it).

These are the only compiled kernels of the fusion; :mod:`.aot` chooses whether a process runs
them from the module compiled ahead of time at installation or through numba's JIT.

Error state ``x = [δθ (rad, world frame), δb (rad/s, sensor frame)]`` with the true
orientation ``q_world_from_sensor = exp(δθ) ⊗ q`` and true bias ``b + δb``.

* Propagation: ``q ← q ⊗ Δq(ω − b)`` (:mod:`propagation`), and for the error state
  ``Φ = [[I, −R·dt], [0, I]]`` with ``R = R_world_from_sensor``. This is the
  ``Fc = [[−[ω×], −I], [0, 0]]`` written for the world-frame error ``δθ_w = R·δθ_sensor``
  of Zhang, Gao, Zhou, "Head attitude sensing algorithm based on IMU in VR
  device" (the ``−[ω×]`` term vanishes in that frame); process noise ``Q = diag(σ_g²·dt·I,
  σ_bw²·dt·I)`` plus the scale-factor term ``k²·‖ω‖²·dt`` on the attitude.
* Gravity: the specific force rotated into the world, ``R·a``, is low-passed (time constant
  ``acc_lowpass_tau_s``; the low-pass state turns with every attitude correction) so that
  linear accelerations average out; its direction ``u ≈ e_z + e_z × δθ`` gives
  ``u_x = −δθ_y`` and ``u_y = δθ_x`` (two scalar updates, noise model in :mod:`disturbance`).
* Heading: the tilt-compensated magnetometer ``m_w = R·m`` has the heading residual
  ``atan2(m_w,x, m_w,y) − declination = δθ_z + h_x·δθ_x + h_y·δθ_y`` (north along +y): the tilt
  compensation carries a tilt error into the heading, amplified by ``tan(dip)`` about the axis
  perpendicular to the field (:func:`heading_tilt_jacobian`). Its Kalman gain rows of the tilt
  states are set to zero (Joseph-form covariance update), so the magnetometer corrects the
  heading and the bias, never the tilt; the tilt terms of the measurement row weigh the
  heading by the tilt's uncertainty and correlate the two, so a tilt error the accelerometer
  later corrects takes the heading error it caused with it. Its noise grows with the field's distance from the
  learned reference (:func:`~.disturbance.heading_noise_var`). A hard-iron offset that
  appeared during the recording (a magnet fixed to the sensor) is learned from the field
  samples and removed from each before it is judged (:mod:`.hard_iron`).
* Rest: zero-rate update of the bias, measurement ``ω_raw = b``.
* All updates of one sample share one linearisation point (sequential scalar updates of the
  error state), which is then injected once: ``q ← exp(δθ) ⊗ q``, ``b ← b + δb``.

The kernel optionally stores what the RTS smoother needs (:mod:`offline`): the predicted
state and covariance, the posterior covariance and the ``−R·dt`` block of ``Φ`` per sample.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from mimucap.core.fusion.disturbance import (
    acc_noise_var, heading_noise_var, lowpass_gain, mag_accept, rest_update,
)
from mimucap.core.fusion.hard_iron import offset_update, scratch
from mimucap.core.fusion.jit import JIT_OPTIONS, LAYOUT_FINGERPRINT, refresh_if_stale
from mimucap.core.fusion.params import (
    PI_ACC_LP_TAU, PI_ACC_RANGE, PI_BIAS_MAX, PI_BIAS_WALK, PI_GAP_RATE, PI_GYR_NOISE, PI_GYR_RANGE,
    PI_GYR_SCALE_NOISE, PI_DECLINATION, PI_INIT_BIAS, PI_INIT_HEADING, PI_INIT_TILT, PI_MAG_RANGE, PI_MAX_GAP,
    PI_METHOD, PI_REST_BIAS_NOISE, PI_USE_ACC, PI_USE_MAG, PI_CORRECT,
)
from mimucap.core.fusion.propagation import (
    exp_quat, quat_multiply, quat_normalise, step_exact, step_rk4, step_taylor3,
)
from mimucap.core.fusion.state import (
    AX_AWLP_INIT, AX_AWLP_X, AX_GYR_PREV_X, AX_HAVE_PREV, AX_INIT, AX_LP_INIT, AX_MAG_REF_OK, AX_N_ACC_MISSING,
    AX_N_ACC_REJECTED, AX_N_MAG_MISSING, AX_N_MAG_REJECTED, AX_N_REST, AX_N_SAMPLES,
    AX_N_SKIPPED, AX_REST_T, AX_T_LAST, AX_HI_ON, AX_HI_O, AX_N_MAG_OFFSET, FLAG_ACC_MISSING,
    FLAG_ACC_REJECTED, FLAG_MAG_MISSING, FLAG_MAG_OFFSET, FLAG_MAG_REJECTED, FLAG_REST, FLAG_SKIPPED,
    FLAG_UNINITIALISED,
)


@njit(inline="always", **JIT_OPTIONS)
def _vector_sample(values, k, range2):
    """Row ``k`` of ``values`` (N, 3), its squared norm, and whether it is usable: finite,
    non-zero and with a squared norm within ``range2`` (NaN compares False)."""
    x, y, z = values[k, 0], values[k, 1], values[k, 2]
    n2 = x * x + y * y + z * z
    return x, y, z, n2, n2 > 1e-6 and n2 <= range2


@njit(inline="always", **JIT_OPTIONS)
def _rotmat(qw, qx, qy, qz, r):
    """Fill ``r`` (3, 3) with ``R_world_from_sensor`` of a unit quaternion."""
    xx, yy, zz = qx * qx, qy * qy, qz * qz
    xy, xz, yz = qx * qy, qx * qz, qy * qz
    wx, wy, wz = qw * qx, qw * qy, qw * qz
    r[0, 0] = 1.0 - 2.0 * (yy + zz)
    r[0, 1] = 2.0 * (xy - wz)
    r[0, 2] = 2.0 * (xz + wy)
    r[1, 0] = 2.0 * (xy + wz)
    r[1, 1] = 1.0 - 2.0 * (xx + zz)
    r[1, 2] = 2.0 * (yz - wx)
    r[2, 0] = 2.0 * (xz - wy)
    r[2, 1] = 2.0 * (yz + wx)
    r[2, 2] = 1.0 - 2.0 * (xx + yy)


@njit(**JIT_OPTIONS)
def _quat_from_rows(ex, ey, ez, nx, ny, nz, ux, uy, uz):
    """Quaternion of ``R_world_from_sensor`` whose rows are east, north, up (sensor coords)."""
    m00, m01, m02 = ex, ey, ez
    m10, m11, m12 = nx, ny, nz
    m20, m21, m22 = ux, uy, uz
    tr = m00 + m11 + m22
    if tr > 0.0:
        s = 2.0 * math.sqrt(1.0 + tr)
        w, x, y, z = 0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s
    elif m00 > m11 and m00 > m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        w, x, y, z = (m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s
    elif m11 > m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        w, x, y, z = (m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s
    else:
        s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
        w, x, y, z = (m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s
    return quat_normalise(w, x, y, z)


@njit(**JIT_OPTIONS)
def align(ax, ay, az, mx, my, mz, use_mag, declination):
    """Initial ``q_world_from_sensor`` from one accelerometer (and magnetometer) sample.

    Up is the accelerometer direction; east is ``m × up`` (magnetic east), turned by the
    declination (rad) into true east. Without a usable magnetometer the heading is arbitrary:
    the sensor x axis is put in the world x-z plane.
    """
    na = math.sqrt(ax * ax + ay * ay + az * az)
    ux, uy, uz = ax / na, ay / na, az / na
    ex = ey = ez = 0.0
    ne = 0.0
    if use_mag:
        ex, ey, ez = my * uz - mz * uy, mz * ux - mx * uz, mx * uy - my * ux
        ne = math.sqrt(ex * ex + ey * ey + ez * ez)
    if ne < 1e-6:
        # project the sensor x (or y) axis onto the horizontal plane
        d = ux
        ex, ey, ez = 1.0 - d * ux, -d * uy, -d * uz
        ne = math.sqrt(ex * ex + ey * ey + ez * ez)
        if ne < 1e-3:
            d = uy
            ex, ey, ez = -d * ux, 1.0 - d * uy, -d * uz
            ne = math.sqrt(ex * ex + ey * ey + ez * ez)
    ex, ey, ez = ex / ne, ey / ne, ez / ne
    nx, ny, nz = uy * ez - uz * ey, uz * ex - ux * ez, ux * ey - uy * ex
    w, x, y, z = _quat_from_rows(ex, ey, ez, nx, ny, nz, ux, uy, uz)
    if use_mag and declination != 0.0:
        # q_true_from_magnetic = Rz(−declination)
        h = -0.5 * declination
        w, x, y, z = quat_multiply(math.cos(h), 0.0, 0.0, math.sin(h), w, x, y, z)
    return w, x, y, z


@njit(inline="always", **JIT_OPTIONS)
def _scalar_update(P, dx, c, i, resid, var):
    """Kalman update of error-state component ``i`` measured with residual and variance.

    ``dx`` accumulates the error-state estimate (sequential updates share one linearisation
    point); ``c`` (6,) is scratch space.
    """
    r = resid - dx[i]
    s = P[i, i] + var
    if s <= 0.0:
        return
    for a in range(6):
        c[a] = P[a, i]
    inv = 1.0 / s
    for a in range(6):
        dx[a] += c[a] * inv * r
    for a in range(6):
        ca = c[a] * inv
        for b in range(a, 6):
            v = P[a, b] - ca * c[b]
            P[a, b] = v
            P[b, a] = v


@njit(inline="always", **JIT_OPTIONS)
def _heading_update(P, dx, c, resid, var, h_x, h_y):
    """Heading update of measurement row ``H = [h_x, h_y, 1, 0, 0, 0]`` whose gain on the tilt
    states is zero (Joseph form, so the covariance stays that of the gain actually applied).

    ``h_x``, ``h_y`` (dimensionless): how the tilt-compensated heading moves with the tilt
    errors (:func:`heading_tilt_jacobian`). The tilt states are "considered" as in the
    Schmidt-Kalman filter (S. F. Schmidt, "Application of state-space methods to navigation
    problems", Advances in Control Systems 3, 1966): never corrected from the magnetometer,
    their uncertainty enters the innovation's variance and their correlation with the other
    states is updated, so later gravity updates correct the heading error a tilt error caused.
    """
    r = resid - dx[2] - h_x * dx[0] - h_y * dx[1]
    for a in range(6):
        c[a] = P[a, 2] + h_x * P[a, 0] + h_y * P[a, 1]
    s = c[2] + h_x * c[0] + h_y * c[1] + var
    if s <= 0.0:
        return
    inv = 1.0 / s
    for a in range(2, 6):
        dx[a] += c[a] * inv * r
    for a in range(6):
        ca = c[a] * inv
        for b in range(max(a, 2), 6):
            v = P[a, b] - ca * c[b]
            P[a, b] = v
            P[b, a] = v


@njit(inline="always", **JIT_OPTIONS)
def heading_tilt_jacobian(mwx, mwy, mwz):
    """``(h_x, h_y)``: derivatives of the heading ``atan2(m_w,x, m_w,y)`` of the field ``m_w``
    (world frame, µT) with respect to the world-frame tilt errors ``δθ_x``, ``δθ_y`` (rad/rad).

    With the true orientation ``exp(δθ) ⊗ q``, the estimate sees the field turned back,
    ``m_w ≈ m − δθ × m``, so ``δψ = δθ_z − (m_z / m_h²)·(m_x·δθ_x + m_y·δθ_y)``, ``m_h`` the
    horizontal field: a tilt error about the horizontal axis perpendicular to the field turns
    the heading by ``tan(dip)`` times itself (2.7 at a 70° dip). Zero for a horizontal field.
    """
    k = mwz / (mwx * mwx + mwy * mwy)
    return -k * mwx, -k * mwy


@njit(inline="always", **JIT_OPTIONS)
def _rotate_lowpass(aux, dx):
    """Rotate the low-passed world-frame specific force with an attitude correction δθ."""
    x, y, z = aux[AX_AWLP_X], aux[AX_AWLP_X + 1], aux[AX_AWLP_X + 2]
    aux[AX_AWLP_X] = x + dx[1] * z - dx[2] * y
    aux[AX_AWLP_X + 1] = y + dx[2] * x - dx[0] * z
    aux[AX_AWLP_X + 2] = z + dx[0] * y - dx[1] * x


@njit(inline="always", **JIT_OPTIONS)
def _inject(q, b, dx, bias_max):
    """Apply the error state to the nominal state and reset it to zero."""
    n2 = dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]
    if n2 < 1e-6:
        # exp by its series: error below |δθ|⁶/46080 ≈ 2e-23
        s = 0.5 - n2 / 48.0 + n2 * n2 / 3840.0
        ew, ex, ey, ez = 1.0 - n2 / 8.0 + n2 * n2 / 384.0, s * dx[0], s * dx[1], s * dx[2]
    else:
        ew, ex, ey, ez = exp_quat(dx[0], dx[1], dx[2])
    w, x, y, z = quat_multiply(ew, ex, ey, ez, q[0], q[1], q[2], q[3])
    w, x, y, z = quat_normalise(w, x, y, z)
    q[0], q[1], q[2], q[3] = w, x, y, z
    for i in range(3):
        v = b[i] + dx[3 + i]
        if v > bias_max:
            v = bias_max
        elif v < -bias_max:
            v = -bias_max
        b[i] = v
    for i in range(6):
        dx[i] = 0.0


@njit(inline="always", **JIT_OPTIONS)
def _store_prior(k, q, b, P, A, use_a, st_q, st_b, st_pp, st_a):
    """Keep sample ``k``'s prior state for the smoother: q (4,), bias (3,), covariance (6, 6)
    and the attitude block of the transition (3, 3), zero when ``use_a`` is false."""
    for i in range(4):
        st_q[k, i] = q[i]
    for i in range(3):
        st_b[k, i] = b[i]
    for i in range(6):
        for j in range(6):
            st_pp[k, i, j] = P[i, j]
    for i in range(3):
        for j in range(3):
            st_a[k, i, j] = A[i, j] if use_a else 0.0


@njit(**JIT_OPTIONS)
def ekf_block(p, t, gyr, acc, mag, q, b, P, aux, out_q, out_bias, out_flags,
              store, st_q, st_b, st_pp, st_pu, st_a):
    """Run the filter over ``N`` samples of one sensor; ``q, b, P, aux`` are updated in place.

    ``t`` (N,) s; ``gyr`` (N, 3) rad/s; ``acc`` (N, 3) m/s² or (0, 3) when absent; ``mag``
    (N, 3) µT or (0, 3). Outputs per sample: ``out_q`` (N, 4) ``q_world_from_sensor`` (NaN
    before initialisation), ``out_bias`` (N, 3), ``out_flags`` (N,) uint8. When ``store``,
    ``st_q`` (N, 4) / ``st_b`` (N, 3) receive the predicted state, ``st_pp`` / ``st_pu``
    (N, 6, 6) the predicted and updated covariance and ``st_a`` (N, 3, 3) the ``−R·dt``
    block of the transition from the previous sample.
    """
    n = t.shape[0]
    has_acc = acc.shape[0] == n and p[PI_USE_ACC] > 0.0
    has_mag = mag.shape[0] == n and p[PI_USE_MAG] > 0.0
    correct = p[PI_CORRECT] > 0.0
    method = int(p[PI_METHOD])
    gyr_range2 = p[PI_GYR_RANGE] ** 2
    acc_range2 = p[PI_ACC_RANGE] ** 2
    mag_range2 = p[PI_MAG_RANGE] ** 2
    q_gyr = p[PI_GYR_NOISE] ** 2
    q_scale = p[PI_GYR_SCALE_NOISE] ** 2
    q_bias = p[PI_BIAS_WALK] ** 2
    bias_max = p[PI_BIAS_MAX]
    declination = p[PI_DECLINATION]
    var_rest = p[PI_REST_BIAS_NOISE] ** 2
    R = np.empty((3, 3))
    A = np.zeros((3, 3))
    M = np.empty((3, 3))
    T = np.empty((3, 3))
    dx = np.zeros(6)
    c = np.empty(6)
    hi_mats, hi_vecs = scratch()
    for k in range(n):
        flags = 0
        aux[AX_N_SAMPLES] += 1.0
        gx, gy, gz = gyr[k, 0], gyr[k, 1], gyr[k, 2]
        g2 = gx * gx + gy * gy + gz * gz
        gyr_ok = g2 <= gyr_range2 and math.isfinite(t[k])  # False for NaN
        acc_ok = False
        ax = ay = az = 0.0
        if has_acc:
            ax, ay, az, _a2, acc_ok = _vector_sample(acc, k, acc_range2)
            if not acc_ok:
                flags |= FLAG_ACC_MISSING
                aux[AX_N_ACC_MISSING] += 1.0
        mag_ok = False
        mx = my = mz = 0.0
        if has_mag:
            mx, my, mz, m2, mag_ok = _vector_sample(mag, k, mag_range2)
            if not mag_ok:
                flags |= FLAG_MAG_MISSING
                aux[AX_N_MAG_MISSING] += 1.0
        for i in range(3):
            for j in range(3):
                A[i, j] = 0.0

        if aux[AX_INIT] == 0.0:
            if gyr_ok and (acc_ok or not has_acc):
                if acc_ok:
                    w, x, y, z = align(ax, ay, az, mx, my, mz, mag_ok, p[PI_DECLINATION])
                else:
                    w, x, y, z = 1.0, 0.0, 0.0, 0.0
                q[0], q[1], q[2], q[3] = w, x, y, z
                for i in range(6):
                    for j in range(6):
                        P[i, j] = 0.0
                P[0, 0] = P[1, 1] = p[PI_INIT_TILT] ** 2
                P[2, 2] = p[PI_INIT_HEADING] ** 2
                P[3, 3] = P[4, 4] = P[5, 5] = p[PI_INIT_BIAS] ** 2
                aux[AX_INIT] = 1.0
                aux[AX_T_LAST] = t[k]
                aux[AX_HAVE_PREV] = 0.0
                aux[AX_LP_INIT] = 0.0
                aux[AX_REST_T] = 0.0
                aux[AX_MAG_REF_OK] = 0.0
                aux[AX_AWLP_INIT] = 0.0
                rest_update(p, aux, gx, gy, gz, ax, ay, az, acc_ok, 0.0)
                if mag_ok:
                    _rotmat(q[0], q[1], q[2], q[3], R)
                    mwx = R[0, 0] * mx + R[0, 1] * my + R[0, 2] * mz
                    mwy = R[1, 0] * mx + R[1, 1] * my + R[1, 2] * mz
                    mwz = R[2, 0] * mx + R[2, 1] * my + R[2, 2] * mz
                    mag_accept(p, aux, math.sqrt(m2), math.atan2(-mwz, math.hypot(mwx, mwy)), 0.0, 0.0)
                if store:
                    _store_prior(k, q, b, P, A, False, st_q, st_b, st_pp, st_a)
            else:
                flags |= FLAG_UNINITIALISED
                if not gyr_ok:
                    flags |= FLAG_SKIPPED
                    aux[AX_N_SKIPPED] += 1.0
                for i in range(4):
                    out_q[k, i] = np.nan
                for i in range(3):
                    out_bias[k, i] = b[i]
                out_flags[k] = flags
                if store:
                    for i in range(4):
                        st_q[k, i] = np.nan
                    for i in range(3):
                        st_b[k, i] = np.nan
                    for i in range(6):
                        for j in range(6):
                            st_pp[k, i, j] = np.nan
                            st_pu[k, i, j] = np.nan
                    for i in range(3):
                        for j in range(3):
                            st_a[k, i, j] = 0.0
                continue
        else:
            dt = t[k] - aux[AX_T_LAST]
            if not gyr_ok or not dt > 0.0:
                # skipped: no propagation and no correction, the state is held
                flags |= FLAG_SKIPPED
                aux[AX_N_SKIPPED] += 1.0
                for i in range(4):
                    out_q[k, i] = q[i]
                for i in range(3):
                    out_bias[k, i] = b[i]
                out_flags[k] = flags
                if store:
                    _store_prior(k, q, b, P, A, False, st_q, st_b, st_pp, st_a)
                    for i in range(6):
                        for j in range(6):
                            st_pu[k, i, j] = P[i, j]
                continue
            aux[AX_T_LAST] = t[k]
            wx, wy, wz = gx - b[0], gy - b[1], gz - b[2]
            if dt > p[PI_MAX_GAP]:
                # gap: nothing is known about the rotation in between
                v = (p[PI_GAP_RATE] * dt) ** 2
                P[0, 0] += v
                P[1, 1] += v
                P[2, 2] += v
                for i in range(3, 6):
                    P[i, i] += q_bias * dt
                aux[AX_HAVE_PREV] = 0.0
                aux[AX_AWLP_INIT] = 0.0
                propagated = False
            else:
                propagated = True
                if aux[AX_HAVE_PREV] == 0.0:
                    aux[AX_GYR_PREV_X], aux[AX_GYR_PREV_X + 1], aux[AX_GYR_PREV_X + 2] = wx, wy, wz
                px, py, pz = aux[AX_GYR_PREV_X], aux[AX_GYR_PREV_X + 1], aux[AX_GYR_PREV_X + 2]
                if method == 0:
                    w, x, y, z = step_taylor3(q[0], q[1], q[2], q[3], px * dt, py * dt, pz * dt,
                                              wx * dt, wy * dt, wz * dt)
                elif method == 1:
                    w, x, y, z = step_rk4(q[0], q[1], q[2], q[3], px, py, pz, wx, wy, wz, dt)
                else:
                    w, x, y, z = step_exact(q[0], q[1], q[2], q[3], wx * dt, wy * dt, wz * dt)
                q[0], q[1], q[2], q[3] = w, x, y, z
                aux[AX_GYR_PREV_X], aux[AX_GYR_PREV_X + 1], aux[AX_GYR_PREV_X + 2] = wx, wy, wz
                aux[AX_HAVE_PREV] = 1.0
                # covariance: P <- Phi P Phi^T + Q with Phi = [[I, A], [0, I]], A = -R dt
                _rotmat(w, x, y, z, R)
                for i in range(3):
                    for j in range(3):
                        A[i, j] = -R[i, j] * dt
                for i in range(3):
                    for j in range(3):
                        M[i, j] = (P[i, 3 + j] + A[i, 0] * P[3, 3 + j] + A[i, 1] * P[4, 3 + j]
                                   + A[i, 2] * P[5, 3 + j])
                for i in range(3):
                    for j in range(3):
                        T[i, j] = (P[i, j]
                                   + A[i, 0] * P[j, 3] + A[i, 1] * P[j, 4] + A[i, 2] * P[j, 5]
                                   + M[i, 0] * A[j, 0] + M[i, 1] * A[j, 1] + M[i, 2] * A[j, 2])
                for i in range(3):
                    for j in range(3):
                        P[i, j] = 0.5 * (T[i, j] + T[j, i])
                        P[i, 3 + j] = M[i, j]
                        P[3 + j, i] = M[i, j]
                v = (q_gyr + q_scale * (wx * wx + wy * wy + wz * wz)) * dt
                vb = q_bias * dt
                for i in range(3):
                    P[i, i] += v
                    P[3 + i, 3 + i] += vb
            if store:
                _store_prior(k, q, b, P, A, True, st_q, st_b, st_pp, st_a)

            if not correct:
                acc_ok = mag_ok = False
            at_rest = correct and rest_update(p, aux, gx, gy, gz, ax, ay, az, acc_ok, dt)
            if not propagated:
                _rotmat(q[0], q[1], q[2], q[3], R)
            updated = False
            # gravity (all updates of this sample share one linearisation point)
            if acc_ok:
                na = math.sqrt(ax * ax + ay * ay + az * az)
                awx = R[0, 0] * ax + R[0, 1] * ay + R[0, 2] * az
                awy = R[1, 0] * ax + R[1, 1] * ay + R[1, 2] * az
                awz = R[2, 0] * ax + R[2, 1] * ay + R[2, 2] * az
                if aux[AX_AWLP_INIT] == 0.0:
                    aux[AX_AWLP_X], aux[AX_AWLP_X + 1], aux[AX_AWLP_X + 2] = awx, awy, awz
                    aux[AX_AWLP_INIT] = 1.0
                else:
                    alpha = lowpass_gain(dt, p[PI_ACC_LP_TAU])
                    aux[AX_AWLP_X] += alpha * (awx - aux[AX_AWLP_X])
                    aux[AX_AWLP_X + 1] += alpha * (awy - aux[AX_AWLP_X + 1])
                    aux[AX_AWLP_X + 2] += alpha * (awz - aux[AX_AWLP_X + 2])
                lx, ly, lz = aux[AX_AWLP_X], aux[AX_AWLP_X + 1], aux[AX_AWLP_X + 2]
                nl = math.sqrt(lx * lx + ly * ly + lz * lz)
                var = acc_noise_var(p, na, nl, wx * wx + wy * wy + wz * wz)
                if var < 0.0 or nl < 1e-3:
                    flags |= FLAG_ACC_REJECTED
                    aux[AX_N_ACC_REJECTED] += 1.0
                else:
                    _scalar_update(P, dx, c, 1, -lx / nl, var)
                    _scalar_update(P, dx, c, 0, ly / nl, var)
                    updated = True
            # heading
            if mag_ok:
                # an attached hard iron learned from the samples (R's last row: up, sensor frame)
                offset_update(p, aux, mx, my, mz, R[2, 0], R[2, 1], R[2, 2], dt, hi_mats, hi_vecs)
                if aux[AX_HI_ON] > 0.0:
                    mx -= aux[AX_HI_O]
                    my -= aux[AX_HI_O + 1]
                    mz -= aux[AX_HI_O + 2]
                    flags |= FLAG_MAG_OFFSET
                    aux[AX_N_MAG_OFFSET] += 1.0
                mwx = R[0, 0] * mx + R[0, 1] * my + R[0, 2] * mz
                mwy = R[1, 0] * mx + R[1, 1] * my + R[1, 2] * mz
                mwz = R[2, 0] * mx + R[2, 1] * my + R[2, 2] * mz
                hnorm = math.hypot(mwx, mwy)
                nm = math.sqrt(mwx * mwx + mwy * mwy + mwz * mwz)
                if hnorm > 0.05 * nm and mag_accept(p, aux, nm, math.atan2(-mwz, hnorm), dt,
                                                     math.sqrt(wx * wx + wy * wy + wz * wz)):
                    psi = math.atan2(mwx, mwy) - declination
                    if psi > math.pi:
                        psi -= 2.0 * math.pi
                    elif psi < -math.pi:
                        psi += 2.0 * math.pi
                    h_x, h_y = heading_tilt_jacobian(mwx, mwy, mwz)
                    _heading_update(P, dx, c, psi,
                                    heading_noise_var(p, aux, nm, math.atan2(-mwz, hnorm), hnorm), h_x, h_y)
                    updated = True
                else:
                    flags |= FLAG_MAG_REJECTED
                    aux[AX_N_MAG_REJECTED] += 1.0
            # gyro bias at rest
            if at_rest:
                flags |= FLAG_REST
                aux[AX_N_REST] += 1.0
                _scalar_update(P, dx, c, 3, gx - b[0], var_rest)
                _scalar_update(P, dx, c, 4, gy - b[1], var_rest)
                _scalar_update(P, dx, c, 5, gz - b[2], var_rest)
                updated = True
            if updated:
                _rotate_lowpass(aux, dx)
                _inject(q, b, dx, bias_max)

        for i in range(4):
            out_q[k, i] = q[i]
        for i in range(3):
            out_bias[k, i] = b[i]
        out_flags[k] = flags
        if store:
            for i in range(6):
                for j in range(6):
                    st_pu[k, i, j] = P[i, j]


@njit(**JIT_OPTIONS)
def ekf_sensors(p, t, gyr, acc, mag, q, b, P, aux, out_q, out_bias, out_flags,
                store, st_q, st_b, st_pp, st_pu, st_a):
    """:func:`ekf_block` for ``S`` sensors in one call: every array gains a leading sensor axis
    (``t`` (S, N); ``acc``/``mag`` (S, 0, 3) when absent; the ``st_*`` arrays (S, 0, ...) when
    not storing)."""
    for s in range(gyr.shape[0]):
        ekf_block(p, t[s], gyr[s], acc[s], mag[s], q[s], b[s], P[s], aux[s], out_q[s],
                  out_bias[s], out_flags[s], store, st_q[s], st_b[s], st_pp[s], st_pu[s], st_a[s])


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
    """Backward RTS pass over one sensor's forward run stored by :func:`ekf_block`: ``q_post``
    (N, 4), ``b_post`` (N, 3) the filtered state, ``q_prior`` / ``b_prior`` the predicted one,
    ``p_prior`` / ``p_post`` (N, 6, 6) the covariances, ``a_blk`` (N, 3, 3) the transition blocks;
    writes the smoothed ``out_q`` (N, 4) and ``out_b`` (N, 3) (:mod:`.offline`)."""
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


@njit(**JIT_OPTIONS)
def rts_smooth_sensors(q_post, b_post, q_prior, b_prior, p_prior, p_post, a_blk, out_q, out_b):
    """:func:`rts_smooth` for ``S`` sensors in one call: every array gains a leading sensor axis."""
    for s in range(q_post.shape[0]):
        rts_smooth(q_post[s], b_post[s], q_prior[s], b_prior[s], p_prior[s], p_post[s], a_blk[s],
                   out_q[s], out_b[s])


@njit(**JIT_OPTIONS)
def _compiled_layout():
    return LAYOUT_FINGERPRINT


# last statement of the module: every kernel above exists when a stale cache is emptied
refresh_if_stale(globals(), _compiled_layout())
