"""Skeleton models, forward kinematics and joint angles.

Frames (``docs/conventions.md``):

* ``world``: ENU, x east, y north, z up.
* ``body``: x forward, y up, z right (``z = x × y``).
* segment frames (ISB-like): x anterior, y superior along the long axis, z to the right. In the
  N-pose every segment frame equals the body frame, so every joint rotation is the identity
  and every joint angle is zero there.

Orientations are ``q_world_from_segment`` (scalar-first unit quaternions, ``(..., 4)``);
positions are metres in the world frame; joint angles are degrees at the edge (column names
end in ``_deg``).

Joint angles: the joint rotation ``q_prox_from_dist = q_world_from_prox⁻¹ ⊗ q_world_from_dist``
is decomposed as intrinsic Z-X'-Y'' (flexion about z, ab/adduction about the floating x, axial
rotation about y). Left-side joints are first mirrored across the sagittal plane
(``M R M`` with ``M = diag(1, 1, -1)``, i.e. quaternion ``[w, -x, -y, z]``), so that a movement
and its mirror image give the same numbers on both sides. Signs: see
:data:`JOINT_ANGLE_SIGNS_DOC`.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mimucap.core import rotation as rot
from mimucap.core.skeleton_models import BUILT_IN_MODELS, FOOT_LENGTH_RATIO, MODEL_NAMES, SHOULDER_SEQUENCES

FloatArray = NDArray[np.float64]


#: Joints whose raw z angle is negated so that clinical flexion is positive: the knee bends
#: backwards, and for the lumbar spine and the neck (distal segment above the joint) forward
#: bending is a negative rotation about z.
FLEXION_SIGN = {"knee": -1.0, "lumbar": -1.0, "neck": -1.0}

JOINT_ANGLE_SIGNS_DOC = """\
Joint angles in degrees. Joint rotation R_prox_from_dist = R_world_from_prox^-1 * R_world_from_dist,
intrinsic Z-X'-Y'' (ISB, Grood & Suntay): flexion/extension about z, ab/adduction about the floating x,
axial rotation about y. Zero in the calibrated N-pose. Left-side joints are mirrored across the sagittal
plane first, so a movement and its mirror image give the same numbers on both sides.
Signs (positive): hip, shoulder: flexion (forward); elbow, knee: flexion (bending; the knee's raw z angle
is negated); wrist: flexion (hand forward); ankle: dorsiflexion; lumbar, neck: forward flexion (raw z
negated); limbs: adduction (towards the midline) and internal rotation; lumbar, neck: lateral bending to
the right (x) and axial rotation to the left (y).
Shoulder X-Z'-Y'': adduction about x, then flexion about z', then internal rotation about y''.
Shoulder Y-X'-Y'' (ISB): plane of elevation (0 = abduction plane, 90 = forward flexion plane), elevation
(angle between humerus and thorax long axes, positive when raised), axial rotation (positive internal);
singular with the arm hanging down (plane of elevation is then reported as 0 and the whole axial rotation
as rotation)."""


@dataclass(frozen=True)
class Segment:
    """One rigid segment of a skeleton model.

    ``attach_ratio`` is the position of this segment's proximal joint in its parent's frame,
    measured from the parent's proximal joint, as a fraction of body height (shape (3,));
    ``direction`` is the unit vector in this segment's frame from its proximal joint to its
    distal end; ``length_ratio`` and ``radius_ratio`` are fractions of body height.
    """

    name: str
    parent: str | None
    joint: str | None
    side: str | None
    length_ratio: float
    attach_ratio: tuple[float, float, float]
    direction: tuple[float, float, float]
    radius_ratio: float


@dataclass(frozen=True)
class Joint:
    """A spherical joint between a proximal and a distal segment; ``side`` is "l", "r" or None."""

    name: str
    proximal: str
    distal: str
    side: str | None

    @property
    def kind(self) -> str:
        """The joint name without its side suffix (``"knee"`` for ``"knee_l"``)."""
        return self.name[:-2] if self.side else self.name


@dataclass(frozen=True)
class SkeletonModel:
    """A tree of segments, parents listed before their children."""

    name: str
    description: str
    root_height_ratio: float
    segments: tuple[Segment, ...]

    @property
    def segment_names(self) -> tuple[str, ...]:
        return tuple(segment.name for segment in self.segments)

    @property
    def joints(self) -> tuple[Joint, ...]:
        return tuple(
            Joint(s.joint, s.parent, s.name, s.side)
            for s in self.segments
            if s.joint is not None and s.parent is not None
        )

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(joint.name for joint in self.joints)

    @property
    def root(self) -> str:
        return self.segments[0].name

    def segment(self, name: str) -> Segment:
        for segment in self.segments:
            if segment.name == name:
                return segment
        raise ValueError(f"model {self.name!r} has no segment {name!r}; it has {', '.join(self.segment_names)}")

    def joint(self, name: str) -> Joint:
        for joint in self.joints:
            if joint.name == name:
                return joint
        raise ValueError(f"model {self.name!r} has no joint {name!r}; it has {', '.join(self.joint_names)}")

    @cached_property
    def tables(self) -> "ModelTables":
        """Index and ratio arrays of this model for the vectorised functions (built once)."""
        return ModelTables.of(self)


@dataclass(frozen=True, eq=False)
class ModelTables:
    """A :class:`SkeletonModel` as arrays, segment axis first, for vectorised kinematics.

    ``S`` segments in model order (parents first), ``J`` joints in :attr:`SkeletonModel.joints`
    order. Lengths are fractions of body height (multiply by ``height_m`` for metres).

    Attributes:
        parent_index: ``(S,)`` index of each segment's parent; the root points at itself.
        attach_ratio: ``(S, 3)`` each segment's proximal joint in its parent's frame (root: 0).
        distal_ratio: ``(S, 3)`` proximal joint → distal end in the segment's own frame
            (``direction · length_ratio``).
        body_ratio, body_frame: ``(2S, 3)`` the attachments then the distal vectors, and
            ``(2S,)`` the segment whose frame each is expressed in (parent, then own): forward
            kinematics turns them all into the world frame with one rotation call.
        levels: per depth in the tree (1, 2, ...): ``(segment indices, parent indices)``, so
            that one vectorised step per level walks the whole tree.
        joint_proximal, joint_distal: ``(J,)`` segment indices of each joint's two segments.
        joint_mirror: ``(J, 4)`` quaternion factors: ``[1, -1, -1, 1]`` mirrors a left-side
            joint across the sagittal plane (:func:`mirror_sagittal`), ones leave it as it is.
        joint_flexion_sign: ``(J, 3)`` factors of the Z-X'-Y'' angles (:data:`FLEXION_SIGN`).
        joint_is_shoulder: ``(J,)`` True for the joints a shoulder sequence applies to.
    """

    parent_index: NDArray[np.intp]
    attach_ratio: FloatArray
    distal_ratio: FloatArray
    body_ratio: FloatArray
    body_frame: NDArray[np.intp]
    levels: tuple[tuple[NDArray[np.intp], NDArray[np.intp]], ...]
    joint_proximal: NDArray[np.intp]
    joint_distal: NDArray[np.intp]
    joint_mirror: FloatArray
    joint_flexion_sign: FloatArray
    joint_is_shoulder: NDArray[np.bool_]

    @classmethod
    def of(cls, model: SkeletonModel) -> "ModelTables":
        index = {name: i for i, name in enumerate(model.segment_names)}
        parent = np.array([0 if s.parent is None else index[s.parent] for s in model.segments], dtype=np.intp)
        depth = [0] * len(model.segments)
        for i, segment in enumerate(model.segments):
            if segment.parent is not None:
                depth[i] = depth[index[segment.parent]] + 1
        levels = []
        for level in range(1, max(depth, default=0) + 1):
            members = np.array([i for i, d in enumerate(depth) if d == level], dtype=np.intp)
            levels.append((members, parent[members]))
        attach = np.array([s.attach_ratio if s.parent is not None else (0.0, 0.0, 0.0) for s in model.segments],
                          dtype=np.float64).reshape(-1, 3)
        # Same operation order as the per-segment formula: (direction · length_ratio) · height.
        distal = np.array([np.array(s.direction) * s.length_ratio for s in model.segments],
                          dtype=np.float64).reshape(-1, 3)
        joints = model.joints
        return cls(
            parent_index=parent,
            attach_ratio=attach,
            distal_ratio=distal,
            body_ratio=np.concatenate((attach, distal)),
            body_frame=np.concatenate((parent, np.arange(len(parent), dtype=np.intp))),
            levels=tuple(levels),
            joint_proximal=np.array([index[j.proximal] for j in joints], dtype=np.intp),
            joint_distal=np.array([index[j.distal] for j in joints], dtype=np.intp),
            joint_mirror=np.array([[1.0, -1.0, -1.0, 1.0] if j.side == "l" else [1.0] * 4 for j in joints],
                                  dtype=np.float64).reshape(-1, 4),
            joint_flexion_sign=np.array([[FLEXION_SIGN.get(j.kind, 1.0), 1.0, 1.0] for j in joints],
                                        dtype=np.float64).reshape(-1, 3),
            joint_is_shoulder=np.array([j.kind == "shoulder" for j in joints], dtype=bool),
        )


@dataclass(frozen=True)
class SegmentPose:
    """Where a segment is: proximal joint and distal end (m, world, ``(..., 3)``), orientation."""

    proximal_m: FloatArray
    distal_m: FloatArray
    q_world_from_segment: FloatArray


# --------------------------------------------------------------------------------------------
# Models
# --------------------------------------------------------------------------------------------

def model_from_dict(data: object, origin: str) -> SkeletonModel:
    """Check and build a :class:`SkeletonModel` from a ``mimucap-skeleton`` document (format
    version 1, see :mod:`mimucap.core.skeleton_models`); errors name ``origin``."""
    if not isinstance(data, dict) or data.get("format") != "mimucap-skeleton":
        raise ValueError(f"{origin}: not a MimuCap skeleton model (missing format 'mimucap-skeleton')")
    if data.get("format_version") != 1:
        raise ValueError(f"{origin}: unsupported skeleton model version {data.get('format_version')!r}")
    segments = []
    seen: set[str] = set()
    try:
        for index, item in enumerate(data["segments"]):
            segment = Segment(
                name=str(item["name"]),
                parent=item["parent"],
                joint=item["joint"],
                side=item["side"],
                length_ratio=float(item["length_ratio"]),
                attach_ratio=tuple(float(v) for v in item["attach_ratio"]),
                direction=tuple(float(v) for v in item["direction"]),
                radius_ratio=float(item["radius_ratio"]),
            )
            if index == 0 and segment.parent is not None:
                raise ValueError("the first segment must be the root (parent null)")
            if index > 0 and segment.parent not in seen:
                raise ValueError(f"segment {segment.name!r} lists parent {segment.parent!r} before it is defined")
            if len(segment.attach_ratio) != 3 or len(segment.direction) != 3:
                raise ValueError(f"segment {segment.name!r}: attach_ratio and direction need 3 values")
            if segment.side not in (None, "l", "r"):
                raise ValueError(f"segment {segment.name!r}: side must be 'l', 'r' or null")
            norm = float(np.linalg.norm(segment.direction))
            if not np.isfinite(norm) or norm == 0.0:
                raise ValueError(f"segment {segment.name!r}: direction must be a non-zero vector")
            segment = Segment(**{**segment.__dict__, "direction": tuple(np.array(segment.direction) / norm)})
            seen.add(segment.name)
            segments.append(segment)
        return SkeletonModel(
            name=str(data["name"]),
            description=str(data.get("description", "")),
            root_height_ratio=float(data["root_height_ratio"]),
            segments=tuple(segments),
        )
    except (KeyError, TypeError) as error:
        raise ValueError(f"{origin}: malformed skeleton model ({error!r})") from error
    except ValueError as error:
        raise ValueError(f"{origin}: {error}") from error


def load_model(name: str = "ten_segment") -> SkeletonModel:
    """The built-in skeleton model ``name`` (one of :data:`MODEL_NAMES`). A model of one's own,
    stored as JSON, is read by :func:`mimucap.io.skeleton_model_file.load_model`."""
    if name not in MODEL_NAMES:
        raise ValueError(f"unknown skeleton model {name!r}; use one of {', '.join(MODEL_NAMES)} or a JSON file")
    return _built_in_model(name)


@functools.lru_cache(maxsize=None)
def _built_in_model(name: str) -> SkeletonModel:
    return model_from_dict(BUILT_IN_MODELS[name], f"built-in model {name}")


def _stacked_orientations(model: SkeletonModel, q_world_from_segment: ArrayLike, what: str) -> FloatArray:
    """``q_world_from_segment`` as float ``(S, ..., 4)`` for the model's ``S`` segments, or a
    ``ValueError`` that starts with ``what``."""
    q = np.asarray(q_world_from_segment, dtype=np.float64)
    n_segments = len(model.tables.parent_index)
    if q.ndim < 2 or q.shape[0] != n_segments or q.shape[-1] != 4:
        raise ValueError(f"{what} orientations of shape ({n_segments}, ..., 4) in model order, got {q.shape}")
    return q


def _check_height(height_m: float) -> float:
    height = float(height_m)
    if not np.isfinite(height) or not 0.5 <= height <= 2.5:
        raise ValueError(f"subject height must be between 0.5 and 2.5 m, got {height_m}")
    return height


def segment_lengths(model: SkeletonModel, height_m: float) -> dict[str, float]:
    """Segment lengths (m) for a subject of ``height_m`` metres."""
    _check_height(height_m)
    return {segment.name: segment.length_ratio * height_m for segment in model.segments}


def foot_sole_m(height_m: float) -> tuple[FloatArray, FloatArray]:
    """The sole's heel and toe points (3,) m in the foot's frame, from the ankle, of a subject
    of ``height_m``: the toe at the end of the fifteen-segment model's foot, the heel a foot's
    length (:data:`~mimucap.core.skeleton_models.FOOT_LENGTH_RATIO`) behind it, the sole level
    in the N-pose (so both touch the floor standing). Every model uses these feet, whether or
    not it has a foot segment."""
    height = _check_height(height_m)
    foot = _built_in_model("fifteen_segment").segment("foot_r")
    toe = np.array(foot.direction) * foot.length_ratio * height
    return toe + np.array([-FOOT_LENGTH_RATIO * height, 0.0, 0.0]), toe


def q_world_from_body_facing(heading_rad: ArrayLike = 0.0) -> FloatArray:
    """Body frame (x forward, y up, z right) in the ENU world for a subject facing ``heading_rad``.

    Heading 0 faces north; positive headings turn counter-clockwise seen from above
    (``pi/2`` faces west). Shape ``(..., 4)`` following ``heading_rad``.
    """
    # Facing north: body x = north (world y), body y = up (world z), body z = east (world x).
    r_world_from_body_north = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    q_north = rot.from_matrix(r_world_from_body_north)
    q_turn = rot.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.asarray(heading_rad, dtype=np.float64))
    return rot.multiply(q_turn, q_north)


def forward_kinematics_stacked(
    model: SkeletonModel,
    q_world_from_segment: ArrayLike,
    height_m: float,
    root_position_m: ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Joint positions of every segment, vectorised over segments (segment axis first).

    Args:
        model: the skeleton model.
        q_world_from_segment: ``(S, ..., 4)`` scalar-first orientations of the ``S`` segments
            in model order (:attr:`SkeletonModel.segment_names`).
        height_m: the subject's height (m).
        root_position_m: ``(..., 3)`` the root segment's proximal point (world, m), default
            ``(0, 0, root_height_ratio·height_m)``.

    Returns:
        ``(proximal_m, distal_m)``, each ``(S, ..., 3)`` in the world frame (ENU, metres), the
        leading shape broadcast from the orientations and the root position. The same numbers
        as :func:`forward_kinematics`.
    """
    height = _check_height(height_m)
    tables = model.tables
    q = _stacked_orientations(model, q_world_from_segment, "forward kinematics needs")
    n_segments = q.shape[0]
    if root_position_m is None:
        root = np.array([0.0, 0.0, model.root_height_ratio * height])
    else:
        root = np.asarray(root_position_m, dtype=np.float64)
    lead = np.broadcast_shapes(q.shape[1:-1], root.shape[:-1])
    # Attachments (in the parents' frames) and distal vectors (own frames) to the world frame
    # at once, broadcast over the leading axes of the orientations.
    expand = (2 * n_segments,) + (1,) * (q.ndim - 2) + (3,)
    world = rot.rotate(q.take(tables.body_frame, axis=0), (tables.body_ratio * height).reshape(expand))
    offset, along = world[:n_segments], world[n_segments:]
    proximal = np.empty((n_segments,) + lead + (3,))
    proximal[0] = root
    for members, parents in tables.levels:
        proximal[members] = proximal[parents] + offset[members]
    return proximal, proximal + along


def forward_kinematics(
    model: SkeletonModel,
    q_world_from_segment: Mapping[str, ArrayLike],
    height_m: float,
    root_position_m: ArrayLike | None = None,
) -> dict[str, SegmentPose]:
    """Joint positions of every segment given its orientation.

    ``q_world_from_segment`` maps each segment name to ``(..., 4)`` (all broadcastable; the
    positions take the broadcast shape); ``root_position_m`` is the root segment's proximal
    point (mid-point of the hip joint centres for the pelvis) in world metres, default
    ``(0, 0, root_height_ratio·height_m)`` (feet on the floor in the N-pose). Returns a
    :class:`SegmentPose` per segment (see :func:`forward_kinematics_stacked` for arrays).
    """
    _check_height(height_m)
    missing = [name for name in model.segment_names if name not in q_world_from_segment]
    if missing:
        raise ValueError(f"forward kinematics needs an orientation for every segment; missing: {', '.join(missing)}")
    q_list = [np.asarray(q_world_from_segment[name], dtype=np.float64) for name in model.segment_names]
    proximal, distal = forward_kinematics_stacked(model, np.stack(np.broadcast_arrays(*q_list)), height_m,
                                                  root_position_m)
    return {name: SegmentPose(proximal[i], distal[i], q_list[i]) for i, name in enumerate(model.segment_names)}


# --------------------------------------------------------------------------------------------
# Joint rotations and angles
# --------------------------------------------------------------------------------------------

def joint_rotations(model: SkeletonModel, q_world_from_segment: Mapping[str, ArrayLike]) -> dict[str, FloatArray]:
    """``q_prox_from_dist = q_world_from_prox⁻¹ ⊗ q_world_from_dist`` for every joint whose two
    segments have orientations in ``q_world_from_segment``."""
    rotations: dict[str, FloatArray] = {}
    for joint in model.joints:
        if joint.proximal in q_world_from_segment and joint.distal in q_world_from_segment:
            q_prox = np.asarray(q_world_from_segment[joint.proximal], dtype=np.float64)
            q_dist = np.asarray(q_world_from_segment[joint.distal], dtype=np.float64)
            rotations[joint.name] = rot.multiply(rot.conjugate(q_prox), q_dist)
    return rotations


def mirror_sagittal(q: ArrayLike) -> FloatArray:
    """Mirror rotations across the sagittal (x-y) plane: ``M R M`` with ``M = diag(1, 1, -1)``.

    An involution: applying it twice gives the input back.
    """
    q = np.asarray(q, dtype=np.float64)
    return q * np.array([1.0, -1.0, -1.0, 1.0])


# Ry(pi) and its inverse: the ISB shoulder Y-X'-Y'' angles of R are the plain YXY angles of
# Ry(-pi) R Ry(pi), which puts plane of elevation 0 in the abduction plane and makes
# elevation positive for a raised arm (see JOINT_ANGLE_SIGNS_DOC).
_Q_Y_PI = np.array([0.0, 0.0, 1.0, 0.0])


def _check_shoulder_sequence(sequence: str) -> str:
    seq = sequence.lower()
    if seq not in SHOULDER_SEQUENCES:
        raise ValueError(f"unknown shoulder sequence {sequence!r}; use one of {', '.join(SHOULDER_SEQUENCES)}")
    return seq


def _axis_names(joint: Joint, shoulder_sequence: str) -> tuple[str, str, str]:
    if joint.kind == "shoulder" and shoulder_sequence == "xzy":
        return ("adduction", "flexion", "rotation")
    if joint.kind == "shoulder" and shoulder_sequence == "yxy":
        return ("plane_of_elevation", "elevation", "rotation")
    return ("flexion", "adduction", "rotation")


def middle_angle(joint: Joint, shoulder_sequence: str = "zxy") -> tuple[str, bool]:
    """The column of ``joint``'s middle Euler angle, and whether its sequence is a proper Euler
    one (singular at a middle angle of 0° or 180°; a Tait-Bryan one is singular at ±90°)."""
    seq = _check_shoulder_sequence(shoulder_sequence)
    axis = _axis_names(joint, seq)[1]
    return f"{joint.name}_{axis}_deg", joint.kind == "shoulder" and seq == "yxy"


def joint_angle_columns(model: SkeletonModel, shoulder_sequence: str = "zxy") -> list[str]:
    """Column names ``<joint>_<axis>_deg`` in model order, three per joint."""
    seq = _check_shoulder_sequence(shoulder_sequence)
    return [f"{joint.name}_{axis}_deg" for joint in model.joints for axis in _axis_names(joint, seq)]


def _angles_of_rotations(
    q_prox_from_dist: FloatArray,
    mirror: FloatArray,
    flexion_sign: FloatArray,
    is_shoulder: NDArray[np.bool_],
    shoulder_sequence: str,
) -> FloatArray:
    """The three angles (deg) of ``J`` joints at once, each in the order of :func:`_axis_names`.

    ``q_prox_from_dist`` is ``(J, ..., 4)``; ``mirror`` ``(J, 4)``, ``flexion_sign`` ``(J, 3)``
    and ``is_shoulder`` ``(J,)`` come from :class:`ModelTables`. Returns ``(J, ..., 3)``.
    """
    expand = (-1,) + (1,) * (q_prox_from_dist.ndim - 2)
    q = q_prox_from_dist * mirror.reshape(expand + (4,))  # left side mirrored (mirror_sagittal)
    if shoulder_sequence == "zxy" or not np.any(is_shoulder):
        return np.degrees(rot.to_euler(q, "ZXY")) * flexion_sign.reshape(expand + (3,))
    angles = np.empty(q.shape[:-1] + (3,))
    others = ~is_shoulder
    if np.any(others):
        angles[others] = np.degrees(rot.to_euler(q[others], "ZXY")) * flexion_sign[others].reshape(expand + (3,))
    shoulders = q[is_shoulder]
    if shoulder_sequence == "xzy":
        angles[is_shoulder] = np.degrees(rot.to_euler(shoulders, "XZY"))
    else:
        q_isb = rot.multiply(rot.multiply(rot.conjugate(_Q_Y_PI), shoulders), _Q_Y_PI)
        angles[is_shoulder] = np.degrees(rot.to_euler(q_isb, "YXY"))
    return angles


def joint_angles_deg_stacked(
    model: SkeletonModel,
    q_world_from_segment: ArrayLike,
    shoulder_sequence: str = "zxy",
) -> FloatArray:
    """Joint angles (deg) of every joint, vectorised over joints.

    Args:
        model: the skeleton model.
        q_world_from_segment: ``(S, ..., 4)`` scalar-first orientations of the ``S`` segments
            in model order (:attr:`SkeletonModel.segment_names`).
        shoulder_sequence: ``"zxy"``, ``"xzy"`` or ``"yxy"`` (see :data:`JOINT_ANGLE_SIGNS_DOC`).

    Returns:
        ``(J, ..., 3)`` degrees, joints in :attr:`SkeletonModel.joints` order, the three angles
        of each in the order of its columns (:func:`joint_angle_columns`): the numbers of
        :func:`joint_angles_deg`.
    """
    seq = _check_shoulder_sequence(shoulder_sequence)
    tables = model.tables
    q = _stacked_orientations(model, q_world_from_segment, "joint angles need")
    q_joint = rot.multiply(rot.conjugate(q[tables.joint_proximal]), q[tables.joint_distal])
    return _angles_of_rotations(q_joint, tables.joint_mirror, tables.joint_flexion_sign,
                                tables.joint_is_shoulder, seq)


def joint_angles_deg(
    model: SkeletonModel,
    q_world_from_segment: Mapping[str, ArrayLike],
    shoulder_sequence: str = "zxy",
) -> dict[str, FloatArray]:
    """Joint angles (deg) keyed by column name (see :func:`joint_angle_columns`).

    Only joints whose two segments are present are returned; each value has the leading
    shape of the orientations (broadcast over the segments). :func:`joint_angles_deg_stacked`
    takes and returns arrays.
    """
    seq = _check_shoulder_sequence(shoulder_sequence)
    tables = model.tables
    names = model.segment_names
    present = [i for i, name in enumerate(names) if name in q_world_from_segment]
    available = np.isin(tables.joint_proximal, present) & np.isin(tables.joint_distal, present)
    if not np.any(available):
        return {}
    # Stack the present segments only; ``position`` maps a model index into that stack.
    position = np.zeros(len(names), dtype=np.intp)
    position[present] = np.arange(len(present))
    q = np.stack(np.broadcast_arrays(
        *[np.asarray(q_world_from_segment[names[i]], dtype=np.float64) for i in present]))
    q_joint = rot.multiply(rot.conjugate(q[position[tables.joint_proximal[available]]]),
                           q[position[tables.joint_distal[available]]])
    angles = _angles_of_rotations(q_joint, tables.joint_mirror[available], tables.joint_flexion_sign[available],
                                  tables.joint_is_shoulder[available], seq)
    columns: dict[str, FloatArray] = {}
    joints = [joint for joint, keep in zip(model.joints, available) if keep]
    for j, joint in enumerate(joints):
        for index, axis in enumerate(_axis_names(joint, seq)):
            columns[f"{joint.name}_{axis}_deg"] = angles[j, ..., index]
    return columns


def joint_rotation_from_angles(joint: Joint, angles_deg: ArrayLike) -> FloatArray:
    """``q_prox_from_dist`` of one joint from its (flexion, adduction, rotation) degrees (Z-X'-Y'')."""
    angles = np.asarray(angles_deg, dtype=np.float64)
    raw = np.radians(angles * np.array([FLEXION_SIGN.get(joint.kind, 1.0), 1.0, 1.0]))
    q = rot.from_euler(raw, "ZXY")
    return mirror_sagittal(q) if joint.side == "l" else q


def joint_angles_from_rotation(joint: Joint, q_prox_from_dist: ArrayLike) -> FloatArray:
    """The (flexion, adduction, rotation) degrees (Z-X'-Y'') of one joint's rotation
    ``(..., 4)``: the inverse of :func:`joint_rotation_from_angles` (not for a shoulder in another
    sequence; see :func:`joint_angles_deg`)."""
    q = np.asarray(q_prox_from_dist, dtype=np.float64)
    if joint.side == "l":
        q = mirror_sagittal(q)
    return np.degrees(rot.to_euler(q, "ZXY")) * np.array([FLEXION_SIGN.get(joint.kind, 1.0), 1.0, 1.0])


def segment_orientations_from_joint_angles(
    model: SkeletonModel,
    q_world_from_root: ArrayLike,
    joint_angles: Mapping[str, ArrayLike],
) -> dict[str, FloatArray]:
    """Pose the skeleton: ``q_world_from_segment`` for every segment.

    ``q_world_from_root`` is the root segment's orientation ``(..., 4)``; ``joint_angles`` maps
    joint names to ``(..., 3)`` degrees (flexion, adduction, rotation) with the signs of
    :data:`JOINT_ANGLE_SIGNS_DOC` (Z-X'-Y'' for every joint). Joints not given stay at zero.
    The exact inverse of :func:`joint_angles_deg` with the default sequence.
    """
    unknown = sorted(set(joint_angles) - set(model.joint_names))
    if unknown:
        raise ValueError(f"model {model.name!r} has no joint(s) {', '.join(unknown)}")
    root = np.asarray(q_world_from_root, dtype=np.float64)
    orientations: dict[str, FloatArray] = {model.root: root}
    for segment in model.segments[1:]:
        joint = model.joint(segment.joint)
        q_parent = orientations[segment.parent]
        if segment.joint in joint_angles:
            q_joint = joint_rotation_from_angles(joint, joint_angles[segment.joint])
            orientations[segment.name] = rot.multiply(q_parent, q_joint)
        else:
            orientations[segment.name] = q_parent
    return orientations
