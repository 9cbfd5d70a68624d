"""Orientation error metric of the BROAD benchmark (Laidig et al., Data 6(7):72, 2021).

The error quaternion is expressed in the world frame: ``q_err = q_est ⊗ q_ref⁻¹`` with both
``q_world_from_sensor`` (scalar first). From it:

* heading error ``2·atan(|z/w|)`` (rotation about the vertical),
* inclination error ``2·acos(√(w² + z²))`` (the remaining tilt part),
* total error: the rotation angle of ``q_err``,

each as an RMSE in degrees over the samples selected by ``mask`` (BROAD: ``movement``), rows
where the reference or the estimate holds NaN being excluded.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mimucap.core import rotation


@dataclass(frozen=True)
class OrientationErrors:
    """RMS errors (degrees) over ``n_samples`` samples."""

    total_deg: float
    heading_deg: float
    inclination_deg: float
    n_samples: int


def error_angles_rad(q_est_world_from_sensor, q_ref_world_from_sensor) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-sample ``(total, heading, inclination)`` errors (rad), each (N,); NaN where undefined."""
    q_est = np.asarray(q_est_world_from_sensor, dtype=np.float64)
    q_ref = np.asarray(q_ref_world_from_sensor, dtype=np.float64)
    if q_est.shape != q_ref.shape or q_est.shape[-1:] != (4,):
        raise ValueError(f"estimate {q_est.shape} and reference {q_ref.shape} must both be (N, 4)")
    q_err = rotation.multiply(q_est, rotation.conjugate(q_ref))
    w, z = q_err[..., 0], q_err[..., 3]
    norm = np.linalg.norm(q_err, axis=-1)
    w_abs = np.abs(w) / norm
    total = 2.0 * np.arccos(np.clip(w_abs, 0.0, 1.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        heading = 2.0 * np.arctan(np.abs(z / w))
    incl = 2.0 * np.arccos(np.clip(np.sqrt(w * w + z * z) / norm, 0.0, 1.0))
    return total, heading, incl


def orientation_errors(q_est_world_from_sensor, q_ref_world_from_sensor, mask=None) -> OrientationErrors:
    """BROAD RMSE (degrees) of an estimate against a reference over ``mask`` (N,) bool."""
    total, heading, incl = error_angles_rad(q_est_world_from_sensor, q_ref_world_from_sensor)
    valid = np.isfinite(total) & np.isfinite(heading)
    if mask is not None:
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != valid.shape:
            raise ValueError(f"mask shape {mask.shape} does not match the {valid.shape[0]} samples")
        valid &= mask
    count = int(valid.sum())
    if count == 0:
        raise ValueError("no sample to evaluate: every selected row holds NaN")

    def rmse(x: np.ndarray) -> float:
        return float(np.degrees(np.sqrt(np.mean(x[valid] ** 2))))

    return OrientationErrors(rmse(total), rmse(heading), rmse(incl), count)
