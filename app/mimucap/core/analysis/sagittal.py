"""The sagittal angular velocity of a shank or foot sensor: the rate of rotation about the
segment's flexion axis, positive when the distal end swings forward.

With a body calibration the sensor's gyroscope is turned into the segment frame with the
calibrated mounting ``q_segment_from_sensor`` and its z component is taken (ISB segment frame:
x anterior, y superior, z to the right for both sides, so a positive rate about z tips the
long axis backwards: the foot or ankle moves forward, as in swing). Without a calibration the
gyroscope axis most aligned with the dominant rotation of the recording is used (principal
axis of the angular velocity), its sign chosen so that the long sustained excursions (the
swings) are positive.

Units: rad/s; gyroscope samples (N, 3) in the sensor frame; quaternions scalar first.
"""

from __future__ import annotations

import numpy as np

from mimucap.core import rotation as rot


def sagittal_rate_calibrated(gyr_sensor: np.ndarray, q_segment_from_sensor: np.ndarray) -> np.ndarray:
    """Rate about the segment's z (flexion) axis (N,) rad/s from gyroscope samples (N, 3) rad/s
    in the sensor frame and the mounting rotation ``q_segment_from_sensor`` (4,)."""
    gyr = np.asarray(gyr_sensor, dtype=np.float64)
    if gyr.ndim != 2 or gyr.shape[1] != 3:
        raise ValueError(f"gyroscope samples must have shape (N, 3), got {gyr.shape}")
    q = rot.normalize(np.asarray(q_segment_from_sensor, dtype=np.float64))
    return rot.rotate(q, gyr)[:, 2]


def dominant_axis(gyr_sensor: np.ndarray) -> np.ndarray:
    """Unit axis (3,) in the sensor frame along which the angular velocity varies most, signed
    so that the swings (long positive excursions) are positive.

    The sign: for each direction, the time spent beyond half of the 99th percentile of |rate|;
    the swing excursion of the shank and of the foot lasts longer than any opposite one (the
    short push-off and heel-strike peaks), so the longer side is the swing side.
    """
    gyr = np.asarray(gyr_sensor, dtype=np.float64)
    if gyr.ndim != 2 or gyr.shape[1] != 3 or gyr.shape[0] < 10:
        raise ValueError(f"gyroscope samples must have shape (N >= 10, 3), got {gyr.shape}")
    centred = gyr - gyr.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    axis = vt[0]
    rate = gyr @ axis
    level = 0.5 * np.percentile(np.abs(rate), 99)
    if np.count_nonzero(rate < -level) > np.count_nonzero(rate > level):
        axis = -axis
    return axis / np.linalg.norm(axis)


def sagittal_rate_dominant(gyr_sensor: np.ndarray) -> np.ndarray:
    """Rate (N,) rad/s about :func:`dominant_axis` (no body calibration needed)."""
    gyr = np.asarray(gyr_sensor, dtype=np.float64)
    return gyr @ dominant_axis(gyr)
