"""The simulated subject's pose at a set of instants, and how two poses are blended.

Frames: ``world`` ENU; ``body`` x forward, y up, z right (``skeleton.q_world_from_body_facing``);
the pelvis orientation is ``q_world_from_body_facing(heading) ⊗ q_body_from_pelvis``.
Joint angles are degrees (flexion, adduction, rotation) in the clinical signs of
``skeleton.JOINT_ANGLE_SIGNS_DOC`` (Z-X'-Y''), the input of
``skeleton.segment_orientations_from_joint_angles``. Heading: rad, 0 = facing north,
positive counter-clockwise seen from above. Positions: m.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mimucap.core import rotation as rot

_X, _Y, _Z = np.eye(3)
_TWO_PI = 2.0 * np.pi


@dataclass(frozen=True)
class BaseState:
    """Where an activity starts: heading (rad) and horizontal root position (m, world x/y)."""

    heading_rad: float = 0.0
    xy_m: tuple[float, float] = (0.0, 0.0)


@dataclass
class BodyPose:
    """The subject at ``n`` instants.

    ``heading_rad`` (n,); ``root_xy_m`` (n,2) horizontal position of the pelvis root (world);
    ``q_body_from_pelvis`` (n,4) pelvis tilt/obliquity/rotation relative to the heading;
    ``joint_angles_deg`` joint → (n,3) (flexion, adduction, rotation); ``plant`` (n,) in [0,1]:
    1 keeps the ankles' midpoint under the root (feet planted), 0 lets the root move freely;
    ``held`` sensor id → (n,) weight in [0,1] of being held in the hands rather than worn;
    ``bundle_q`` (n,4) ``q_world_from_bundle`` and ``bundle_p_m`` (n,3) of the held bundle,
    valid with weight ``bundle_weight`` (n,) (0: no bundle; identity and origin then);
    ``axis_turned`` (n,) int: bundle axis 0/1/2 being turned, −1 otherwise; ``ground`` (n,) in
    [0,1]: 1 sets the root height so that the lower ankle touches the ground, 0 uses the
    standing height plus ``root_dz_m`` (n,) (m) given by the activity; ``contact`` (n,2) in
    [0,1]: whether the left and right foot are on the ground (1) or in the air (0), the
    evaluation truth of gait events (initial contact where it rises through 0.5).
    """

    heading_rad: np.ndarray
    root_xy_m: np.ndarray
    q_body_from_pelvis: np.ndarray
    joint_angles_deg: dict[str, np.ndarray]
    plant: np.ndarray
    held: dict[str, np.ndarray] = field(default_factory=dict)
    bundle_q: np.ndarray | None = None
    bundle_p_m: np.ndarray | None = None
    bundle_weight: np.ndarray | None = None
    axis_turned: np.ndarray | None = None
    ground: np.ndarray | None = None
    root_dz_m: np.ndarray | None = None
    contact: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = self.plant.shape[0]
        if self.bundle_q is None:
            self.bundle_q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
            self.bundle_p_m = np.zeros((n, 3))
            self.bundle_weight = np.zeros(n)
        elif self.bundle_weight is None:
            self.bundle_weight = np.ones(n)
        if self.axis_turned is None:
            self.axis_turned = np.full(n, -1, dtype=np.int64)
        if self.ground is None:
            self.ground = np.ones(n)
        if self.root_dz_m is None:
            self.root_dz_m = np.zeros(n)
        if self.contact is None:
            self.contact = np.ones((n, 2))

    def take(self, index: np.ndarray) -> BodyPose:
        """The poses at ``index`` (boolean mask or integer indices)."""
        return BodyPose(
            heading_rad=self.heading_rad[index], root_xy_m=self.root_xy_m[index],
            q_body_from_pelvis=self.q_body_from_pelvis[index],
            joint_angles_deg={k: v[index] for k, v in self.joint_angles_deg.items()},
            plant=self.plant[index], held={k: v[index] for k, v in self.held.items()},
            bundle_q=self.bundle_q[index], bundle_p_m=self.bundle_p_m[index],
            bundle_weight=self.bundle_weight[index], axis_turned=self.axis_turned[index],
            ground=self.ground[index], root_dz_m=self.root_dz_m[index], contact=self.contact[index],
        )

    def put(self, index: np.ndarray, other: BodyPose) -> None:
        """Overwrite the poses at ``index`` with ``other`` (same joints and held sensors)."""
        self.heading_rad[index] = other.heading_rad
        self.root_xy_m[index] = other.root_xy_m
        self.q_body_from_pelvis[index] = other.q_body_from_pelvis
        for k in self.joint_angles_deg:
            self.joint_angles_deg[k][index] = other.joint_angles_deg[k]
        self.plant[index] = other.plant
        self.ground[index] = other.ground
        self.root_dz_m[index] = other.root_dz_m
        self.contact[index] = other.contact
        for k in self.held:
            self.held[k][index] = other.held[k]
        self.bundle_q[index] = other.bundle_q
        self.bundle_p_m[index] = other.bundle_p_m
        self.bundle_weight[index] = other.bundle_weight
        self.axis_turned[index] = other.axis_turned


def blend(previous: BodyPose, new: BodyPose, weight: np.ndarray) -> BodyPose:
    """Crossfade two poses of the same instants with ``weight`` (n,) (0: previous, 1: new)."""
    w = np.asarray(weight, dtype=np.float64)
    n = w.shape[0]
    mix = lambda a, b: a + (b - a) * w.reshape((n,) + (1,) * (np.ndim(a) - 1))  # noqa: E731
    joints = sorted(set(previous.joint_angles_deg) | set(new.joint_angles_deg))
    zero = np.zeros((n, 3))
    angles = {j: mix(previous.joint_angles_deg.get(j, zero), new.joint_angles_deg.get(j, zero)) for j in joints}
    held_ids = sorted(set(previous.held) | set(new.held))
    none = np.zeros(n)
    held = {s: mix(previous.held.get(s, none), new.held.get(s, none)) for s in held_ids}
    # The bundle pose moves towards the new one only as far as both are valid (row by row).
    towards_new = w * new.bundle_weight
    total = towards_new + (1.0 - w) * previous.bundle_weight
    share = np.divide(towards_new, total, out=np.zeros(n), where=total > 0.0)
    share = np.where(previous.bundle_weight > 0.0, share, 1.0)
    bundle_q = rot.slerp(previous.bundle_q, new.bundle_q, share)
    bundle_p = previous.bundle_p_m + (new.bundle_p_m - previous.bundle_p_m) * share[:, None]
    axis = np.where(w < 0.5, previous.axis_turned, new.axis_turned)
    return BodyPose(
        heading_rad=mix(previous.heading_rad, new.heading_rad),
        root_xy_m=mix(previous.root_xy_m, new.root_xy_m),
        q_body_from_pelvis=rot.slerp(previous.q_body_from_pelvis, new.q_body_from_pelvis, w),
        joint_angles_deg=angles, plant=mix(previous.plant, new.plant), held=held,
        bundle_q=bundle_q, bundle_p_m=bundle_p, bundle_weight=mix(previous.bundle_weight, new.bundle_weight),
        axis_turned=axis, ground=mix(previous.ground, new.ground), root_dz_m=mix(previous.root_dz_m, new.root_dz_m),
        contact=mix(previous.contact, new.contact),
    )


def pelvis_rotation(yaw_deg, obliquity_deg, lean_deg) -> np.ndarray:
    """``q_body_from_pelvis``: rotation about body y (yaw, positive turns left), then x
    (obliquity, positive drops the right side), then z (forward lean positive)."""
    q = rot.from_axis_angle(_Y, np.radians(yaw_deg))
    q = rot.multiply(q, rot.from_axis_angle(_X, np.radians(obliquity_deg)))
    return rot.multiply(q, rot.from_axis_angle(_Z, -np.radians(lean_deg)))


def standing_sway(tau: np.ndarray, amplitude_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Quiet-standing sway: small pelvis lean and obliquity (deg) at 0.2-0.35 Hz."""
    lean = amplitude_deg * np.sin(_TWO_PI * 0.23 * tau + 0.4)
    obliquity = 0.6 * amplitude_deg * np.sin(_TWO_PI * 0.31 * tau + 1.3)
    return lean, obliquity


def align_keys(target: BodyPose, source: BodyPose) -> None:
    """Give ``target`` and ``source`` the same joint and held-sensor keys (missing ones zero)."""
    for pose, other in ((target, source), (source, target)):
        n = pose.plant.shape[0]
        for joint in other.joint_angles_deg:
            pose.joint_angles_deg.setdefault(joint, np.zeros((n, 3)))
        for sensor_id in other.held:
            pose.held.setdefault(sensor_id, np.zeros(n))


def empty_pose_like(poses: list[BodyPose], n: int) -> BodyPose:
    """A pose of ``n`` instants (zeros, identity pelvis) carrying the keys of every one of ``poses``."""
    result = BodyPose(heading_rad=np.zeros(n), root_xy_m=np.zeros((n, 2)), q_body_from_pelvis=np.tile([1.0, 0, 0, 0], (n, 1)),
                      joint_angles_deg={}, plant=np.zeros(n))
    for pose in poses:
        align_keys(result, pose)
    return result
