"""Skeleton models, forward kinematics and joint angles.

Frames (``shared/docs/conventions.md``):

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

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mimucap.core import rotation as rot
from mimucap.resources import resources_root

FloatArray = NDArray[np.float64]

MODEL_NAMES = ("ten_segment", "fifteen_segment")
SHOULDER_SEQUENCES = ("zxy", "xzy", "yxy")

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


@dataclass(frozen=True)
class SegmentPose:
    """Where a segment is: proximal joint and distal end (m, world, ``(..., 3)``), orientation."""

    proximal_m: FloatArray
    distal_m: FloatArray
    q_world_from_segment: FloatArray


# --------------------------------------------------------------------------------------------
# Models
# --------------------------------------------------------------------------------------------

def _parse_model(data: object, origin: str) -> SkeletonModel:
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


def load_model(name_or_path: str | Path = "ten_segment") -> SkeletonModel:
    """Load a skeleton model by name (``"ten_segment"``, ``"fifteen_segment"``) or JSON path."""
    candidate = Path(name_or_path)
    if str(name_or_path) in MODEL_NAMES:
        # Packaged, read-only model data (resources/models); the only file core reads.
        candidate = resources_root() / "models" / f"{name_or_path}.json"
    elif not candidate.suffix:
        raise ValueError(f"unknown skeleton model {name_or_path!r}; use one of {', '.join(MODEL_NAMES)} or a JSON file")
    try:
        text = candidate.read_text(encoding="utf-8")
    except OSError as error:
        raise ValueError(f"cannot read skeleton model {candidate}: {error.strerror or error}") from error
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise ValueError(f"{candidate}: invalid JSON at line {error.lineno}: {error.msg}") from error
    return _parse_model(data, str(candidate))


def segment_lengths(model: SkeletonModel, height_m: float) -> dict[str, float]:
    """Segment lengths (m) for a subject of ``height_m`` metres."""
    if not np.isfinite(height_m) or not 0.5 <= height_m <= 2.5:
        raise ValueError(f"subject height must be between 0.5 and 2.5 m, got {height_m}")
    return {segment.name: segment.length_ratio * height_m for segment in model.segments}


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


def forward_kinematics(
    model: SkeletonModel,
    q_world_from_segment: Mapping[str, ArrayLike],
    height_m: float,
    root_position_m: ArrayLike | None = None,
) -> dict[str, SegmentPose]:
    """Joint positions of every segment given its orientation.

    ``q_world_from_segment`` maps each segment name to ``(..., 4)`` (all broadcastable);
    ``root_position_m`` is the root segment's proximal point (mid-point of the hip joint
    centres for the pelvis) in world metres, default ``(0, 0, root_height_ratio·height_m)``
    (feet on the floor in the N-pose). Returns a :class:`SegmentPose` per segment.
    """
    segment_lengths(model, height_m)  # validates the height
    missing = [name for name in model.segment_names if name not in q_world_from_segment]
    if missing:
        raise ValueError(f"forward kinematics needs an orientation for every segment; missing: {', '.join(missing)}")
    if root_position_m is None:
        root_position_m = np.array([0.0, 0.0, model.root_height_ratio * height_m])
    root = np.asarray(root_position_m, dtype=np.float64)
    poses: dict[str, SegmentPose] = {}
    for segment in model.segments:
        q = np.asarray(q_world_from_segment[segment.name], dtype=np.float64)
        if segment.parent is None:
            proximal = np.broadcast_to(root, np.broadcast_shapes(root.shape, q.shape[:-1] + (3,)))
        else:
            parent = poses[segment.parent]
            offset = rot.rotate(parent.q_world_from_segment, np.array(segment.attach_ratio) * height_m)
            proximal = parent.proximal_m + offset
        distal = proximal + rot.rotate(q, np.array(segment.direction) * segment.length_ratio * height_m)
        poses[segment.name] = SegmentPose(np.asarray(proximal, dtype=np.float64), distal, q)
    return poses


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


def joint_angle_columns(model: SkeletonModel, shoulder_sequence: str = "zxy") -> list[str]:
    """Column names ``<joint>_<axis>_deg`` in model order, three per joint."""
    seq = _check_shoulder_sequence(shoulder_sequence)
    return [f"{joint.name}_{axis}_deg" for joint in model.joints for axis in _axis_names(joint, seq)]


def _angles_of_rotation(joint: Joint, q_prox_from_dist: FloatArray, shoulder_sequence: str) -> FloatArray:
    """The three angles (deg, ``(..., 3)``) of one joint, in the order of :func:`_axis_names`."""
    q = mirror_sagittal(q_prox_from_dist) if joint.side == "l" else q_prox_from_dist
    if joint.kind == "shoulder" and shoulder_sequence == "xzy":
        return np.degrees(rot.to_euler(q, "XZY"))
    if joint.kind == "shoulder" and shoulder_sequence == "yxy":
        q_isb = rot.multiply(rot.multiply(rot.conjugate(_Q_Y_PI), q), _Q_Y_PI)
        return np.degrees(rot.to_euler(q_isb, "YXY"))
    angles = np.degrees(rot.to_euler(q, "ZXY"))
    return angles * np.array([FLEXION_SIGN.get(joint.kind, 1.0), 1.0, 1.0])


def joint_angles_deg(
    model: SkeletonModel,
    q_world_from_segment: Mapping[str, ArrayLike],
    shoulder_sequence: str = "zxy",
) -> dict[str, FloatArray]:
    """Joint angles (deg) keyed by column name (see :func:`joint_angle_columns`).

    Only joints whose two segments are present are returned; each value has the leading
    shape of the orientations.
    """
    seq = _check_shoulder_sequence(shoulder_sequence)
    columns: dict[str, FloatArray] = {}
    rotations = joint_rotations(model, q_world_from_segment)
    for joint in model.joints:
        if joint.name not in rotations:
            continue
        angles = _angles_of_rotation(joint, rotations[joint.name], seq)
        for index, axis in enumerate(_axis_names(joint, seq)):
            columns[f"{joint.name}_{axis}_deg"] = angles[..., index]
    return columns


def joint_rotation_from_angles(joint: Joint, angles_deg: ArrayLike) -> FloatArray:
    """``q_prox_from_dist`` of one joint from its (flexion, adduction, rotation) degrees (Z-X'-Y'')."""
    angles = np.asarray(angles_deg, dtype=np.float64)
    raw = np.radians(angles * np.array([FLEXION_SIGN.get(joint.kind, 1.0), 1.0, 1.0]))
    q = rot.from_euler(raw, "ZXY")
    return mirror_sagittal(q) if joint.side == "l" else q


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
