"""Stride length and heading change of a foot sensor by zero-velocity-update integration.

Between two mid-stances of the same foot the foot moves through one swing. At each
mid-stance the foot is at rest on the ground (Skog et al. 2010, "Zero-velocity detection — an
algorithm evaluation", IEEE TBME 57:2657-2666): its velocity is zero and its accelerometer
measures gravity alone. Per stride (Rampp et al. 2015, "Inertial sensor-based stride parameter
calculation from gait sequences in geriatric patients", IEEE TBME 62:1089-1097):

1. the mid-stance is the centre of the ``rest_window_s`` window of least gyroscope energy in
   the stance (the foot's quietest moment);
2. the orientation starts level from the mean accelerometer reading at the first mid-stance
   (heading arbitrary: only changes matter) and is propagated with the gyroscope;
3. acceleration is turned into that levelled frame, gravity (the measured rest magnitude) is
   removed, and it is integrated to a velocity whose value at the second mid-stance (which
   must be zero) is removed linearly over the stride (a constant accelerometer bias and the
   slow drift of the orientation become a linear velocity error);
4. the velocity is integrated to the displacement; its horizontal norm is the stride length,
   and the turn of the orientation about the vertical is the stride's heading change.

Inputs on a uniform time grid: ``acc`` (N, 3) m/s² and ``gyr`` (N, 3) rad/s in the sensor
frame; indices into that grid; outputs in metres and radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mimucap.core import rotation as rot


@dataclass(frozen=True)
class StrideDisplacement:
    """One stride of a foot between two rests: ``displacement_m`` (3,) in the levelled frame
    of the first rest (z up), ``length_m`` its horizontal norm, ``heading_change_rad`` the
    foot's turn about the vertical (positive counter-clockwise from above)."""

    displacement_m: np.ndarray
    length_m: float
    heading_change_rad: float


def rest_index(gyr: np.ndarray, first: int, last: int, window: int) -> int | None:
    """Centre index of the ``window``-sample window of least gyroscope energy within samples
    ``first .. last`` (inclusive), or None when the span is shorter than the window."""
    first, last = max(int(first), 0), min(int(last), gyr.shape[0] - 1)
    if last - first + 1 < window:
        return None
    energy = np.sum(gyr[first:last + 1] ** 2, axis=1)
    moving = np.convolve(energy, np.ones(window) / window, mode="valid")
    return first + int(np.argmin(moving)) + window // 2


def level_orientation(acc_at_rest: np.ndarray) -> np.ndarray:
    """``q_level_from_sensor`` (4,) turning the mean rest reading ``acc_at_rest`` (3,) onto +z
    (the shortest such rotation)."""
    a = np.asarray(acc_at_rest, dtype=np.float64)
    norm = np.linalg.norm(a)
    if not norm > 1.0:
        raise ValueError(f"the foot's accelerometer reads {norm:.2f} m/s² at rest; gravity is missing")
    a = a / norm
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(a, z)
    s = np.linalg.norm(axis)
    angle = np.arctan2(s, float(a @ z))
    if s < 1e-12:
        return rot.identity() if angle < 1.0 else rot.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.pi)
    return rot.from_axis_angle(axis / s, angle)


def integrate_stride(acc: np.ndarray, gyr: np.ndarray, rate_hz: float, start: int, end: int,
                     rest_half_window: int = 5) -> StrideDisplacement:
    """Displacement of the sensor from rest sample ``start`` to rest sample ``end`` (module
    doc); ``rest_half_window`` samples either side of ``start`` give the gravity reading."""
    if not 0 <= start < end < acc.shape[0]:
        raise ValueError(f"stride samples {start}..{end} outside the recording of {acc.shape[0]} samples")
    dt = 1.0 / rate_hz
    a0 = max(start - rest_half_window, 0)
    acc_rest = acc[a0:start + rest_half_window + 1].mean(axis=0)
    gravity = float(np.linalg.norm(acc_rest))
    q0 = level_orientation(acc_rest)
    # Trapezoidal rate over each interval: the mean of its two end samples.
    steps = rot.from_rotvec(0.5 * (gyr[start:end] + gyr[start + 1:end + 1]) * dt)
    q = np.empty((end - start + 1, 4))
    q[0] = q0
    for k in range(steps.shape[0]):
        q[k + 1] = rot.multiply(q[k], steps[k])
    acc_level = rot.rotate(q, acc[start:end + 1]) - np.array([0.0, 0.0, gravity])
    velocity = np.concatenate((np.zeros((1, 3)), np.cumsum(0.5 * (acc_level[1:] + acc_level[:-1]) * dt, axis=0)))
    ramp = np.linspace(0.0, 1.0, velocity.shape[0])[:, None]
    velocity = velocity - ramp * velocity[-1]
    displacement = np.sum(0.5 * (velocity[1:] + velocity[:-1]) * dt, axis=0)
    turn = rot.multiply(q[-1], rot.conjugate(q[0]))
    # Twist of the turn about the vertical (swing-twist decomposition).
    heading = 2.0 * np.arctan2(turn[3], turn[0])
    heading = (heading + np.pi) % (2.0 * np.pi) - np.pi
    return StrideDisplacement(displacement, float(np.hypot(displacement[0], displacement[1])), float(heading))
