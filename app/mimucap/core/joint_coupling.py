"""The heading offset between the two segments of an approximate hinge joint (the knee).

The flexion axis of a hinge is one line fixed in both segments: in this model's segment frames
(ISB, :mod:`mimucap.core.skeleton`) it is each segment's z axis, which the body calibration
makes parallel in the N-pose. Seen in the world frame through the two segments' orientations,
the two axes coincide; when they do not, the difference in azimuth about the vertical is the
heading error of one segment relative to the other, whatever its cause (a magnetometer
disturbed near the floor, a gyroscope drifting with its magnetometer rejected, or no
magnetometer at all). The joint therefore carries the relative heading from the thigh to the
shank, and the magnetometer is needed only for the heading of the body as a whole (Laidig,
Lehmann, Bégin, Seel 2017, "Exploiting kinematic constraints to compensate magnetometer
disturbances when calculating joint angles of approximate hinge joints"; magnetometer-free
lower-limb kinematics built on such constraints: Teufl, Miezal, Taetz, Fröhlich, Bleser 2018,
"Validity, test-retest reliability and long-term stability of magnetometer free inertial sensor
based 3D joint kinematics").

The azimuth difference is observable whenever the axis is not vertical (a knee axis is
horizontal in walking and standing), and each instant's estimate is weighted by the product of
the two axes' horizontal lengths. A real knee is only approximately a hinge: its axial rotation
and varus/valgus enter the instant offset, so it is averaged over a few seconds
(:class:`~mimucap.core.heading_sources.AngleSmoother`), which keeps their faster variation
within a gait cycle and takes the slower offset as the heading error: an axial rotation held
for longer than that, away from the body calibration's pose, is taken for a heading error too.
Elbows are left out: the forearm's axis turns with pronation (a two-degree-of-freedom joint,
Laidig, Weygers, Bachhuber, Seel 2019, "Magnetometer-free realtime inertial motion tracking by
exploitation of kinematic constraints in 2-DoF joints"), which this hinge model does not hold.
"""

from __future__ import annotations

import numpy as np

from mimucap.core import rotation

#: Joint kinds treated as hinges (flexion about both segments' z axes).
HINGE_JOINTS = ("knee",)
#: The flexion axis in both segments' frames (ISB: z to the right).
HINGE_AXIS_SEGMENT = np.array([0.0, 0.0, 1.0])


def hinge_heading_offset(q_world_from_proximal: np.ndarray,
                         q_world_from_distal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distal segment's heading error relative to the proximal one, from the hinge axis.

    ``q_world_from_proximal``, ``q_world_from_distal`` (..., 4) segment orientations at the
    same instants. Returns ``(offset_rad (...), weight (...))``: the angle (rad, counter-clockwise
    seen from above) by which the distal axis is turned about the vertical from the proximal
    one (the distal segment is corrected by turning it back by this angle), and the product of
    the two axes' horizontal lengths (0 where the axis is vertical or an orientation missing)."""
    proximal = rotation.rotate(q_world_from_proximal, HINGE_AXIS_SEGMENT)
    distal = rotation.rotate(q_world_from_distal, HINGE_AXIS_SEGMENT)
    cross = proximal[..., 0] * distal[..., 1] - proximal[..., 1] * distal[..., 0]
    dot = proximal[..., 0] * distal[..., 0] + proximal[..., 1] * distal[..., 1]
    weight = np.hypot(proximal[..., 0], proximal[..., 1]) * np.hypot(distal[..., 0], distal[..., 1])
    finite = np.isfinite(weight) & np.isfinite(cross) & np.isfinite(dot)
    offset = np.where(finite, np.arctan2(np.where(finite, cross, 0.0), np.where(finite, dot, 1.0)), 0.0)
    return offset, np.where(finite, weight, 0.0)
