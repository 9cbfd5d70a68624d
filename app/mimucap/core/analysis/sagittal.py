"""The sagittal plane of a shank or foot sensor: its flexion (mediolateral) axis, the rate of
rotation about it (positive when the distal end swings forward), and the antero-posterior and
vertical components of its acceleration.

With a body calibration the axes are the segment's own, turned into the sensor frame with the
calibrated mounting ``q_segment_from_sensor`` (ISB segment frame: x anterior, y superior, z to
the right for both sides, so a positive rate about z tips the long axis backwards: the foot or
ankle moves forward, as in swing). Without one they are found in the recording itself, so that
no mounting is assumed:

* the mediolateral axis is the gyroscope axis most aligned with the dominant rotation of the
  recording (principal axis of the angular velocity: gait is a rotation in the sagittal plane),
  its sign chosen so that the long sustained excursions (the swings) are positive;
* the vertical is the accelerometer's mean reading while the segment is quietest (mid-stance
  and standing: at rest it measures gravity alone, Skog et al. 2010, "Zero-velocity detection —
  an algorithm evaluation"), made perpendicular to the mediolateral axis; the anterior axis
  completes the right-handed frame (x = y × z).

Units: rad/s, m/s²; gyroscope and accelerometer samples (N, 3) in the sensor frame; axes unit
vectors (3,) in the sensor frame; quaternions scalar first.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mimucap.core import rotation as rot

#: Length (s) of the windows whose gyroscope energy marks the quiet samples (the mid-stance
#: window of Rampp et al. 2015, "Inertial sensor-based stride parameter calculation from gait
#: sequences in geriatric patients").
QUIET_WINDOW_S = 0.1
#: Share of the recording's windows, the quietest, whose accelerometer mean gives the vertical.
QUIET_SHARE = 0.1


@dataclass(frozen=True)
class SagittalAxes:
    """A sensor's sagittal axes in its own frame: ``mediolateral`` (3,) the flexion axis
    (pointing to the subject's right: a positive rate swings the distal end forward),
    ``anterior`` (3,) perpendicular to it; ``source`` says where they came from."""

    mediolateral: np.ndarray
    anterior: np.ndarray
    source: str

    @property
    def superior(self) -> np.ndarray:
        """The third axis (3,): ``mediolateral × anterior`` (ISB: y = z × x)."""
        return np.cross(self.mediolateral, self.anterior)

    def rate(self, gyr_sensor: np.ndarray) -> np.ndarray:
        """Sagittal angular velocity (N,) rad/s from gyroscope samples (N, 3) rad/s."""
        return _samples(gyr_sensor, "gyroscope") @ self.mediolateral

    def acceleration(self, acc_sensor: np.ndarray) -> np.ndarray:
        """Antero-posterior and vertical (superior) components (N, 2) m/s² of accelerometer
        samples (N, 3) m/s²: the acceleration in the sagittal plane."""
        acc = _samples(acc_sensor, "accelerometer")
        return np.stack((acc @ self.anterior, acc @ self.superior), axis=-1)


def _samples(values: np.ndarray, what: str) -> np.ndarray:
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{what} samples must have shape (N, 3), got {array.shape}")
    return array


def axes_calibrated(q_segment_from_sensor: np.ndarray) -> SagittalAxes:
    """The segment's z (flexion) and x (anterior) axes in the sensor frame, from the calibrated
    mounting ``q_segment_from_sensor`` (4,)."""
    q_sensor_from_segment = rot.conjugate(rot.normalize(np.asarray(q_segment_from_sensor, dtype=np.float64)))
    return SagittalAxes(rot.rotate(q_sensor_from_segment, np.array([0.0, 0.0, 1.0])),
                        rot.rotate(q_sensor_from_segment, np.array([1.0, 0.0, 0.0])), "body calibration")


def axes_from_data(acc_sensor: np.ndarray, gyr_sensor: np.ndarray, rate_hz: float) -> SagittalAxes:
    """The sagittal axes found in the recording (module doc): ``acc_sensor`` (N, 3) m/s² and
    ``gyr_sensor`` (N, 3) rad/s sampled at ``rate_hz``. ``ValueError`` when the quiet samples
    do not measure gravity (no accelerometer reading at rest)."""
    acc = _samples(acc_sensor, "accelerometer")
    gyr = _samples(gyr_sensor, "gyroscope")
    if acc.shape != gyr.shape:
        raise ValueError(f"accelerometer {acc.shape} and gyroscope {gyr.shape} samples differ in number")
    mediolateral = dominant_axis(gyr)
    window = int(np.clip(round(QUIET_WINDOW_S * rate_hz), 1, acc.shape[0]))
    energy = np.convolve(np.sum(gyr ** 2, axis=1), np.ones(window) / window, mode="same")
    quiet = energy <= np.quantile(energy, QUIET_SHARE)
    up = acc[quiet].mean(axis=0)
    up = up - (up @ mediolateral) * mediolateral
    norm = float(np.linalg.norm(up))
    if not norm > 1.0:
        raise ValueError(f"the accelerometer reads {norm:.2f} m/s² across the flexion axis while the sensor is "
                         "quietest: gravity is missing, so the vertical cannot be found")
    up = up / norm
    return SagittalAxes(mediolateral, np.cross(up, mediolateral), "recording (principal rotation axis, gravity at rest)")


def sagittal_rate_calibrated(gyr_sensor: np.ndarray, q_segment_from_sensor: np.ndarray) -> np.ndarray:
    """Rate about the segment's z (flexion) axis (N,) rad/s from gyroscope samples (N, 3) rad/s
    in the sensor frame and the mounting rotation ``q_segment_from_sensor`` (4,)."""
    gyr = _samples(gyr_sensor, "gyroscope")
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
