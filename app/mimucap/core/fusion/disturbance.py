"""Disturbance handling of the orientation EKF: rest detection, accelerometer weighting,
magnetic disturbance rejection against a learned reference.

All functions are numba-compiled and work on one sensor's auxiliary state vector ``aux``
(layout in :mod:`mimucap.core.fusion.state`) and the packed settings ``p``
(:mod:`mimucap.core.fusion.params`).

* **Rest** (gyro bias at rest): the gyro and accelerometer samples stay within
  ``rest_gyr_dev_rad_s`` / ``rest_acc_dev_m_s2`` of their low-pass values (time constant
  ``rest_tau_s``), the low-passed rate is below ``rest_max_rate_rad_s``, for ``rest_time_s``.
* **Accelerometer** (strong motion): the gravity measurement is the specific force rotated
  into the world frame and low-passed (linear accelerations average out); its noise is
  ``σ² = σ_acc² + (k_dev·|‖a_lp‖ − g|)² + (k_rate·‖ω‖)²`` (m/s²)², and a raw sample with
  ``|‖a‖ − g|`` above ``acc_reject_m_s2`` is rejected.
* **Magnetometer**: the field norm (µT) and the dip angle (rad, positive downwards, computed
  in the world frame from the current orientation estimate) are compared with a reference
  learned from accepted samples (time constant ``mag_ref_tau_s``; the first sample after
  initialisation seeds it). A sample outside ``mag_norm_tol`` (fraction) or
  ``mag_dip_tol_rad`` is rejected, and so are the samples until the field has agreed with the
  reference again for ``mag_settle_s``. While rejected, a candidate field is followed; if the
  field stays consistent with the candidate for ``mag_new_field_s`` while the sensor turns
  (mean rate at least ``mag_new_min_rate_rad_s``: the field is homogeneous) it becomes the
  new reference (the sensor moved to a place with a different but steady field), so a permanent
  change cannot lock the magnetometer out forever, while a field that keeps changing (a
  magnet moving with the sensor, a steel object passing by) stays rejected.
"""

from __future__ import annotations

import math

from numba import njit

from mimucap.core.fusion.jit import JIT_OPTIONS, LAYOUT_FINGERPRINT, refresh_if_stale
from mimucap.core.fusion.params import (
    PI_ACC_DEV_GAIN, PI_ACC_NOISE, PI_ACC_RATE_GAIN, PI_ACC_REJECT, PI_GRAVITY, PI_HEADING_FIELD_GAIN,
    PI_HEADING_NOISE,
    PI_MAG_DIP_TOL, PI_MAG_NEW_FIELD, PI_MAG_NEW_MIN_RATE, PI_MAG_SETTLE, PI_MAG_NORM_TOL, PI_MAG_REF_TAU, PI_REST_ACC_DEV,
    PI_REST_GYR_DEV, PI_REST_MAX_RATE, PI_REST_TAU, PI_REST_TIME,
)
from mimucap.core.fusion.state import (
    AX_ALP_X, AX_GLP_X, AX_LP_INIT, AX_MAG_CAND_DIP, AX_MAG_CAND_NORM, AX_MAG_CAND_ROT, AX_MAG_CAND_T,
    AX_MAG_DIP_REF, AX_MAG_GOOD_T, AX_MAG_NORM_REF, AX_MAG_REF_OK, AX_N_MAG_NEW_REF, AX_REST_T,
)

#: Time constant (s) with which a candidate magnetic field is averaged.
MAG_CANDIDATE_TAU_S = 1.0


@njit(inline="always", **JIT_OPTIONS)
def lowpass_gain(dt, tau):
    """Gain ``1 − exp(−dt/τ)`` of a first-order low-pass filter (series for small ``dt/τ``)."""
    if not dt > 0.0:
        return 0.0
    x = dt / tau
    if x < 0.01:
        return x * (1.0 - 0.5 * x * (1.0 - x / 3.0))
    return 1.0 - math.exp(-x)


@njit(inline="always", **JIT_OPTIONS)
def rest_update(p, aux, gx, gy, gz, ax, ay, az, acc_valid, dt):
    """Update the rest detector with one sample; return ``True`` while at rest.

    ``g*`` raw gyro (rad/s), ``a*`` raw accelerometer (m/s²) in the sensor frame, ``dt`` (s).
    Without a valid accelerometer sample the sensor does not count as resting.
    """
    if aux[AX_LP_INIT] == 0.0:
        aux[AX_GLP_X], aux[AX_GLP_X + 1], aux[AX_GLP_X + 2] = gx, gy, gz
        if acc_valid:
            aux[AX_ALP_X], aux[AX_ALP_X + 1], aux[AX_ALP_X + 2] = ax, ay, az
            aux[AX_LP_INIT] = 1.0
        aux[AX_REST_T] = 0.0
        return False
    alpha = lowpass_gain(dt, p[PI_REST_TAU])
    aux[AX_GLP_X] += alpha * (gx - aux[AX_GLP_X])
    aux[AX_GLP_X + 1] += alpha * (gy - aux[AX_GLP_X + 1])
    aux[AX_GLP_X + 2] += alpha * (gz - aux[AX_GLP_X + 2])
    if not acc_valid:
        aux[AX_REST_T] = 0.0
        return False
    aux[AX_ALP_X] += alpha * (ax - aux[AX_ALP_X])
    aux[AX_ALP_X + 1] += alpha * (ay - aux[AX_ALP_X + 1])
    aux[AX_ALP_X + 2] += alpha * (az - aux[AX_ALP_X + 2])
    dgx, dgy, dgz = gx - aux[AX_GLP_X], gy - aux[AX_GLP_X + 1], gz - aux[AX_GLP_X + 2]
    dax, day, daz = ax - aux[AX_ALP_X], ay - aux[AX_ALP_X + 1], az - aux[AX_ALP_X + 2]
    lx, ly, lz = aux[AX_GLP_X], aux[AX_GLP_X + 1], aux[AX_GLP_X + 2]
    th_g = p[PI_REST_GYR_DEV]
    th_a = p[PI_REST_ACC_DEV]
    th_r = p[PI_REST_MAX_RATE]
    if (dgx * dgx + dgy * dgy + dgz * dgz < th_g * th_g
            and dax * dax + day * day + daz * daz < th_a * th_a
            and lx * lx + ly * ly + lz * lz < th_r * th_r):
        aux[AX_REST_T] += dt
    else:
        aux[AX_REST_T] = 0.0
    return aux[AX_REST_T] >= p[PI_REST_TIME]


@njit(inline="always", **JIT_OPTIONS)
def acc_noise_var(p, acc_norm, lowpass_norm, rate2):
    """Variance (unit-vector units) of the gravity direction measurement, or -1 to reject.

    ``acc_norm`` is the raw ``‖a‖`` (m/s²): a sample further than ``acc_reject_m_s2`` from
    ``g`` (a knock, a jump) is rejected. ``lowpass_norm`` is the norm of the low-passed
    world-frame specific force: its distance from ``g`` shows acceleration the low-pass has
    not averaged out yet and raises the noise; ``rate2`` is the squared bias-corrected ``‖ω‖``
    ((rad/s)²).
    """
    g = p[PI_GRAVITY]
    if abs(acc_norm - g) > p[PI_ACC_REJECT]:
        return -1.0
    s_dev = p[PI_ACC_DEV_GAIN] * abs(lowpass_norm - g)
    var = p[PI_ACC_NOISE] ** 2 + s_dev * s_dev + p[PI_ACC_RATE_GAIN] ** 2 * rate2
    return var / (g * g)


@njit(inline="always", **JIT_OPTIONS)
def mag_accept(p, aux, norm_uT, dip_rad, dt, rate):
    """Judge one magnetometer sample against the learned reference; ``True`` = use it.

    ``norm_uT`` is the field norm, ``dip_rad`` its dip angle in the world frame (positive
    downwards), ``rate`` the sensor's angular rate (rad/s). Updates the reference (accepted
    samples) or the candidate (rejected ones).
    """
    if aux[AX_MAG_REF_OK] == 0.0:
        aux[AX_MAG_NORM_REF] = norm_uT
        aux[AX_MAG_DIP_REF] = dip_rad
        aux[AX_MAG_REF_OK] = 1.0
        aux[AX_MAG_CAND_T] = 0.0
        aux[AX_MAG_GOOD_T] = p[PI_MAG_SETTLE]
        return True
    tol = p[PI_MAG_NORM_TOL]
    dip_tol = p[PI_MAG_DIP_TOL]
    ref_n = aux[AX_MAG_NORM_REF]
    ref_d = aux[AX_MAG_DIP_REF]
    if abs(norm_uT - ref_n) <= tol * ref_n and abs(dip_rad - ref_d) <= dip_tol:
        alpha = lowpass_gain(dt, p[PI_MAG_REF_TAU])
        aux[AX_MAG_NORM_REF] = ref_n + alpha * (norm_uT - ref_n)
        aux[AX_MAG_DIP_REF] = ref_d + alpha * (dip_rad - ref_d)
        aux[AX_MAG_CAND_T] = 0.0
        aux[AX_MAG_GOOD_T] += dt
        return aux[AX_MAG_GOOD_T] >= p[PI_MAG_SETTLE]
    aux[AX_MAG_GOOD_T] = 0.0
    cand_n = aux[AX_MAG_CAND_NORM]
    cand_d = aux[AX_MAG_CAND_DIP]
    if (aux[AX_MAG_CAND_T] > 0.0 and abs(norm_uT - cand_n) <= tol * cand_n
            and abs(dip_rad - cand_d) <= dip_tol):
        alpha = lowpass_gain(dt, MAG_CANDIDATE_TAU_S)
        aux[AX_MAG_CAND_NORM] = cand_n + alpha * (norm_uT - cand_n)
        aux[AX_MAG_CAND_DIP] = cand_d + alpha * (dip_rad - cand_d)
        aux[AX_MAG_CAND_T] += dt
        aux[AX_MAG_CAND_ROT] += rate * dt
    else:
        aux[AX_MAG_CAND_NORM] = norm_uT
        aux[AX_MAG_CAND_DIP] = dip_rad
        aux[AX_MAG_CAND_T] = 1e-9
        aux[AX_MAG_CAND_ROT] = 0.0
    if (aux[AX_MAG_CAND_T] >= p[PI_MAG_NEW_FIELD]
            and aux[AX_MAG_CAND_ROT] >= p[PI_MAG_NEW_MIN_RATE] * aux[AX_MAG_CAND_T]):
        aux[AX_MAG_NORM_REF] = aux[AX_MAG_CAND_NORM]
        aux[AX_MAG_DIP_REF] = aux[AX_MAG_CAND_DIP]
        aux[AX_MAG_CAND_T] = 0.0
        aux[AX_N_MAG_NEW_REF] += 1.0
        aux[AX_MAG_GOOD_T] = p[PI_MAG_SETTLE]
        return True
    return False


@njit(inline="always", **JIT_OPTIONS)
def heading_noise_var(p, aux, norm_uT, dip_rad, horizontal_uT):
    """Variance (rad²) of the heading measured from an accepted field sample.

    ``norm_uT`` and ``dip_rad`` as for :func:`mag_accept`, ``horizontal_uT`` the norm of the
    field's horizontal part. The sample's distance from the reference,
    ``e = √(Δ‖m‖² + (‖m_ref‖·Δdip)²)`` (µT), is the least disturbance that explains it; the same
    disturbance turned horizontally would move the heading by ``e/‖m_h‖`` (rad).
    """
    var = p[PI_HEADING_NOISE] ** 2
    gain = p[PI_HEADING_FIELD_GAIN]
    if gain > 0.0 and aux[AX_MAG_REF_OK] > 0.0:
        ref_n = aux[AX_MAG_NORM_REF]
        dn = norm_uT - ref_n
        dd = ref_n * (dip_rad - aux[AX_MAG_DIP_REF])
        angle = gain * math.sqrt(dn * dn + dd * dd) / horizontal_uT
        var += angle * angle
    return var


@njit(**JIT_OPTIONS)
def _compiled_layout():
    return LAYOUT_FINGERPRINT


# last statement of the module: every kernel above exists when a stale cache is emptied
refresh_if_stale(globals(), _compiled_layout())
