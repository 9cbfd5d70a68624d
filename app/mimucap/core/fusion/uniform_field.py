"""Relative headings from a magnetic field that is the same for every sensor of the body.

A field that changes alike over the whole body (a steel frame or a magnet a few metres away, a
building's field that differs from where the magnetometers were calibrated) makes each
sensor's filter reject its magnetometer, since the field's magnitude and dip no longer match
the calibrated ones, and each heading then drifts on its own gyroscope. Yet every sensor still
measures the same field vector in the world frame, so the magnetometers still say how the
sensors are turned *relative to each other* (Laidig, Lehmann, Bégin, Seel 2017, "Exploiting
kinematic constraints to compensate magnetometer disturbances when calculating joint angles of
approximate hinge joints", use the same observation for the field two sensors share).

At each instant every sensor's calibrated field is turned into the world frame with its own
orientation; a sensor *agrees* with the body when the horizontal and vertical components of
its field lie within :data:`AGREEMENT_FRACTION` of the field's magnitude from the median
over the sensors (both are independent of heading, so a sensor whose heading drifted still
agrees). The azimuth of an agreeing sensor's horizontal field, minus the circular mean of the
agreeing sensors' azimuths, is that sensor's heading error relative to the body; averaged over
a few seconds (:class:`~mimucap.core.heading_sources.ExponentialAverage`, weighted by the horizontal
field) it is removed from the sensor's heading. The body's own heading stays the filters'
mean: a field turned about the vertical without a change of magnitude or dip is invisible to
any magnetometer check.

Arrays: ``q_world_from_sensor`` (S, 4) and ``mag_uT`` (S, 3) (calibrated field, sensor frame,
µT; NaN rows for a sensor without either) at one instant; angles in rad, world ENU.
"""

from __future__ import annotations

import numpy as np

from mimucap.core import rotation

#: A sensor's horizontal and vertical field components must lie within this fraction of the
#: field's magnitude of the body's median (the magnetometer-calibration check's 10 %: a
#: gradient of this size turns a heading by up to its size over the horizontal field).
AGREEMENT_FRACTION = 0.1
#: At least this many sensors must agree on the field for it to count as the body's.
MIN_AGREEING = 3


def field_components(q_world_from_sensor: np.ndarray, mag_uT: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Horizontal magnitude (µT), vertical component (µT, up positive) and azimuth (rad, from
    north towards east) of each sensor's field in the world frame: three (S,) arrays."""
    world = rotation.rotate(q_world_from_sensor, mag_uT)
    return np.hypot(world[:, 0], world[:, 1]), world[:, 2], np.arctan2(world[:, 0], world[:, 1])


def relative_azimuths(q_world_from_sensor: np.ndarray, mag_uT: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each sensor's heading error relative to the body, from the field they share:
    ``(error_rad (S,), weight (S,))`` of :func:`shared_field_terms`."""
    error, weight, _deviation = shared_field_terms(q_world_from_sensor, mag_uT)
    return error, weight


def shared_field_terms(q_world_from_sensor: np.ndarray,
                       mag_uT: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each sensor's heading error relative to the body, from the field they share, and how far
    its field lies from the body's.

    Returns ``(error_rad (S,), weight (S,), deviation_uT (S, 2))``: ``error_rad`` the azimuth of
    the sensor's field minus the circular mean over the agreeing sensors (so a sensor whose
    heading is too far east sees the field too far west: the heading error is the negative
    azimuth difference), ``weight`` the horizontal field (µT) for agreeing sensors, 0 for the
    others (and for all when fewer than :data:`MIN_AGREEING` agree); ``deviation_uT`` the
    sensor's horizontal and vertical components minus the body's median (the two a heading
    error leaves alone; NaN without a field): where a room's field varies alike in every
    direction, as they vary so does the third no check can see, its turn about the vertical."""
    q = np.asarray(q_world_from_sensor, dtype=np.float64)
    mag = np.asarray(mag_uT, dtype=np.float64)
    n = len(q)
    error = np.zeros(n)
    weight = np.zeros(n)
    deviation = np.full((n, 2), np.nan)
    valid = np.isfinite(q).all(axis=1) & np.isfinite(mag).all(axis=1)
    if valid.sum() < MIN_AGREEING:
        return error, weight, deviation
    horizontal, vertical, azimuth = field_components(q[valid], mag[valid])
    h_median, v_median = np.median(horizontal), np.median(vertical)
    deviation[valid] = np.stack([horizontal - h_median, vertical - v_median], axis=-1)
    tolerance = AGREEMENT_FRACTION * float(np.hypot(h_median, v_median))
    agree = (np.abs(horizontal - h_median) < tolerance) & (np.abs(vertical - v_median) < tolerance)
    if agree.sum() < MIN_AGREEING:
        return error, weight, deviation
    mean = np.arctan2(np.sum(horizontal[agree] * np.sin(azimuth[agree])),
                      np.sum(horizontal[agree] * np.cos(azimuth[agree])))
    rows = np.flatnonzero(valid)[agree]
    error[rows] = -np.angle(np.exp(1j * (azimuth[agree] - mean)))
    weight[rows] = horizontal[agree]
    return error, weight, deviation


def deviation_spread_uT(q_world_from_sensor: np.ndarray, mag_uT: np.ndarray, moving: np.ndarray) -> np.ndarray:
    """How much each sensor's field's deviation from the body's varied over a recording (µT):
    the root of the summed variances of its horizontal and vertical deviations
    (:func:`shared_field_terms`) over the instants at which it ``moving`` ((T, S) bool), NaN for
    a sensor with fewer than two such instants. ``q_world_from_sensor`` (T, S, 4) and ``mag_uT``
    (T, S, 3) calibrated field (NaN where a sensor has none).

    Only a sensor moving through the room can show how the room's field varies at its height: a
    still one keeps whatever deviation its place gives it, and the body's N-pose is one place."""
    q = np.asarray(q_world_from_sensor, dtype=np.float64)
    mag = np.asarray(mag_uT, dtype=np.float64)
    world = rotation.rotate(q, mag)
    horizontal, vertical = np.hypot(world[..., 0], world[..., 1]), world[..., 2]
    valid = np.isfinite(horizontal) & np.isfinite(vertical)
    shared = valid.sum(axis=-1) >= MIN_AGREEING
    counted = valid & shared[:, None] & np.asarray(moving, dtype=bool)
    spread = np.full(q.shape[1], np.nan)
    if not np.any(shared):
        return spread
    with np.errstate(all="ignore"):
        h_median = np.nanmedian(np.where(valid, horizontal, np.nan)[shared], axis=-1)
        v_median = np.nanmedian(np.where(valid, vertical, np.nan)[shared], axis=-1)
    deviation = np.stack([horizontal[shared] - h_median[:, None], vertical[shared] - v_median[:, None]], axis=-1)
    counted = counted[shared]
    for sensor in range(q.shape[1]):
        rows = counted[:, sensor]
        if rows.sum() >= 2:
            spread[sensor] = float(np.sqrt(np.sum(np.var(deviation[rows, sensor], axis=0))))
    return spread
