"""The axis of a hinge joint (knee, elbow; approximately the ankle and wrist) from the movement of
the two segments it joins.

A hinge turns the two segments relative to each other about one axis, fixed in both: with
``j1`` (3,) that axis in the first sensor's frame and ``j2`` (3,) in the second's, the axis has
one direction in the world whichever way the joint is bent,

    ``R_world_from_1(t) · j1 = R_up(δ) · R_world_from_2(t) · j2``  for every ``t``

(the hinge constraint Laidig, Lehmann, Bégin and Seel exploit in "Exploiting kinematic
constraints to compensate magnetometer disturbances when calculating joint angles of
approximate hinge joints", 2017), where ``R_up(δ)`` turns by ``δ`` about the vertical: each
sensor's heading comes from its own magnetometer and filter, so two sensors' headings disagree
by a degree or more (much more in a disturbed room), an offset that barely changes over a
movement of seconds. Laidig, Weygers, Seel et al. estimate such an offset together with the
joint axes in "Self-calibrating magnetometer-free inertial motion tracking of 2-DoF joints"
(Sensors 22, 2022); left in, it tilts the axes by about ``δ`` over the flexion excursion. Two
estimators:

* :func:`fit_hinge_from_orientations` (the default of :mod:`mimucap.core.functional_bodycal`):
  least squares on that constraint, ``min Σ |R1(t) j1 − R_up(δ) R2(t) j2|²`` over unit axes and
  ``δ``: for a given ``δ`` it is ``max j1ᵀ M j2`` with ``M = Σ R_1_from_world(t) R_up(δ)
  R_world_from_2(t)``, so ``j1`` and ``j2`` are the first left and right singular vectors of
  ``M``, and ``δ`` maximises ``M``'s largest singular value (a search over one angle). The
  offset is observable because the segments swing about a horizontal axis: the vertical then
  moves through both sensor frames.
* :func:`fit_hinge_from_rates`: Seel, Raisch and Schauer, "IMU-based joint angle measurement for
  gait analysis" (Sensors 14, 2014), section 3.1: the angular rates ``ω1``, ``ω2`` (rad/s, each
  in its sensor frame) differ by a rotation about the axis alone, so their parts perpendicular
  to it have equal length, ``|ω1 × j1| − |ω2 × j2| = 0``; Gauss-Newton least squares, each
  unit axis moved in its tangent plane. It needs no heading at all, but a joint that also
  turns about other axes in step with its flexion (the knee's axial rotation while walking)
  pulls the axis of a segment that turns mostly about the hinge axis itself (the thigh) off,
  towards its long axis (``bench/bench_functional_calibration.py`` compares both).

The signs: the constraint fixes neither; :func:`consistent_signs` turns ``j2`` to point the
way ``j1`` does, and the joint's physics (the knee flexes one way) gives the sign of both
(:mod:`mimucap.core.functional_bodycal`).

Frames: each axis in its own sensor's frame; rates rad/s; quaternions scalar-first Hamilton
``q_world_from_sensor``, ``(N, 4)``; ``up_world`` (3,) the world's up unit vector.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mimucap.core import rotation as rot

FloatArray = NDArray[np.float64]

#: Gauss-Newton stops when the parameter step is below this (rad) or after MAX_ITERATIONS.
STEP_TOLERANCE_RAD = 1e-10
MAX_ITERATIONS = 100
#: Below this rate (rad/s) a cross product's length has no usable direction (its derivative).
_TINY_RATE = 1e-9
#: Fewest samples a fit accepts.
MIN_SAMPLES = 20
#: The largest heading offset sought (deg). An axis that stays horizontal cannot tell ``δ`` from
#: ``δ + 180°`` with ``j2`` reversed; two sensors' filters disagree far less than 90°.
MAX_HEADING_OFFSET_DEG = 90.0

ESTIMATORS = ("orientations", "rates")


def _tracks(q1: ArrayLike, q2: ArrayLike) -> tuple[FloatArray, FloatArray]:
    a = np.asarray(q1, dtype=np.float64)
    b = np.asarray(q2, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 4 or b.shape != a.shape:
        raise ValueError(f"a hinge fit needs two (N, 4) orientation tracks at the same instants, got {a.shape} "
                         f"and {b.shape}")
    return a, b


def angular_rates(t_s: ArrayLike, q_world_from_sensor: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Mean angular rate (rad/s, sensor frame) between consecutive orientations.

    ``t_s`` (N,) s, ``q_world_from_sensor`` (N, 4). Returns the indices (M,) of each interval's
    first sample and the rates (M, 3), ``ω = log(q_k⁻¹ ⊗ q_k+1) / (t_k+1 − t_k)``: the body rate
    in the sensor frame, what a bias-free gyroscope averages over the interval. Intervals with a
    non-finite orientation or a non-positive duration are left out."""
    t = np.asarray(t_s, dtype=np.float64)
    q = np.asarray(q_world_from_sensor, dtype=np.float64)
    if t.ndim != 1 or q.shape != (t.shape[0], 4):
        raise ValueError(f"angular_rates needs (N,) times and (N, 4) quaternions, got {t.shape} and {q.shape}")
    dt = np.diff(t)
    finite = np.all(np.isfinite(q), axis=1)
    index = np.flatnonzero((dt > 0.0) & finite[:-1] & finite[1:])
    rates = rot.to_rotvec(rot.multiply(rot.conjugate(q[index]), q[index + 1])) / dt[index][:, None]
    return index, rates


def heading_offset_rad(v1_world: ArrayLike, v2_world: ArrayLike, up_world: ArrayLike) -> float:
    """The turn ``δ`` (rad) about ``up_world`` (3,) that best carries the directions
    ``v2_world`` onto ``v1_world`` ((N, 3) each): ``max Σ v1 · R_up(δ) v2``, in closed form from
    their horizontal parts, ``atan2(Σ up · (v2 × v1), Σ v1_h · v2_h)``."""
    up = np.asarray(up_world, dtype=np.float64)
    a = np.asarray(v1_world, dtype=np.float64)
    b = np.asarray(v2_world, dtype=np.float64)
    a_h = a - np.outer(a @ up, up)
    b_h = b - np.outer(b @ up, up)
    return float(np.arctan2(np.sum(np.cross(b_h, a_h) @ up), np.sum(a_h * b_h)))


def fit_hinge_from_orientations(q_world_from_sensor1: ArrayLike, q_world_from_sensor2: ArrayLike,
                                up_world: ArrayLike = (0.0, 0.0, 1.0), find_offset: bool = True
                                ) -> tuple[FloatArray, FloatArray, float]:
    """``(j1, j2, δ)``: the hinge axis (3,) in each sensor's frame, pointing the same way, and the
    heading offset ``δ`` (rad, within ±:data:`MAX_HEADING_OFFSET_DEG`) of the second sensor about
    ``up_world``, from orientation tracks ``(N, 4)`` at the same instants (non-finite rows left
    out; at least :data:`MIN_SAMPLES`): least squares on the hinge constraint (module
    docstring). With ``find_offset`` False, ``δ = 0``: the sensors' headings are trusted (the
    offset is not observable when one segment keeps its orientation, as a still upper arm while
    the elbow flexes: a turn of the other sensor's heading is then taken up by the still one's
    axis).

    For a given ``δ`` the best axes give ``Σ (R1 j1)·(R_up(δ) R2 j2) = σ1(M(δ))``, the largest
    singular value of ``M(δ) = Σ R_1_from_world R_up(δ) R_world_from_2``, and
    ``R_up(δ) = P + cos δ (I − P) + sin δ [up]×`` (``P = up upᵀ``) makes ``M`` a combination of
    three sums computed once. ``σ1`` is maximised over ``δ`` on a 1° grid, then by Brent's
    method within a degree of the best grid point; the axes are ``M``'s first singular
    vectors there."""
    from scipy.optimize import minimize_scalar

    a, b = _tracks(q_world_from_sensor1, q_world_from_sensor2)
    up = np.asarray(up_world, dtype=np.float64)
    finite = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
    if int(finite.sum()) < MIN_SAMPLES:
        raise ValueError(f"a hinge fit needs at least {MIN_SAMPLES} samples, got {int(finite.sum())}")
    r1 = rot.to_matrix(a[finite])
    r2 = rot.to_matrix(b[finite])
    along = np.outer(up, up)
    cross = np.array([[0.0, -up[2], up[1]], [up[2], 0.0, -up[0]], [-up[1], up[0], 0.0]])
    parts = [np.einsum("nji,jk,nkl->il", r1, part, r2) for part in (along, np.eye(3) - along, cross)]

    def matrix(delta: float) -> FloatArray:
        return parts[0] + np.cos(delta) * parts[1] + np.sin(delta) * parts[2]

    def largest(delta: float) -> float:
        return float(np.linalg.svd(matrix(delta), compute_uv=False)[0])

    delta = 0.0
    if find_offset:
        grid = np.radians(np.arange(-MAX_HEADING_OFFSET_DEG, MAX_HEADING_OFFSET_DEG + 0.5, 1.0))
        best = float(grid[int(np.argmax([largest(d) for d in grid]))])
        step = np.radians(1.0)
        found = minimize_scalar(lambda d: -largest(d), bounds=(best - step, best + step), method="bounded",
                                options={"xatol": STEP_TOLERANCE_RAD})
        delta = float(found.x) if -found.fun >= largest(best) else best
    u, _s, vt = np.linalg.svd(matrix(delta))
    return u[:, 0], vt[0], delta


def _tangent_basis(j: FloatArray) -> tuple[FloatArray, FloatArray]:
    helper = np.eye(3)[int(np.argmin(np.abs(j)))]
    u = np.cross(j, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(j, u)


def _lengths_and_jacobian(rates: FloatArray, j: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``|ω × j|`` (N,) and its derivative (N, 2) along the tangent basis of ``j``."""
    cross = np.cross(rates, j)
    length = np.linalg.norm(cross, axis=1)
    # d|ω × j|/dj = ((ω × j) × ω) / |ω × j|
    gradient = np.cross(cross, rates) / np.maximum(length, _TINY_RATE)[:, None]
    u, v = _tangent_basis(j)
    return length, np.column_stack((gradient @ u, gradient @ v))


def _rates_cost(rates1: FloatArray, rates2: FloatArray, j1: FloatArray, j2: FloatArray) -> float:
    return float(np.sum((np.linalg.norm(np.cross(rates1, j1), axis=1)
                         - np.linalg.norm(np.cross(rates2, j2), axis=1)) ** 2))


def _gauss_newton(rates1: FloatArray, rates2: FloatArray, j1: FloatArray, j2: FloatArray
                  ) -> tuple[FloatArray, FloatArray, float]:
    current = _rates_cost(rates1, rates2, j1, j2)
    for _ in range(MAX_ITERATIONS):
        l1, d1 = _lengths_and_jacobian(rates1, j1)
        l2, d2 = _lengths_and_jacobian(rates2, j2)
        step, *_ = np.linalg.lstsq(np.hstack((d1, -d2)), l2 - l1, rcond=None)
        u1, v1 = _tangent_basis(j1)
        u2, v2 = _tangent_basis(j2)
        scale = 1.0
        while scale > 1e-6:  # halve the step until the cost does not grow
            a = j1 + scale * (step[0] * u1 + step[1] * v1)
            b = j2 + scale * (step[2] * u2 + step[3] * v2)
            a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
            trial = _rates_cost(rates1, rates2, a, b)
            if trial <= current:
                break
            scale *= 0.5
        else:
            break
        j1, j2, current = a, b, trial
        if scale * np.linalg.norm(step) < STEP_TOLERANCE_RAD:
            break
    return j1, j2, current


def _principal_axis(rates: FloatArray) -> FloatArray:
    _, vectors = np.linalg.eigh(rates.T @ rates)
    return vectors[:, -1]


def fit_hinge_from_rates(rates1_rad_s: ArrayLike, rates2_rad_s: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """``(j1, j2)``, the hinge axis (3,) in each sensor's frame (signs arbitrary), from the
    angular rates (N, 3) of both sensors at the same instants by Seel et al.'s constraint
    (module docstring). Gauss-Newton from several starts (each sensor's principal rotation
    axis, which is the hinge axis when the movement is mostly about it, and every pair of
    sensor axes); the least residual wins. ``ValueError`` when the segments did not move."""
    g1 = np.asarray(rates1_rad_s, dtype=np.float64)
    g2 = np.asarray(rates2_rad_s, dtype=np.float64)
    if g1.ndim != 2 or g1.shape[1] != 3 or g2.shape != g1.shape:
        raise ValueError(f"a hinge fit needs two (N, 3) rate arrays, got {g1.shape} and {g2.shape}")
    if g1.shape[0] < MIN_SAMPLES:
        raise ValueError(f"a hinge fit needs at least {MIN_SAMPLES} samples, got {g1.shape[0]}")
    if not (np.all(np.isfinite(g1)) and np.all(np.isfinite(g2))):
        raise ValueError("a hinge fit: non-finite angular rates")
    if max(float(np.abs(g1).max()), float(np.abs(g2).max())) < 1e-6:
        raise ValueError("a hinge fit: the segments did not move")
    starts = [(_principal_axis(g1), _principal_axis(g2))]
    starts += [(np.eye(3)[a], np.eye(3)[b]) for a in range(3) for b in range(3)]
    best = min((_gauss_newton(g1, g2, j1, j2) for j1, j2 in starts), key=lambda found: found[2])
    return best[0], best[1]


def consistent_signs(j1_sensor: ArrayLike, j2_sensor: ArrayLike, q_world_from_sensor1: ArrayLike,
                     q_world_from_sensor2: ArrayLike) -> tuple[FloatArray, float]:
    """``j2`` turned to point the way ``j1`` does, and the RMS angle (deg) between the two in the
    world.

    For a hinge ``R_world_from_1(t)·j1 = R_world_from_2(t)·j2`` at every instant (the second
    sensor's orientations already turned by any heading offset); the sign of ``j2`` is the one
    that makes them agree on average over the orientations given ((N, 4) each, same instants;
    non-finite rows left out). The RMS angle between them measures how well the movement
    agrees with a hinge."""
    a = rot.rotate(np.asarray(q_world_from_sensor1, dtype=np.float64), np.asarray(j1_sensor, dtype=np.float64))
    j2 = np.asarray(j2_sensor, dtype=np.float64)
    b = rot.rotate(np.asarray(q_world_from_sensor2, dtype=np.float64), j2)
    finite = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
    cos = np.sum(a[finite] * b[finite], axis=1)
    if not cos.size:
        raise ValueError("consistent_signs: no instant with both orientations")
    if float(np.mean(cos)) < 0.0:
        j2, cos = -j2, -cos
    return j2, float(np.degrees(np.sqrt(np.mean(np.arccos(np.clip(cos, -1.0, 1.0)) ** 2))))


def hinge_angle_rad(j1_sensor: ArrayLike, q_world_from_sensor1: ArrayLike, q_world_from_sensor2: ArrayLike,
                    q_sensor1_from_sensor2_reference: ArrayLike) -> FloatArray:
    """Signed rotation (rad, (N,)) of the second sensor relative to the first about ``j1``
    (first sensor's frame), counted from the reference relative orientation (4,)
    ``q_sensor1_from_sensor2`` (e.g. standing): the angle of ``q_rel(t) ⊗ q_rel(ref)⁻¹``, a
    rotation in the first sensor's frame, projected on the axis; positive counter-clockwise
    about ``j1``."""
    j1 = np.asarray(j1_sensor, dtype=np.float64)
    q_rel = rot.multiply(rot.conjugate(np.asarray(q_world_from_sensor1, dtype=np.float64)),
                         np.asarray(q_world_from_sensor2, dtype=np.float64))
    reference = rot.conjugate(np.asarray(q_sensor1_from_sensor2_reference, dtype=np.float64))
    delta = rot.canonical(rot.multiply(q_rel, reference))
    return 2.0 * np.arctan2(delta[..., 1:] @ j1, delta[..., 0])
