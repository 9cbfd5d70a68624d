"""Offline orientation estimate of a recording: forward EKF plus Rauch-Tung-Striebel smoother.

The forward pass is the online filter (:mod:`ekf`) storing, per sample, the predicted state
``x_{k|k-1}``, the predicted and updated covariances and the transition block ``A = −R·dt`` of
``Φ = [[I, A], [0, I]]``. The backward pass runs over the error state
``[δθ (world frame, rad), δb (rad/s)]``:

``C_k = P_{k|k} Φ_{k+1}ᵀ P_{k+1|k}⁻¹``,
``δx_k = C_k · (x_{k+1|N} ⊖ x_{k+1|k})`` with ``q_a ⊖ q_b = log(q_a ⊗ q_b⁻¹)`` and the bias
difference, and ``x_{k|N} = x_{k|k} ⊕ δx_k`` (``q ← exp(δθ) ⊗ q``, ``b ← b + δb``).

So every sample uses the whole recording: gyro bias learned at the end of a recording and
heading corrections after a magnetic disturbance reach back in time.

The forward pass weighs a field that differs from its reference down more than the online
filter, holds that reference and never adopts a new one
(:meth:`~mimucap.core.fusion.params.FusionParams.smoother_pass`,
:meth:`~mimucap.core.fusion.ekf.OrientationEKF.smoother_pass`): the backward pass treats the
heading measurements as white noise, so it would follow a foreign field's heading error, which
lasts seconds, more closely than the causal filter does, while the gyroscope drift it accepts
instead is bounded by the trusted field on both sides. Memory: about 0.7 kB per
sample and sensor during the call (:class:`SmootherStore`). The forward pass may be fed in
blocks (:func:`forward_block`, as the per-sensor chain does to read its filter's covariance
between blocks), then :func:`smooth` runs the backward pass; :func:`fuse_offline` does both
for whole recordings. The backward pass is the compiled kernel
:func:`~mimucap.core.fusion.kernels.rts_smooth_sensors` (as chosen by :mod:`.kernel_selection`).
"""

from __future__ import annotations

import numpy as np

from mimucap.core.fusion.ekf import FusionResult, OrientationEKF, shaped_inputs
from mimucap.core.fusion.kernel_selection import fusion_kernels
from mimucap.core.fusion.params import DEFAULT_FUSION_PARAMS, FusionParams
from mimucap.core.fusion.state import FusionState


class SmootherStore:
    """What the forward pass of one sensor over ``n`` samples keeps for the backward pass (about
    0.7 kB per sample): the predicted state, the predicted and updated covariances and the
    transition block of every sample, as the kernel writes them."""

    def __init__(self, n: int) -> None:
        self.arrays = (np.empty((1, n, 4)), np.empty((1, n, 3)), np.empty((1, n, 6, 6)),
                       np.empty((1, n, 6, 6)), np.empty((1, n, 3, 3)))

    def rows(self, start: int, stop: int) -> tuple[np.ndarray, ...]:
        """Views of samples ``start:stop`` for one block of the forward pass (C-contiguous: the
        sensor axis has length one)."""
        return tuple(array[:, start:stop] for array in self.arrays)


def forward_block(ekf: OrientationEKF, store: SmootherStore, start: int, t_s, gyr_rad_s, acc_m_s2=None,
                  mag_uT=None) -> FusionResult:
    """Feed ``ekf`` (one sensor) the block of samples ``start:start + N`` of a recording, keeping
    what the backward pass needs in ``store``; the outputs are those of
    :meth:`~mimucap.core.fusion.ekf.OrientationEKF.update_batch`. Feeding a recording block by
    block keeps exactly what one call over it keeps."""
    n = len(np.asarray(t_s))
    return ekf.update_batch(t_s, gyr_rad_s, acc_m_s2, mag_uT, _store=store.rows(start, start + n))


def smooth(q_forward: np.ndarray, bias_forward: np.ndarray, store: SmootherStore) -> tuple[np.ndarray, np.ndarray]:
    """The Rauch-Tung-Striebel backward pass over one sensor's forward run: its outputs
    ``q_forward`` (N, 4), ``bias_forward`` (N, 3) and ``store`` (filled for all N samples);
    returns the smoothed ``q_world_from_sensor`` (N, 4) and gyro bias (N, 3) rad/s."""
    n = len(q_forward)
    out_q, out_b = np.empty((1, n, 4)), np.empty((1, n, 3))
    if n:
        # one sensor as a batch of one: views, no copies
        fusion_kernels().rts_smooth_sensors(
            np.ascontiguousarray(q_forward, dtype=np.float64)[None],
            np.ascontiguousarray(bias_forward, dtype=np.float64)[None], *store.arrays, out_q, out_b)
    return out_q[0], out_b[0]


def fuse_offline(t_s, gyr_rad_s, acc_m_s2=None, mag_uT=None, *,
                 params: FusionParams = DEFAULT_FUSION_PARAMS, algorithm: str = "ekf-taylor3",
                 use_mag: bool = True, state: FusionState | None = None) -> FusionResult:
    """Smoothed orientation of a whole recording (same inputs and outputs as :func:`ekf.fuse`).

    Sensors are smoothed one after the other, so the forward-pass storage (about 0.7 kB per
    sample) is held for one sensor at a time. The forward pass runs with
    ``params.smoother_pass()`` (the smoother's own magnetometer weighting, module docstring);
    the flags and counters are those of that pass. ``state`` (one sensor's) is the prior at the
    first sample, e.g. what a filter that ran before the recording had learnt (gyro bias,
    heading, their covariance); a fresh filter starts when it is None.
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
        store = SmootherStore(n)
        ekf = OrientationEKF(params, algorithm=algorithm, use_mag=use_mag, state=state).smoother_pass()
        forward = forward_block(ekf, store, 0, t[s], gyr3[s], None if acc3 is None else acc3[s],
                                None if mag3 is None else mag3[s])
        out_q[s], out_b[s] = smooth(forward.q_world_from_sensor, forward.bias_rad_s, store)
        flags[s] = forward.flags
        counters.append(forward.counters[0])
    if single:
        return FusionResult(out_q[0], out_b[0], flags[0], tuple(counters))
    return FusionResult(out_q, out_b, flags, tuple(counters))
