"""Quaternions, rotation matrices, rotation vectors and Euler sequences.

Conventions (``docs/conventions.md``):

* Hamilton quaternions, **scalar first** ``[w, x, y, z]``, float64 arrays of shape ``(..., 4)``,
  vectorised over every leading axis (inputs broadcast against each other).
* ``q_A_from_B`` maps the coordinates of a vector in frame B to frame A:
  ``v_A = rotate(q_A_from_B, v_B)``; composition reads left to right:
  ``q_A_from_C = multiply(q_A_from_B, q_B_from_C)``. The same holds for matrices
  ``R_A_from_B`` of shape ``(..., 3, 3)``.
* ``q`` and ``-q`` are the same rotation: compare rotations with :func:`angle_between`.
* Angles are radians; rotation vectors are ``axis * angle`` in radians, shape ``(..., 3)``.
* Euler sequences are **intrinsic** (each rotation about the axis of the frame already
  rotated): ``"ZXY"`` means ``R = Rz(a) @ Rx'(b) @ Ry''(c)``; supported are the joint-angle
  sequences ``"ZXY"``, ``"XZY"`` and ``"YXY"``. At the singular configurations (the middle
  angle ±90° for the Tait-Bryan sequences, 0° or 180° for Y-X'-Y'') the third angle is set
  to zero and the first one carries the whole rotation about the remaining free axis.

scipy's scalar-last ``Rotation`` is used nowhere else in MimuCap; this module does not need it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

#: Below this |sin| or |cos| of the middle Euler angle the decomposition is treated as singular.
EULER_SINGULARITY_EPS = 1e-9

EULER_SEQUENCES = ("ZXY", "XZY", "YXY")


def _as_quat(q: ArrayLike) -> FloatArray:
    array = np.asarray(q, dtype=np.float64)
    if array.shape[-1:] != (4,):
        raise ValueError(f"a quaternion array must have shape (..., 4), got {array.shape}")
    return array


def _as_vec3(v: ArrayLike, what: str = "vector") -> FloatArray:
    array = np.asarray(v, dtype=np.float64)
    if array.shape[-1:] != (3,):
        raise ValueError(f"a {what} array must have shape (..., 3), got {array.shape}")
    return array


def identity(shape: tuple[int, ...] = ()) -> FloatArray:
    """Identity quaternions of shape ``shape + (4,)``."""
    q = np.zeros(tuple(shape) + (4,))
    q[..., 0] = 1.0
    return q


def normalize(q: ArrayLike) -> FloatArray:
    """Unit quaternions ``q / |q|``; a zero or non-finite quaternion raises ``ValueError``."""
    q = _as_quat(q)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if not np.all(np.isfinite(norm)) or np.any(norm == 0.0):
        raise ValueError("cannot normalise a zero or non-finite quaternion")
    return q / norm


def canonical(q: ArrayLike) -> FloatArray:
    """The same rotations with a non-negative scalar part (``q`` or ``-q``)."""
    q = _as_quat(q)
    return np.where(q[..., :1] < 0.0, -q, q)


def multiply(q1: ArrayLike, q2: ArrayLike) -> FloatArray:
    """Hamilton product ``q1 ⊗ q2`` (``q_A_from_C = multiply(q_A_from_B, q_B_from_C)``)."""
    q1 = _as_quat(q1)
    q2 = _as_quat(q2)
    w1, x1, y1, z1 = q1[..., 0], q1[..., 1], q1[..., 2], q1[..., 3]
    w2, x2, y2, z2 = q2[..., 0], q2[..., 1], q2[..., 2], q2[..., 3]
    out = np.empty(np.broadcast_shapes(q1.shape, q2.shape))
    out[..., 0] = w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2
    out[..., 1] = w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2
    out[..., 2] = w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2
    out[..., 3] = w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2
    return out


def conjugate(q: ArrayLike) -> FloatArray:
    """Conjugate ``[w, -x, -y, -z]``: the inverse of a unit quaternion."""
    q = _as_quat(q)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def inverse(q: ArrayLike) -> FloatArray:
    """Inverse ``q* / |q|²`` (``q_B_from_A = inverse(q_A_from_B)``)."""
    q = _as_quat(q)
    return conjugate(q) / np.sum(q * q, axis=-1, keepdims=True)


def rotate(q_a_from_b: ArrayLike, v_b: ArrayLike) -> FloatArray:
    """Rotate vectors: ``v_A = q_A_from_B ⊗ v_B ⊗ q_A_from_B*`` for unit quaternions.

    Shapes ``(..., 4)`` and ``(..., 3)`` broadcast; returns ``(..., 3)``.
    """
    q = _as_quat(q_a_from_b)
    v = _as_vec3(v_b)
    w, ux, uy, uz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    vx, vy, vz = v[..., 0], v[..., 1], v[..., 2]
    # v' = v + w·t + u × t with t = 2 u × v (components written out: np.cross is slow on
    # the small arrays of live processing).
    tx = 2.0 * (uy * vz - uz * vy)
    ty = 2.0 * (uz * vx - ux * vz)
    tz = 2.0 * (ux * vy - uy * vx)
    out = np.empty(np.broadcast_shapes(q.shape[:-1] + (3,), v.shape))
    out[..., 0] = vx + w * tx + (uy * tz - uz * ty)
    out[..., 1] = vy + w * ty + (uz * tx - ux * tz)
    out[..., 2] = vz + w * tz + (ux * ty - uy * tx)
    return out


def heading_rad(q_world_from_frame: ArrayLike) -> FloatArray:
    """Heading ``(...)`` rad of a frame's x axis (a segment's anterior axis) projected on the
    world's ground plane (world ENU): 0 towards north, positive counter-clockwise seen from
    above, in [-π, π]; 0 where the x axis is vertical and has no heading."""
    x_world = rotate(q_world_from_frame, np.array([1.0, 0.0, 0.0]))
    east, north = x_world[..., 0], x_world[..., 1]
    return np.where(np.hypot(east, north) < 1e-9, 0.0, np.arctan2(-east, north))


def to_matrix(q: ArrayLike) -> FloatArray:
    """Rotation matrices ``R_A_from_B`` (``(..., 3, 3)``) of unit quaternions ``q_A_from_B``."""
    q = _as_quat(q)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    # Entries written into one array (stacking rows is slow on the small arrays of live use).
    r = np.empty(q.shape[:-1] + (3, 3))
    r[..., 0, 0] = 1.0 - 2.0 * (yy + zz)
    r[..., 0, 1] = 2.0 * (xy - wz)
    r[..., 0, 2] = 2.0 * (xz + wy)
    r[..., 1, 0] = 2.0 * (xy + wz)
    r[..., 1, 1] = 1.0 - 2.0 * (xx + zz)
    r[..., 1, 2] = 2.0 * (yz - wx)
    r[..., 2, 0] = 2.0 * (xz - wy)
    r[..., 2, 1] = 2.0 * (yz + wx)
    r[..., 2, 2] = 1.0 - 2.0 * (xx + yy)
    return r


def from_matrix(matrix: ArrayLike) -> FloatArray:
    """Unit quaternions (``w >= 0``) of rotation matrices ``(..., 3, 3)`` (Shepperd's method).

    The matrix should be orthonormal with determinant +1; small deviations are absorbed by
    the final normalisation.
    """
    m = np.asarray(matrix, dtype=np.float64)
    if m.shape[-2:] != (3, 3):
        raise ValueError(f"a rotation matrix array must have shape (..., 3, 3), got {m.shape}")
    m00, m01, m02 = m[..., 0, 0], m[..., 0, 1], m[..., 0, 2]
    m10, m11, m12 = m[..., 1, 0], m[..., 1, 1], m[..., 1, 2]
    m20, m21, m22 = m[..., 2, 0], m[..., 2, 1], m[..., 2, 2]
    trace = m00 + m11 + m22
    # Four candidate solutions, each well conditioned when its leading component is largest.
    candidates = np.stack(
        (
            np.stack((1.0 + trace, m21 - m12, m02 - m20, m10 - m01), axis=-1),
            np.stack((m21 - m12, 1.0 + m00 - m11 - m22, m01 + m10, m02 + m20), axis=-1),
            np.stack((m02 - m20, m01 + m10, 1.0 - m00 + m11 - m22, m12 + m21), axis=-1),
            np.stack((m10 - m01, m02 + m20, m12 + m21, 1.0 - m00 - m11 + m22), axis=-1),
        ),
        axis=-2,
    )
    choice = np.argmax(np.stack((trace, m00, m11, m22), axis=-1), axis=-1)
    q = np.take_along_axis(candidates, choice[..., None, None], axis=-2)[..., 0, :]
    return canonical(normalize(q))


def from_axis_angle(axis: ArrayLike, angle: ArrayLike) -> FloatArray:
    """Quaternions rotating by ``angle`` (rad) about ``axis`` (``(..., 3)``, any length > 0)."""
    axis = _as_vec3(axis, "rotation axis")
    norm = np.linalg.norm(axis, axis=-1, keepdims=True)
    if np.any(norm == 0.0):
        raise ValueError("a rotation axis must not be the zero vector")
    half = 0.5 * np.asarray(angle, dtype=np.float64)[..., None]
    return np.concatenate((np.cos(half), np.sin(half) * axis / norm), axis=-1)


def to_axis_angle(q: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Unit axis ``(..., 3)`` and angle in ``[0, π]`` (rad); the identity gives axis x."""
    rotvec = to_rotvec(q)
    angle = np.linalg.norm(rotvec, axis=-1)
    axis = np.zeros_like(rotvec)
    axis[..., 0] = 1.0
    nonzero = angle > 0.0
    axis[nonzero] = rotvec[nonzero] / angle[nonzero][..., None]
    return axis, angle


def from_rotvec(rotvec: ArrayLike) -> FloatArray:
    """Exponential map: rotation vectors ``(..., 3)`` (rad) to unit quaternions."""
    rotvec = _as_vec3(rotvec, "rotation vector")
    angle = np.linalg.norm(rotvec, axis=-1, keepdims=True)
    half = 0.5 * angle
    small = half < 1e-4
    safe_half = np.where(small, 1.0, half)
    # sin(h)/h by its Taylor series where h is tiny (error below 1e-18).
    sinc_half = np.where(small, 1.0 - half * half / 6.0, np.sin(safe_half) / safe_half)
    return np.concatenate((np.cos(half), 0.5 * sinc_half * rotvec), axis=-1)


def to_rotvec(q: ArrayLike) -> FloatArray:
    """Logarithm map: unit quaternions to rotation vectors ``(..., 3)`` with angle in [0, π]."""
    q = canonical(_as_quat(q))
    w = q[..., :1]
    u = q[..., 1:]
    n = np.linalg.norm(u, axis=-1, keepdims=True)
    small = n < 1e-8
    safe_n = np.where(small, 1.0, n)
    # angle/|u| = 2 atan2(n, w) / n, and 2/w (1 - n²/(3 w²)) when n is tiny (w ≈ 1).
    scale = np.where(
        small,
        2.0 / np.where(small, w, 1.0) * (1.0 - (n * n) / 3.0),
        2.0 * np.arctan2(n, w) / safe_n,
    )
    return scale * u


exp = from_rotvec
log = to_rotvec


def slerp(q0: ArrayLike, q1: ArrayLike, t: ArrayLike) -> FloatArray:
    """Spherical linear interpolation along the shorter arc; ``t`` in [0, 1] broadcasts.

    ``slerp(q0, q1, 0) == q0`` and ``slerp(q0, q1, 1)`` is ``q1`` (possibly as ``-q1``).
    """
    q0 = _as_quat(q0)
    q1 = _as_quat(q1)
    t = np.asarray(t, dtype=np.float64)[..., None]
    delta = multiply(conjugate(q0), q1)
    return multiply(q0, from_rotvec(t * to_rotvec(delta)))


def angle_between(q1: ArrayLike, q2: ArrayLike) -> FloatArray:
    """Rotation angle (rad, in [0, π]) between orientations, sign-invariant: ``angle(q1⁻¹ ⊗ q2)``."""
    delta = multiply(conjugate(_as_quat(q1)), _as_quat(q2))
    return 2.0 * np.arctan2(np.linalg.norm(delta[..., 1:], axis=-1), np.abs(delta[..., 0]))


def average(q: ArrayLike, weights: ArrayLike | None = None) -> FloatArray:
    """Mean orientation of ``q`` (``(..., N, 4)``) over its second-last axis.

    Markley's eigenvector method: the eigenvector of ``Σ wᵢ qᵢ qᵢᵀ`` with the largest
    eigenvalue; insensitive to the sign of each ``qᵢ``. ``weights`` has shape ``(..., N)``
    (default: equal). Returns ``(..., 4)`` with ``w >= 0``.
    """
    q = _as_quat(q)
    if q.ndim < 2 or q.shape[-2] == 0:
        raise ValueError("average needs at least one quaternion along axis -2")
    if weights is None:
        weights = np.ones(q.shape[:-1])
    weights = np.asarray(weights, dtype=np.float64)
    outer = np.einsum("...n,...ni,...nj->...ij", weights, q, q)
    _, vectors = np.linalg.eigh(outer)
    return canonical(vectors[..., :, -1])


# --------------------------------------------------------------------------------------------
# Euler sequences (intrinsic)
# --------------------------------------------------------------------------------------------

def _axis_rotation_matrix(axis: str, angle: FloatArray) -> FloatArray:
    c, s = np.cos(angle), np.sin(angle)
    one, zero = np.ones_like(angle), np.zeros_like(angle)
    if axis == "X":
        rows = ((one, zero, zero), (zero, c, -s), (zero, s, c))
    elif axis == "Y":
        rows = ((c, zero, s), (zero, one, zero), (-s, zero, c))
    else:
        rows = ((c, -s, zero), (s, c, zero), (zero, zero, one))
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def _check_sequence(sequence: str) -> str:
    seq = sequence.upper()
    if seq not in EULER_SEQUENCES:
        raise ValueError(
            f"unsupported Euler sequence {sequence!r}; use one of {', '.join(EULER_SEQUENCES)}"
        )
    return seq


def from_euler(angles: ArrayLike, sequence: str = "ZXY") -> FloatArray:
    """Quaternions from intrinsic Euler angles ``(..., 3)`` (rad) in ``sequence``.

    ``from_euler([a, b, c], "ZXY")`` is ``Rz(a) ⊗ Rx'(b) ⊗ Ry''(c)``.
    """
    seq = _check_sequence(sequence)
    angles = _as_vec3(angles, "Euler angle")
    unit = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
    q = from_axis_angle(np.array(unit[seq[0]]), angles[..., 0])
    for index in (1, 2):
        q = multiply(q, from_axis_angle(np.array(unit[seq[index]]), angles[..., index]))
    return q


def to_euler(q: ArrayLike, sequence: str = "ZXY") -> FloatArray:
    """Intrinsic Euler angles ``(..., 3)`` (rad) of unit quaternions in ``sequence``.

    Ranges: Tait-Bryan ``ZXY``/``XZY``: first and third in (-π, π], middle in [-π/2, π/2];
    proper ``YXY``: first and third in (-π, π], middle in [0, π]. Singular cases: see the
    module docstring.
    """
    seq = _check_sequence(sequence)
    r = to_matrix(normalize(q))
    if seq == "ZXY":
        # R = Rz(a) Rx(b) Ry(c): R21 = sin b, R01 = -sin a cos b, R11 = cos a cos b,
        # R20 = -cos b sin c, R22 = cos b cos c.
        middle = np.arctan2(r[..., 2, 1], np.hypot(r[..., 2, 0], r[..., 2, 2]))
        first = np.arctan2(-r[..., 0, 1], r[..., 1, 1])
        third = np.arctan2(-r[..., 2, 0], r[..., 2, 2])
        singular = np.abs(np.cos(middle)) < EULER_SINGULARITY_EPS
        # With c = 0: R = Rz(a) Rx(±π/2): R00 = cos a, R10 = sin a.
        first_singular = np.arctan2(r[..., 1, 0], r[..., 0, 0])
    elif seq == "XZY":
        # R = Rx(a) Rz(b) Ry(c): R01 = -sin b, R21 = sin a cos b, R11 = cos a cos b,
        # R02 = cos b sin c, R00 = cos b cos c.
        middle = np.arctan2(-r[..., 0, 1], np.hypot(r[..., 0, 0], r[..., 0, 2]))
        first = np.arctan2(r[..., 2, 1], r[..., 1, 1])
        third = np.arctan2(r[..., 0, 2], r[..., 0, 0])
        singular = np.abs(np.cos(middle)) < EULER_SINGULARITY_EPS
        # With c = 0: R = Rx(a) Rz(±π/2): R12 = -sin a, R22 = cos a.
        first_singular = np.arctan2(-r[..., 1, 2], r[..., 2, 2])
    else:
        # R = Ry(a) Rx(b) Ry(c): R11 = cos b, R01 = sin a sin b, R21 = cos a sin b,
        # R10 = sin b sin c, R12 = -sin b cos c.
        middle = np.arctan2(np.hypot(r[..., 0, 1], r[..., 2, 1]), r[..., 1, 1])
        first = np.arctan2(r[..., 0, 1], r[..., 2, 1])
        third = np.arctan2(r[..., 1, 0], -r[..., 1, 2])
        singular = np.abs(np.sin(middle)) < EULER_SINGULARITY_EPS
        # With c = 0: b = 0 gives Ry(a) (R02 = sin a, R00 = cos a); b = π gives
        # Ry(a) Rx(π) (R02 = -sin a, R00 = cos a).
        sign = np.where(r[..., 1, 1] > 0.0, 1.0, -1.0)
        first_singular = np.arctan2(sign * r[..., 0, 2], r[..., 0, 0])
    first = np.where(singular, first_singular, first)
    third = np.where(singular, 0.0, third)
    return np.stack((first, middle, third), axis=-1)


def euler_matrix(angles: ArrayLike, sequence: str = "ZXY") -> FloatArray:
    """Rotation matrices ``(..., 3, 3)`` of intrinsic Euler angles, as products of axis matrices."""
    seq = _check_sequence(sequence)
    angles = _as_vec3(angles, "Euler angle")
    result = _axis_rotation_matrix(seq[0], angles[..., 0])
    for index in (1, 2):
        result = result @ _axis_rotation_matrix(seq[index], angles[..., index])
    return result
