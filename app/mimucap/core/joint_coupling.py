"""The errors of the distal segment of an approximate hinge joint (the knee), from its axis.

The flexion axis of a hinge is one line fixed in both segments: in this model's segment frames
(ISB, :mod:`mimucap.core.skeleton`) it is each segment's z axis, which the body calibration
makes parallel in the N-pose. Seen through the two segments' orientations the two axes
coincide; where they do not, the distal segment's orientation is wrong, whatever the cause (a
magnetometer disturbed near the floor, a gyroscope drifting with its magnetometer rejected, no
magnetometer at all). The joint therefore carries the heading from the thigh to the shank, and
the magnetometer is needed only for the heading of the body as a whole (Laidig, Lehmann, Bégin,
Seel 2017, "Exploiting kinematic constraints to compensate magnetometer disturbances when
calculating joint angles of approximate hinge joints"; magnetometer-free lower-limb kinematics
built on such constraints: Teufl, Miezal, Taetz, Fröhlich, Bleser 2018, "Validity, test-retest
reliability and long-term stability of magnetometer free inertial sensor based 3D joint
kinematics").

Two errors move the axis, and both are estimated: the filter's heading drift, a rotation about
the world's vertical, and the body calibration's error, a rotation about the segment's own long
axis (its sensor's heading in the N-pose, taken in a field of its own near the floor). They are
one and the same while the segment stands upright, and told apart by how far it leans in
walking (:func:`hinge_statistics`). A real knee is only approximately a hinge: its axial
rotation and varus/valgus enter each instant, so the estimate is a least-squares fit over a
few seconds (:mod:`mimucap.core.heading_sources` averages the normal equations), which keeps
their faster variation within a gait cycle; an axial rotation held for longer than that, away
from the body calibration's pose, is taken for an error. Elbows are left out: the forearm's
axis turns with pronation (a two-degree-of-freedom joint: Laidig, Weygers, Bachhuber, Seel
2019, "Magnetometer-free realtime inertial motion tracking by exploitation of kinematic
constraints in 2-DoF joints"), which this hinge model does not hold.
"""

from __future__ import annotations

import numpy as np

from mimucap.core import rotation

#: Joint kinds treated as hinges (flexion about both segments' z axes).
HINGE_JOINTS = ("knee",)
#: The flexion axis in both segments' frames (ISB: z to the right).
HINGE_AXIS_SEGMENT = np.array([0.0, 0.0, 1.0])


#: Weight (fraction of the instants' count) of the prior that the error lies in the segment's
#: frame rather than about the vertical, which decides while the segment stands upright (both
#: rotations are then one and the same).
VERTICAL_RIDGE = 0.05
#: An instant whose proximal axis lies further than this from the distal one (deg) says nothing
#: about a hinge: the sensors are off the body (held together while their magnetometers are
#: calibrated) or have slipped. A knee's varus/valgus and axial rotation and the heading errors
#: the coupling corrects stay well within it while the sensors are on the body.
HINGE_RESIDUAL_LIMIT_DEG = 30.0


def hinge_statistics(q_world_from_proximal: np.ndarray, q_world_from_distal: np.ndarray) -> np.ndarray:
    """What one instant says about the distal segment's errors, as sums to be averaged (..., 5).

    The proximal segment's axis seen in the distal frame, ``a``, would be the distal z axis.
    A distal orientation turned by ``-δ`` about the world's vertical and by ``-ε`` about its own
    long axis (y) moves it, to first order, to ``a ≈ z + ε x + δ (v × z)`` with ``v`` the
    world's up in the distal frame: ``a_x ≈ ε + δ v_y``, ``a_y ≈ −δ v_x``. The vertical and the
    long axis differ only as far as the segment leans (``v_x``), which is what separates the
    two: a drift of the filter's heading (about the vertical) from an error of the body
    calibration (the sensor's heading in the N-pose, about the segment's axis). Returns
    ``[1, v_y, v_x² + v_y², a_x, a_x v_y − a_y v_x]``, the terms of the least-squares normal
    equations of ``(ε, δ)``; zeros where an orientation is missing or ``a`` lies further than
    :data:`HINGE_RESIDUAL_LIMIT_DEG` from ``z`` (no hinge there), so that the first term,
    averaged, is the share of the instants that held the hinge.
    """
    axis = rotation.rotate(q_world_from_proximal, HINGE_AXIS_SEGMENT)
    a = rotation.rotate(rotation.conjugate(q_world_from_distal), axis)
    v = rotation.rotate(rotation.conjugate(q_world_from_distal), np.array([0.0, 0.0, 1.0]))
    out = np.stack([np.ones(a.shape[:-1]), v[..., 1], v[..., 0] ** 2 + v[..., 1] ** 2, a[..., 0],
                    a[..., 0] * v[..., 1] - a[..., 1] * v[..., 0]], axis=-1)
    hinge = np.isfinite(out).all(axis=-1) & (a[..., 2] > np.cos(np.radians(HINGE_RESIDUAL_LIMIT_DEG)))
    return np.where(hinge[..., None], out, 0.0)


def hinge_errors(statistics: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(ε, δ)`` rad (...) from averaged :func:`hinge_statistics` (..., 5): the distal segment is
    corrected by turning it by ``ε`` about its own long axis and by ``δ`` about the vertical
    (``Rz(δ) ⊗ q ⊗ Ry(ε)``). A small prior (:data:`VERTICAL_RIDGE`) keeps ``δ`` at zero where
    the segment never leaned."""
    s0, s1, s2, s3, s4 = np.moveaxis(statistics, -1, 0)
    a11, a12, a22 = s0, s1, s2 + VERTICAL_RIDGE * s0
    det = a11 * a22 - a12 * a12
    safe = det > 1e-12
    det = np.where(safe, det, 1.0)
    epsilon = np.where(safe, (a22 * s3 - a12 * s4) / det, 0.0)
    delta = np.where(safe, (a11 * s4 - a12 * s3) / det, 0.0)
    return epsilon, delta
