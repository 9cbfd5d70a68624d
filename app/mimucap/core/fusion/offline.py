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
sample and sensor during the call. The backward pass is the compiled kernel
:func:`~mimucap.core.fusion.kernels.rts_smooth_sensors` (as chosen by :mod:`.aot`).
"""

from __future__ import annotations

import numpy as np

from mimucap.core.fusion.aot import fusion_kernels
from mimucap.core.fusion.ekf import FusionResult, OrientationEKF, shaped_inputs
from mimucap.core.fusion.params import DEFAULT_FUSION_PARAMS, FusionParams
from mimucap.core.fusion.state import FusionState


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
            # one sensor as a batch of one: views, no copies
            fusion_kernels().rts_smooth_sensors(
                forward.q_world_from_sensor[None], forward.bias_rad_s[None], *store,
                out_q[s:s + 1], out_b[s:s + 1])
        flags[s] = forward.flags
        counters.append(forward.counters[0])
    if single:
        return FusionResult(out_q[0], out_b[0], flags[0], tuple(counters))
    return FusionResult(out_q, out_b, flags, tuple(counters))
