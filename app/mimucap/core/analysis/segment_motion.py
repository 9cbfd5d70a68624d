"""How a body segment moves, from its orientations alone: the inclination of its long axis, its
angular velocity, and the two components the clinical tests read (flexion about its own
lateral axis, turning about the vertical).

Inputs: ``q_world_from_segment`` (T, 4) scalar first, world ENU (z up), ISB segment axes (x
anterior, y superior along the segment, z to the right), on the time grid ``t_s`` (T,) s,
strictly increasing. Outputs in degrees and degrees per second: the clinical tests state
their thresholds in those units.
"""

from __future__ import annotations

import numpy as np

from mimucap.core import rotation as rot
from mimucap.core.analysis.signals import check_time, lowpass

_UP = np.array([0.0, 0.0, 1.0])


def inclination_deg(q_world_from_segment: np.ndarray) -> np.ndarray:
    """Angle (T,) deg between the segment's long axis (its y axis) and the world vertical: 0
    for an upright trunk or a vertical thigh, 90 for a thigh lying level on a chair seat."""
    y = rot.rotate(np.asarray(q_world_from_segment, dtype=float), np.array([0.0, 1.0, 0.0]))
    return np.degrees(np.arccos(np.clip(y @ _UP, -1.0, 1.0)))


def angular_velocity_world(t_s: np.ndarray, q_world_from_segment: np.ndarray) -> np.ndarray:
    """Angular velocity (T, 3) rad/s in world axes: the rotation between neighbouring samples
    over their interval, centred on each sample (one-sided at the ends)."""
    t = check_time(t_s, "segment orientations", min_samples=2)
    q = np.asarray(q_world_from_segment, dtype=float)
    if q.shape != (t.shape[0], 4):
        raise ValueError(f"segment orientations: shape {q.shape} does not match {t.shape[0]} time stamps")
    step = rot.to_rotvec(rot.multiply(q[1:], rot.conjugate(q[:-1]))) / np.diff(t)[:, None]
    if step.shape[0] == 1:
        return np.repeat(step, 2, axis=0)
    return np.concatenate((step[:1], 0.5 * (step[1:] + step[:-1]), step[-1:]))


def flexion_rate_dps(t_s: np.ndarray, q_world_from_segment: np.ndarray, lowpass_hz: float | None = None) -> np.ndarray:
    """Rate (T,) deg/s at which the segment tips forward about its own lateral (z) axis:
    positive while a trunk leans forward, negative while it straightens. ``lowpass_hz`` smooths
    it with a zero-phase filter (no delay)."""
    omega = angular_velocity_world(t_s, q_world_from_segment)
    lateral = rot.rotate(np.asarray(q_world_from_segment, dtype=float), np.array([0.0, 0.0, 1.0]))
    rate = -np.degrees(np.sum(omega * lateral, axis=1))
    return _smoothed(t_s, rate, lowpass_hz)


def yaw_rate_dps(t_s: np.ndarray, q_world_from_segment: np.ndarray, lowpass_hz: float | None = None) -> np.ndarray:
    """Rate (T,) deg/s at which the segment turns about the world vertical (positive counter-
    clockwise seen from above, a turn to the left)."""
    rate = np.degrees(angular_velocity_world(t_s, q_world_from_segment)[:, 2])
    return _smoothed(t_s, rate, lowpass_hz)


def _smoothed(t_s: np.ndarray, values: np.ndarray, lowpass_hz: float | None) -> np.ndarray:
    if lowpass_hz is None:
        return values
    rate_hz = 1.0 / float(np.median(np.diff(np.asarray(t_s, dtype=float))))
    return lowpass(values, rate_hz, lowpass_hz)
