"""Step 5 of the processing path: the joint angles of the measured joints, and why each may be
wrong (no I/O, no Qt).

The angles themselves are the ISB sequences of ``docs/conventions.md``
(:func:`mimucap.core.skeleton.joint_angles_deg`); only the joints whose two segments carry a
sensor have them (:func:`measured_joint_angles`: a segment without a sensor follows its parent,
and its joint's angle would be a constant zero).

A joint angle inherits the reasons for doubt of the sensors of its two segments at the pose
instants (:func:`at_instants`, from each chain's :mod:`.sensor_doubt`), plus those of the body
calibration (none, a poor verdict, or made from doubtful orientations); a recording's
magnetometer turns take the sensors off the body (:func:`off_body`), and near its Euler
sequence's singularity a joint's first and third angles amplify any error (:func:`singular`).
The reasons are bits of :mod:`.doubt_reasons`.

Times are seconds, angles degrees unless the name says otherwise.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

import numpy as np

from mimucap.core import bodycal, skeleton
from mimucap.core.heading_sources import relieved
from mimucap.core.pipeline.doubt_reasons import (
    BODY_CALIBRATION_DOUBTFUL, BODY_CALIBRATION_POOR, DOUBT_DTYPE, LOST_SAMPLES, NO_BODY_CALIBRATION,
    NO_ORIENTATION, OFF_BODY, SINGULAR,
)
from mimucap.core.pipeline.instants import HOLD_BACK_LIMIT_S


def measured_joint_angles(model: skeleton.SkeletonModel, angles_deg: Mapping[str, np.ndarray],
                          measured_segments) -> dict[str, np.ndarray]:
    """The joint-angle columns of the joints whose two segments carry a sensor: a segment
    without one only follows its parent, and its joint's angle would be a constant zero."""
    measured = set(measured_segments)
    keep = {joint.name for joint in model.joints if joint.proximal in measured and joint.distal in measured}
    return {column: values for column, values in angles_deg.items()
            if any(column.startswith(joint + "_") for joint in keep)}


def at_instants(t_query: np.ndarray, t_s: np.ndarray, reasons: np.ndarray, hold_s: float) -> np.ndarray:
    """A sensor's reasons at the instants ``t_query`` (M,) from its samples ``(t_s (N,),
    reasons (N,))``: those of the sample at or before each instant and of the one after (an
    orientation between two samples is interpolated from both); before the first sample
    :data:`NO_ORIENTATION`; more than ``hold_s`` after the last (an orientation held, not
    measured) :data:`LOST_SAMPLES`. (M,) ``uint16``."""
    t_query = np.asarray(t_query, dtype=np.float64)
    out = np.zeros(t_query.shape, dtype=DOUBT_DTYPE)
    if not len(t_s):
        out[:] = NO_ORIENTATION
        return out
    reasons = np.asarray(reasons, dtype=DOUBT_DTYPE)
    before = np.searchsorted(t_s, t_query, side="right") - 1
    after = np.searchsorted(t_s, t_query, side="left")
    known = before >= 0
    out[known] = reasons[before[known]]
    inside = after < len(t_s)
    out[inside] |= reasons[after[inside]]
    out[~known] |= NO_ORIENTATION
    out[t_query > t_s[-1] + hold_s] |= LOST_SAMPLES
    return out


def joint_reasons(model: skeleton.SkeletonModel, t_pose: np.ndarray, segment_of_sensor: Mapping[str, str],
                  sensor_reasons: Mapping[str, tuple[np.ndarray, np.ndarray]],
                  body_calibration: bodycal.BodyCalibration | None,
                  hold_s: float = HOLD_BACK_LIMIT_S,
                  heading_source: Mapping[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """Joint → the reasons (T,) its angles at the pose instants ``t_pose`` may be wrong: its two
    sensors' (``sensor_reasons`` sensor → ``(t_s (N,), reasons (N,))``, at the instants by
    :func:`at_instants`, ``hold_s`` the longest a held orientation counts as measured), and no
    body calibration or a poor one, or one made from doubtful orientations. Joints whose
    segments do not both carry a sensor are left out. A sensor whose heading at an instant came
    from the field the body shares or from its joint (``heading_source`` sensor → (T,)) is not
    doubtful there for its own magnetometer's reasons
    (:func:`~mimucap.core.heading_sources.relieved`)."""
    shared = np.zeros(len(t_pose), dtype=DOUBT_DTYPE)
    if body_calibration is None:
        shared |= NO_BODY_CALIBRATION
    else:
        if body_calibration.quality.verdict == "poor":
            shared |= BODY_CALIBRATION_POOR
        if body_calibration.quality.doubtful_sensors:
            shared |= BODY_CALIBRATION_DOUBTFUL
    at = {sid: at_instants(t_pose, t, values, hold_s) for sid, (t, values) in sensor_reasons.items()}
    if heading_source:
        at = {sid: relieved(values, heading_source[sid]) if sid in heading_source else values
              for sid, values in at.items()}
    sensor_of_segment = {segment: sid for sid, segment in segment_of_sensor.items() if sid in at}
    out = {}
    for joint in model.joints:
        sensors = [sensor_of_segment.get(joint.proximal), sensor_of_segment.get(joint.distal)]
        if any(sensor is None for sensor in sensors):
            continue
        out[joint.name] = shared | at[sensors[0]] | at[sensors[1]]
    return out


def singular_reasons(model: skeleton.SkeletonModel, joint: str, angles_deg: Mapping[str, np.ndarray],
                     shoulder_sequence: str) -> np.ndarray | int:
    """:data:`~mimucap.core.pipeline.doubt_reasons.SINGULAR` (T,) where ``joint``'s angles
    (``angles_deg``, columns of :func:`~mimucap.core.skeleton.joint_angle_columns`) lie near their
    sequence's singularity (0 when the joint has no angles)."""
    column, proper = skeleton.middle_angle(model.joint(joint), shoulder_sequence)
    return singular(angles_deg[column], proper) if column in angles_deg else 0


def off_body(t_s: np.ndarray, windows: Iterable[tuple[float, float]], gyr_rad_s: np.ndarray | None,
             still_rate_rad_s: float, still_time_s: float) -> np.ndarray:
    """:data:`OFF_BODY` (N,) ``uint16`` at a sensor's samples ``t_s`` (N,) inside any of
    ``windows`` (start, end) s, in which the sensors are turned in the hand, and after each
    until the sensor has turned slower than ``still_rate_rad_s`` for ``still_time_s`` (its
    rates ``gyr_rad_s`` (N, 3); None: until the window's end): a sensor is strapped back on
    after the turns, and where it sits is known once the subject stands still."""
    t_s = np.asarray(t_s, dtype=np.float64)
    out = np.zeros(t_s.shape, dtype=DOUBT_DTYPE)
    still_since = None
    if gyr_rad_s is not None:
        moving = ~(np.linalg.norm(np.asarray(gyr_rad_s, dtype=np.float64), axis=1) < still_rate_rad_s)
        still_since = t_s - np.maximum.accumulate(np.where(moving, t_s, -np.inf))
    for start, end in windows:
        stop = end
        if still_since is not None:
            settled = np.flatnonzero((t_s >= end) & (still_since >= still_time_s))
            stop = float(t_s[settled[0]]) if len(settled) else math.inf
        out[(t_s >= start) & (t_s < stop)] = OFF_BODY
    return out


def singular(middle_deg: np.ndarray, proper: bool) -> np.ndarray:
    """:data:`SINGULAR` (T,) ``uint16`` where a joint's middle Euler angle ``middle_deg`` (T,)
    is within 30° of its sequence's singularity (±90° for Tait-Bryan sequences such as Z-X'-Y'',
    0° and 180° for a ``proper`` one such as Y-X'-Y''): there the first and third angles change
    at least twice as fast as the rotation itself (``1 / cos`` or ``1 / sin`` of the middle
    angle), so a degree of attitude error becomes several in them (gimbal lock)."""
    middle = np.radians(np.asarray(middle_deg, dtype=np.float64))
    conditioning = np.abs(np.sin(middle)) if proper else np.abs(np.cos(middle))
    return np.where(conditioning < 0.5, SINGULAR, 0).astype(DOUBT_DTYPE)
