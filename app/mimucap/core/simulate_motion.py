"""Scripted human motion for the simulated suit: activities, their joint-angle curves, blending.

An *activity* (standing N-pose, T-pose, walking, turning, arm raises, squats, holding sensors
for a magnetometer calibration) maps local time ``tau`` (s since it started) and its start
state (heading and horizontal position) to a :class:`BodyPose`: the subject's heading, the
pelvis orientation relative to the heading, joint angles, and optionally the pose of a bundle
of sensors held in the hands. A :class:`Schedule` strings activities together and blends each
new one in over :data:`BLEND_S` seconds (1 s when walking starts or stops; minimum-jerk
weights), so poses, velocities and
accelerations stay continuous.

Frames: ``world`` ENU; ``body`` x forward, y up, z right (``skeleton.q_world_from_body_facing``);
the pelvis orientation is ``q_world_from_body_facing(heading) ⊗ q_body_from_pelvis``.
Joint angles are degrees (flexion, adduction, rotation) in the clinical signs of
``skeleton.JOINT_ANGLE_SIGNS_DOC`` (Z-X'-Y''), the input of
``skeleton.segment_orientations_from_joint_angles``. Heading: rad, 0 = facing north,
positive counter-clockwise seen from above. Positions: m.
"""

from __future__ import annotations

import bisect
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np

from mimucap.core import phases
from mimucap.core import rotation as rot
from mimucap.core.simulate_calibration import HAND_HEIGHT_M, HAND_PATHS
from mimucap.core.simulate_names import ACTIVITY_NAMES, SCENARIOS
from mimucap.core.simulate_sensors import minimum_jerk

#: Seconds over which a new activity is blended in.
BLEND_S = 0.5
#: Height (m) and distance in front of the pelvis (m) at which hand-held sensors are turned.
HELD_HEIGHT_M = 1.05
HELD_FORWARD_M = 0.35

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


def _zeros_angles(n: int, joints: tuple[str, ...]) -> dict[str, np.ndarray]:
    return {joint: np.zeros((n, 3)) for joint in joints}


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


def _periodic_bump(phase: np.ndarray, centre: float, width: float) -> np.ndarray:
    """Gaussian bump on the unit circle of gait phase (centre and width in cycles)."""
    d = (phase - centre + 0.5) % 1.0 - 0.5
    return np.exp(-(d / width) ** 2)


def _pelvis(yaw_deg, obliquity_deg, lean_deg) -> np.ndarray:
    """``q_body_from_pelvis``: rotation about body y (yaw, positive turns left), then x
    (obliquity, positive drops the right side), then z (forward lean positive)."""
    q = rot.from_axis_angle(_Y, np.radians(yaw_deg))
    q = rot.multiply(q, rot.from_axis_angle(_X, np.radians(obliquity_deg)))
    return rot.multiply(q, rot.from_axis_angle(_Z, -np.radians(lean_deg)))


def _sway(tau: np.ndarray, amplitude_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Quiet-standing sway: small pelvis lean and obliquity (deg) at 0.2-0.35 Hz."""
    lean = amplitude_deg * np.sin(_TWO_PI * 0.23 * tau + 0.4)
    obliquity = 0.6 * amplitude_deg * np.sin(_TWO_PI * 0.31 * tau + 1.3)
    return lean, obliquity


class Activity(ABC):
    """Base of all activities: ``duration_s`` (None: indefinite) and :meth:`pose`."""

    name = "activity"
    #: Label of the marker written where the activity starts (:mod:`mimucap.core.phases`).
    marker = "activity"
    duration_s: float | None = None
    #: Seconds over which this activity is blended in, and over which the next one replaces it
    #: (the longer of the two applies).
    blend_in_s = BLEND_S
    blend_out_s = BLEND_S

    @abstractmethod
    def pose(self, tau: np.ndarray, start: BaseState) -> BodyPose:
        """The subject at local times ``tau`` (n,) s for an activity that started in ``start``."""

    def _standing(self, tau: np.ndarray, start: BaseState, sway_deg: float) -> BodyPose:
        n = tau.shape[0]
        lean, obliquity = _sway(tau, sway_deg)
        return BodyPose(
            heading_rad=np.full(n, start.heading_rad), root_xy_m=np.tile(start.xy_m, (n, 1)),
            q_body_from_pelvis=_pelvis(np.zeros(n), obliquity, lean), joint_angles_deg={},
            plant=np.ones(n),
        )

    def describe(self) -> str:
        return self.name

    def marker_label(self) -> str:
        """The label of the marker at this activity's start, as a person would write it."""
        return self.marker


def _check_arms(arms: str) -> tuple[str, ...]:
    options = {"right": ("r",), "left": ("l",), "both": ("l", "r")}
    if arms not in options:
        raise ValueError(f"arms must be right, left or both, got {arms!r}")
    return options[arms]


class NPose(Activity):
    """Standing upright, arms hanging, palms in: every segment frame parallel to the body frame,
    with quiet-standing sway of ``sway_deg`` (0 for a perfectly still subject)."""

    name = "npose"
    marker = phases.NPOSE

    def __init__(self, duration_s: float | None = None, sway_deg: float = 0.3) -> None:
        self.duration_s = duration_s
        self.sway_deg = float(sway_deg)

    def pose(self, tau, start):
        return self._standing(tau, start, self.sway_deg)


class TPose(Activity):
    """Arms raised sideways to ``angle_deg`` (default 88°: Z-X'-Y'' is singular at exactly 90°)
    in ``raise_s`` seconds (minimum jerk), then held; ``arms`` right, left or both."""

    name = "tpose"
    marker = phases.TPOSE

    def __init__(self, duration_s: float | None = None, arms: str = "both", angle_deg: float = 88.0,
                 raise_s: float = 1.5, sway_deg: float = 0.3) -> None:
        self.sides = _check_arms(arms)
        if not 0.0 < angle_deg < 90.0:
            raise ValueError(f"T-pose abduction must be between 0 and 90° (exclusive), got {angle_deg}")
        self.arms, self.duration_s, self.angle_deg = arms, duration_s, float(angle_deg)
        self.raise_s, self.sway_deg = float(raise_s), float(sway_deg)

    def pose(self, tau, start):
        pose = self._standing(tau, start, self.sway_deg)
        abduction = self.angle_deg * minimum_jerk(tau / self.raise_s)
        for side in self.sides:
            angles = np.zeros((tau.shape[0], 3))
            angles[:, 1] = -abduction
            pose.joint_angles_deg[f"shoulder_{side}"] = angles
        return pose

    def describe(self) -> str:
        return f"tpose({self.arms})"

    def marker_label(self) -> str:
        return self.marker if self.arms == "both" else f"{self.marker} ({self.arms} arm)"


#: Leg segment lengths (thigh, shank) in m of the default subject (1.75 m, ten-segment ratios).
DEFAULT_LEG_LENGTHS_M = (0.245 * 1.75, 0.246 * 1.75)
_GAIT_GRID = 512
_GAIT_HARMONICS = 40


#: Gait phase of toe-off (heel strike at 0) of every simulated leg.
TOE_OFF_PHASE = 0.62


def stance_weight_right(phase: np.ndarray) -> np.ndarray:
    """Share (0..1) of the right foot in carrying the body at gait ``phase`` (right heel strike
    at 0, toe-off at 0.62; the left foot carries the rest): single support 0.12-0.5, smooth
    hand-overs in the double-support phases 0-0.12 and 0.5-0.62."""
    p = np.asarray(phase, dtype=np.float64) % 1.0
    return minimum_jerk(p / 0.12) - minimum_jerk((p - 0.5) / 0.12)


class Walk(Activity):
    """Level walking at ``speed_mps`` with feet that stay put while they carry the body.

    Joint-angle curves (right leg; phase 0 = right heel strike, the left leg half a cycle
    later), after the typical sagittal gait curves (Perry & Burnfield; Winter): hip flexion
    about +30° at heel strike to −10° at 50 %; knee flexion 5° at heel strike, a loading-
    response peak of ~17° at 15 %, ~6° at 40 %, 38° at toe-off and 60° in swing at 70 %;
    ankle plantar-flexion of about −15° at toe-off; arm swing ±20° opposite to the legs with the
    elbow flexed 10-30°; pelvis rotation ±5°, obliquity ±4°, thorax counter-rotation.

    Progression: the root moves forward exactly as far as the carrying foot moves backward
    relative to it (sagittal leg geometry with ``leg_lengths_m`` = (thigh, shank), the share
    of each foot from :func:`stance_weight_right`), so the stance foot does not slide; this
    fixes the stride length, and the stride duration ``stride_s`` follows from ``speed_mps``
    (about 1.09 s at 1.2 m/s for a 1.75 m subject). The forward speed fluctuates within the
    stride (about 0.8-1.5 m/s at a mean of 1.2 m/s). Sideways the pelvis sways ±2.5 cm
    towards the carrying foot (the feet may slide sideways by a few centimetres). Vertically the root oscillates by ±2 cm around 3.5 cm below its
    standing height, lowest in double support. ``turn_rate_dps`` walks along a circle.
    """

    name = "walk"
    marker = phases.WALK
    blend_in_s = 1.0  # gait initiation and termination take about one step
    blend_out_s = 1.0

    def __init__(self, duration_s: float | None = None, speed_mps: float = 1.2, turn_rate_dps: float = 0.0,
                 leg_lengths_m: tuple[float, float] = DEFAULT_LEG_LENGTHS_M) -> None:
        if not 0.3 <= speed_mps <= 2.5:
            raise ValueError(f"walking speed must be in 0.3..2.5 m/s, got {speed_mps}")
        self.duration_s, self.speed = duration_s, float(speed_mps)
        self.turn_rate = math.radians(turn_rate_dps)
        self.fit_legs(leg_lengths_m)

    def fit_legs(self, leg_lengths_m: tuple[float, float]) -> Walk:
        """Use the subject's (thigh, shank) lengths in m for the progression; returns self."""
        thigh, shank = (float(v) for v in leg_lengths_m)
        if not (0.1 < thigh < 1.0 and 0.1 < shank < 1.0):
            raise ValueError(f"leg lengths must be 0.1..1 m, got {leg_lengths_m}")
        phase = np.arange(_GAIT_GRID) / _GAIT_GRID
        lean = self.trunk(phase)[2]
        forward = {}
        for side, shift in (("r", 0.0), ("l", 0.5)):
            leg = self.leg((phase + shift) % 1.0)
            thigh_angle = np.radians(leg["hip"][:, 0] - lean)
            shank_angle = thigh_angle - np.radians(leg["knee"][:, 0])
            forward[side] = thigh * np.sin(thigh_angle) + shank * np.sin(shank_angle)
        step = 2.0 / _GAIT_GRID
        rate = {side: (np.roll(x, -1) - np.roll(x, 1)) / step for side, x in forward.items()}
        weight = stance_weight_right(phase)
        advance_per_phase = -(weight * rate["r"] + (1.0 - weight) * rate["l"])
        self.stride_m = float(advance_per_phase.mean())
        self.stride_s = self.stride_m / self.speed
        if not 0.5 <= self.stride_s <= 3.0:
            raise ValueError(f"walking at {self.speed} m/s needs a stride of {self.stride_s:.2f} s, outside 0.5..3 s")
        coefficients = np.fft.rfft(advance_per_phase - self.stride_m)[1:_GAIT_HARMONICS + 1] / _GAIT_GRID
        k = np.arange(1, coefficients.shape[0] + 1)
        # ∫ 2 Re(C_k e^{2πikφ}) dφ = 2 Re(C_k / (2πik) e^{2πikφ})
        self._integral = 2.0 * coefficients / (2j * np.pi * k)
        self._k = k
        self._offset = float(np.real(self._integral.sum()))
        return self

    def _distance(self, tau: np.ndarray) -> np.ndarray:
        """Forward distance (m) covered after ``tau`` seconds."""
        cycles = tau / self.stride_s
        angle = _TWO_PI * np.outer(cycles % 1.0, self._k)
        # Row-wise sums (not a matrix product, whose rounding could depend on the row count).
        periodic = (np.cos(angle) * np.real(self._integral)).sum(axis=1) - (np.sin(angle) * np.imag(self._integral)).sum(axis=1)
        return self.stride_m * cycles + periodic - self._offset

    @staticmethod
    def leg(phase: np.ndarray) -> dict[str, np.ndarray]:
        """Hip, knee and ankle angles (n,3) deg of one leg at its own gait ``phase``."""
        hip = np.stack((10.0 + 20.0 * np.cos(_TWO_PI * (phase - 0.04)),
                        5.0 * np.sin(_TWO_PI * (phase + 0.1)),
                        4.0 * np.cos(_TWO_PI * phase)), axis=-1)
        knee_flexion = (5.0 + 12.0 * _periodic_bump(phase, 0.15, 0.14) + 55.0 * _periodic_bump(phase, 0.70, 0.14))
        knee = np.stack((knee_flexion, np.zeros_like(phase), 3.0 * np.cos(_TWO_PI * phase)), axis=-1)
        ankle_flexion = (2.0 - 7.0 * _periodic_bump(phase, 0.05, 0.05) + 10.0 * _periodic_bump(phase, 0.42, 0.12)
                         - 17.0 * _periodic_bump(phase, 0.63, 0.06))
        ankle = np.stack((ankle_flexion, np.zeros_like(phase), np.zeros_like(phase)), axis=-1)
        return {"hip": hip, "knee": knee, "ankle": ankle}

    @staticmethod
    def arm(phase: np.ndarray) -> dict[str, np.ndarray]:
        """One arm, given the gait phase of the *opposite* leg: the arm swings forward with it."""
        swing = np.cos(_TWO_PI * phase)
        shoulder = np.stack((3.0 + 20.0 * swing, np.full_like(phase, -6.0), np.zeros_like(phase)), axis=-1)
        elbow = np.stack((20.0 + 10.0 * swing, np.zeros_like(phase), np.zeros_like(phase)), axis=-1)
        wrist = np.stack((5.0 + 3.0 * swing, np.zeros_like(phase), np.zeros_like(phase)), axis=-1)
        return {"shoulder": shoulder, "elbow": elbow, "wrist": wrist}

    @staticmethod
    def trunk(phase: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pelvis yaw, obliquity (positive: right side down) and forward lean (deg) at the right
        leg's gait ``phase``: in right stance the left (swinging) side drops."""
        yaw = 5.0 * np.cos(_TWO_PI * phase)
        obliquity = -4.0 * np.sin(_TWO_PI * (phase + 0.1))  # the swinging side drops
        lean = 4.0 + 1.5 * np.cos(2.0 * _TWO_PI * (phase - 0.1))
        return yaw, obliquity, lean

    def pose(self, tau, start):
        n = tau.shape[0]
        phase = (tau / self.stride_s) % 1.0
        heading = start.heading_rad + self.turn_rate * tau
        distance = self._distance(tau)
        if self.turn_rate == 0.0:
            forward = np.array([-math.sin(start.heading_rad), math.cos(start.heading_rad)])
            xy = np.asarray(start.xy_m) + distance[:, None] * forward
        else:
            # Along a circle of radius speed / turn rate: d(x, y)/ds = (-sin ψ, cos ψ).
            radius = self.speed / self.turn_rate
            along = start.heading_rad + distance / radius
            xy = np.asarray(start.xy_m) + radius * np.stack(
                (np.cos(along) - math.cos(start.heading_rad), np.sin(along) - math.sin(start.heading_rad)), axis=-1
            )
        # Sideways sway towards the carrying foot: right of the line of progression in right stance.
        sway = 0.025 * np.sin(_TWO_PI * (phase - 0.06))
        right = np.stack((np.cos(heading), np.sin(heading)), axis=-1)
        xy = xy + sway[:, None] * right
        angles: dict[str, np.ndarray] = {}
        for side, shift in (("r", 0.0), ("l", 0.5)):
            for kind, value in self.leg((phase + shift) % 1.0).items():
                angles[f"{kind}_{side}"] = value
            for kind, value in self.arm((phase + shift + 0.5) % 1.0).items():
                angles[f"{kind}_{side}"] = value
        yaw, obliquity, lean = self.trunk(phase)
        angles["lumbar"] = np.stack((np.full(n, 2.0), -0.7 * obliquity, -0.8 * yaw), axis=-1)
        angles["neck"] = np.stack((np.full(n, -4.0), np.zeros(n), -0.2 * yaw), axis=-1)
        root_dz = -0.035 + 0.02 * np.cos(2.0 * _TWO_PI * (phase - 0.3))
        # Each foot is on the ground from its heel strike (own phase 0) to its toe-off (0.62).
        contact = np.stack([((phase + shift) % 1.0 < TOE_OFF_PHASE).astype(float) for shift in (0.5, 0.0)], axis=-1)
        return BodyPose(heading_rad=heading, root_xy_m=xy, q_body_from_pelvis=_pelvis(yaw, obliquity, lean),
                        joint_angles_deg=angles, plant=np.zeros(n), ground=np.zeros(n), root_dz_m=root_dz,
                        contact=contact)


class Turn(Activity):
    """Turning on the spot by ``angle_deg`` (positive: to the left, counter-clockwise from above)
    in ``turn_s`` seconds with small stepping, then standing ``pause_s``; repeated ``turns``
    times (None: forever)."""

    name = "turn"
    marker = phases.TURN

    def __init__(self, duration_s: float | None = None, angle_deg: float = 180.0, turn_s: float = 2.5,
                 pause_s: float = 1.0, turns: int | None = None) -> None:
        if turn_s <= 0.5 or pause_s < 0:
            raise ValueError("turn_s must exceed 0.5 s and pause_s be >= 0")
        self.angle = math.radians(angle_deg)
        self.turn_s, self.pause_s = float(turn_s), float(pause_s)
        period = self.turn_s + self.pause_s
        self.duration_s = duration_s if duration_s is not None else (None if turns is None else turns * period)

    def pose(self, tau, start):
        pose = self._standing(tau, start, 0.2)
        period = self.turn_s + self.pause_s
        cycle, within = np.divmod(tau, period)
        progress = minimum_jerk(within / self.turn_s)
        pose.heading_rad = start.heading_rad + self.angle * (cycle + progress)
        # Stepping: alternate legs lift (hip and knee flex) while turning, four steps per turn.
        stepping = np.where(within < self.turn_s, np.sin(np.pi * within / self.turn_s) ** 2, 0.0)
        step_phase = 2.0 * within / self.turn_s
        pose.contact = np.ones((tau.shape[0], 2))
        for column, (side, shift) in ((1, ("r", 0.0)), (0, ("l", 0.5))):
            lift = stepping * np.maximum(0.0, np.sin(_TWO_PI * (step_phase + shift))) ** 2
            pose.contact[:, column] = (lift <= 0.0).astype(float)
            zeros = np.zeros_like(tau)
            pose.joint_angles_deg[f"hip_{side}"] = np.stack((20.0 * lift, zeros, zeros), axis=-1)
            pose.joint_angles_deg[f"knee_{side}"] = np.stack((40.0 * lift, zeros, zeros), axis=-1)
            pose.joint_angles_deg[f"ankle_{side}"] = np.stack((20.0 * lift, zeros, zeros), axis=-1)  # foot level
        return pose


class _Cyclic(Activity):
    """Raise over ``move_s``, hold ``hold_s``, lower over ``move_s``, rest ``rest_s``; ``cycles`` times."""

    def _setup(self, duration_s, cycles, move_s, hold_s, rest_s):
        if move_s <= 0 or hold_s < 0 or rest_s < 0:
            raise ValueError("move_s must be > 0 and hold_s, rest_s >= 0")
        self.move_s, self.hold_s, self.rest_s = float(move_s), float(hold_s), float(rest_s)
        self.period = 2 * self.move_s + self.hold_s + self.rest_s
        self.duration_s = duration_s if duration_s is not None else (None if cycles is None else cycles * self.period)

    def level(self, tau: np.ndarray) -> np.ndarray:
        """Movement level in [0, 1] over the cycle."""
        within = tau % self.period
        up = minimum_jerk(within / self.move_s)
        down = minimum_jerk((within - self.move_s - self.hold_s) / self.move_s)
        return up - down


class ArmRaise(_Cyclic):
    """Raising the arms to ``angle_deg`` and back: ``plane`` "flexion" (forward, up to 170°) or
    "abduction" (sideways, below 90°: Z-X'-Y'' is singular at 90°); ``arms`` right/left/both."""

    name = "arm_raise"
    marker = phases.ARM_RAISE

    def __init__(self, duration_s: float | None = None, arms: str = "both", plane: str = "flexion",
                 angle_deg: float = 150.0, cycles: int | None = None, move_s: float = 1.5,
                 hold_s: float = 0.5, rest_s: float = 0.5) -> None:
        self.sides = _check_arms(arms)
        if plane not in ("flexion", "abduction"):
            raise ValueError(f"arm raise plane must be flexion or abduction, got {plane!r}")
        limit = 170.0 if plane == "flexion" else 89.0
        if not 0.0 < angle_deg <= limit:
            raise ValueError(f"arm raise in the {plane} plane must be between 0 and {limit}°, got {angle_deg}")
        self.arms, self.plane, self.angle_deg = arms, plane, float(angle_deg)
        self._setup(duration_s, cycles, move_s, hold_s, rest_s)

    def pose(self, tau, start):
        pose = self._standing(tau, start, 0.3)
        level = self.level(tau)
        for side in self.sides:
            angles = np.zeros((tau.shape[0], 3))
            if self.plane == "flexion":
                angles[:, 0] = self.angle_deg * level
            else:
                angles[:, 1] = -self.angle_deg * level
            pose.joint_angles_deg[f"shoulder_{side}"] = angles
            pose.joint_angles_deg[f"elbow_{side}"] = np.stack((10.0 * level, 0 * level, 0 * level), axis=-1)
        return pose

    def describe(self) -> str:
        return f"arm_raise({self.arms},{self.plane})"


class Squat(_Cyclic):
    """Squats with the feet planted and flat: at full ``depth`` (0..1, default 0.8) the pelvis
    and trunk lean 30° forward, the hips flex 110° (thighs 80° from vertical), the knees 110°
    (shanks 30° forward), the ankles dorsiflex 30° and the arms reach forward 80°."""

    name = "squat"
    marker = phases.SQUAT

    def __init__(self, duration_s: float | None = None, depth: float = 0.8, cycles: int | None = None,
                 move_s: float = 1.4, hold_s: float = 0.3, rest_s: float = 0.4) -> None:
        if not 0.0 < depth <= 1.0:
            raise ValueError(f"squat depth must be in (0, 1], got {depth}")
        self.depth = float(depth)
        self._setup(duration_s, cycles, move_s, hold_s, rest_s)

    def pose(self, tau, start):
        pose = self._standing(tau, start, 0.0)
        s = self.depth * self.level(tau)
        zeros = np.zeros_like(tau)
        pose.q_body_from_pelvis = _pelvis(zeros, zeros, 30.0 * s)
        for side in ("l", "r"):
            pose.joint_angles_deg[f"hip_{side}"] = np.stack((110.0 * s, -4.0 * s, zeros), axis=-1)
            pose.joint_angles_deg[f"knee_{side}"] = np.stack((110.0 * s, zeros, zeros), axis=-1)
            pose.joint_angles_deg[f"ankle_{side}"] = np.stack((30.0 * s, zeros, zeros), axis=-1)
            pose.joint_angles_deg[f"shoulder_{side}"] = np.stack((80.0 * s, zeros, zeros), axis=-1)
            pose.joint_angles_deg[f"elbow_{side}"] = np.stack((10.0 * s, zeros, zeros), axis=-1)
        pose.joint_angles_deg["lumbar"] = np.stack((10.0 * s, zeros, zeros), axis=-1)
        pose.joint_angles_deg["neck"] = np.stack((-25.0 * s, zeros, zeros), axis=-1)
        return pose


class JointExcursion(_Cyclic):
    """One joint moved along one axis to ``angle_deg`` and back, as in a range-of-motion test
    (shoulder flexion, elbow flexion, hip abduction, trunk rotation, ...): ``joint`` a model
    joint (``shoulder_r``, ``lumbar``, ...), ``axis`` flexion, adduction or rotation, ``angle_deg``
    the peak in the clinical signs of ``skeleton.JOINT_ANGLE_SIGNS_DOC`` (abduction is negative
    adduction), repeated ``cycles`` times; standing otherwise still."""

    name = "rom"

    def __init__(self, duration_s: float | None = None, joint: str = "elbow_r", axis: str = "flexion",
                 angle_deg: float = 120.0, cycles: int | None = None, move_s: float = 1.5,
                 hold_s: float = 0.5, rest_s: float = 0.5) -> None:
        axes = ("flexion", "adduction", "rotation")
        if axis not in axes:
            raise ValueError(f"ROM axis must be one of {', '.join(axes)}, got {axis!r}")
        if not 0.0 < abs(angle_deg) <= 180.0:
            raise ValueError(f"ROM angle must be within ±180° and not 0, got {angle_deg}")
        self.joint, self.axis, self.angle_deg = str(joint), axis, float(angle_deg)
        self._setup(duration_s, cycles, move_s, hold_s, rest_s)

    def pose(self, tau, start):
        pose = self._standing(tau, start, 0.2)
        angles = np.zeros((tau.shape[0], 3))
        angles[:, ("flexion", "adduction", "rotation").index(self.axis)] = self.angle_deg * self.level(tau)
        pose.joint_angles_deg[self.joint] = angles
        return pose

    def describe(self) -> str:
        return f"rom({self.joint},{self.axis})"


class HoldSensors(Activity):
    """Standing while turning a bundle of sensors held in the hands (magnetometer calibration).

    ``protocol`` "single_axis" (``turns`` turns about bundle x, then y, then z, each roughly
    horizontal), "figure8" or "tumble" (see :mod:`mimucap.core.simulate_calibration`);
    ``sensor_ids`` the units held (all, if empty). The bundle is held 0.35 m in front of the
    pelvis at 1.05 m; after the protocol it is held still. Picking the units up from the body
    and putting them back is blended over 1 s.
    """

    blend_in_s = 1.0  # picking the sensors up and putting them back takes a moment
    blend_out_s = 1.0

    def __init__(self, protocol: str, duration_s: float | None = None, sensor_ids: tuple[str, ...] = (),
                 turns: int = 1, seed: int = 0) -> None:
        if protocol not in HAND_PATHS:
            raise ValueError(f"unknown hand-held protocol {protocol!r}")
        if int(turns) != turns or not 1 <= turns <= 5:
            raise ValueError(f"turns must be an integer from 1 to 5, got {turns}")
        self.name = f"mag_{protocol}"
        self.marker = {"single_axis": phases.MAG_TURNS, "figure8": phases.MAG_FIGURE8,
                       "tumble": phases.MAG_TUMBLE}[protocol]
        self.protocol = protocol
        self.sensor_ids = tuple(sensor_ids)
        self.path = HAND_PATHS[protocol](np.random.default_rng([int(seed) & 0xFFFFFFFF, 404]), int(turns))
        self.duration_s = duration_s

    def pose(self, tau, start):
        pose = self._standing(tau, start, 0.2)
        clamped = np.minimum(tau, self.path.duration_s)
        q, p = self.path(clamped)
        forward = np.array([-math.sin(start.heading_rad), math.cos(start.heading_rad), 0.0])
        centre = np.array([start.xy_m[0], start.xy_m[1], HELD_HEIGHT_M]) + HELD_FORWARD_M * forward
        pose.bundle_q = q
        pose.bundle_p_m = centre + (p - np.array([0.0, 0.0, HAND_HEIGHT_M]))
        pose.bundle_weight = np.ones(tau.shape[0])
        if self.protocol == "single_axis":
            _, axis = self.path.base(clamped)
            pose.axis_turned = np.where(tau <= self.path.duration_s, axis, -1)
        else:
            pose.axis_turned = np.full(tau.shape, -1, dtype=np.int64)
        for sensor_id in self.sensor_ids:
            pose.held[sensor_id] = np.ones(tau.shape[0])
        return pose

    def describe(self) -> str:
        return f"{self.name}({','.join(self.sensor_ids)})"




def make_activity(name: str, params: dict | None = None, *, sensor_ids: tuple[str, ...] = (), seed: int = 0) -> Activity:
    """Build an activity by name with keyword ``params``; unknown names or parameters raise
    ``ValueError``. Hand-held activities default to holding ``sensor_ids``."""
    params = dict(params or {})
    factories: dict[str, Callable[..., Activity]] = {
        "npose": NPose, "tpose": TPose, "walk": Walk, "turn": Turn, "arm_raise": ArmRaise, "squat": Squat,
        "rom": JointExcursion,
    }
    try:
        if name in factories:
            return factories[name](**params)
        if name.startswith("mag_") and name[4:] in ("single_axis", "figure8", "tumble"):
            params["sensor_ids"] = tuple(params.get("sensor_ids") or sensor_ids)
            return HoldSensors(name[4:], seed=seed, **params)
    except TypeError as error:
        raise ValueError(f"activity {name!r}: {error}") from None
    raise ValueError(f"unknown activity {name!r}; use one of {', '.join(ACTIVITY_NAMES + ('demo',))}")


def demo_cycle() -> list[Activity]:
    """One loop of the demo: N-pose 3 s, T-pose 3 s, N-pose 2 s, walk 8 s, turn 180°, walk
    back 8 s, turn 180°, two squats, two forward arm raises (about 50 s)."""
    return [
        NPose(3.0), TPose(3.0, arms="both"), NPose(2.0), Walk(8.0), Turn(turns=1, angle_deg=180.0, pause_s=0.5),
        Walk(8.0), Turn(turns=1, angle_deg=-180.0, pause_s=0.5), Squat(cycles=2), ArmRaise(cycles=2),
    ]




def _demo_loop() -> Iterator[Activity]:
    while True:
        yield from demo_cycle()


def magcal_turns(sensor_ids: tuple[str, ...] = (), seed: int = 0) -> HoldSensors:
    """The magnetometer turns of a session's start: every unit (``sensor_ids``; all if empty)
    taken off the body, held together and turned one full turn about its x, then y, then z axis
    (the single-axis protocol of Choe, Zhao, Qiu and So, "Study of calibration method of
    low-cost MEMS magnetometer"), about 26 s; the units are put back by the next activity."""
    turns = HoldSensors("single_axis", sensor_ids=tuple(sensor_ids), turns=1, seed=seed)
    turns.duration_s = turns.path.duration_s
    return turns


def _after_magcal_turns(activities: Iterator[Activity], turns: HoldSensors) -> Iterator[Activity]:
    """``turns``, then ``activities``; a first N-pose of fixed length is lengthened by the time
    the units take to be put back on the body, so that it still holds its full still time."""
    yield turns
    first = next(activities, None)
    if first is None:
        return
    if isinstance(first, NPose) and first.duration_s is not None:
        first.duration_s += turns.blend_out_s
    yield first
    yield from activities


def scenario_activities(name: str, params: dict | None = None, *, sensor_ids: tuple[str, ...] = (),
                        seed: int = 0, with_magcal_turns: bool = False) -> Iterator[Activity]:
    """The activities of a scenario in order (an endless iterator for ``demo``).

    ``demo`` loops :func:`demo_cycle`; ``bodycal`` is N-pose 3 s, T-pose 3 s (``params`` go to
    the T-pose), then N-pose; any activity name is that activity alone, preceded by 1 s of
    N-pose unless it is ``npose``. With ``with_magcal_turns`` the scenario begins with
    :func:`magcal_turns` of ``sensor_ids``. Parameters are checked here, before anything runs.
    """
    activities = _scenario(name, params, sensor_ids, seed)
    if with_magcal_turns:
        return _after_magcal_turns(activities, magcal_turns(sensor_ids, seed))
    return activities


def _scenario(name: str, params: dict | None, sensor_ids: tuple[str, ...], seed: int) -> Iterator[Activity]:
    if name == "demo":
        if params:
            raise ValueError("the demo scenario takes no parameters")
        return _demo_loop()
    if name == "bodycal":
        try:
            tpose = TPose(3.0, **(params or {}))
        except TypeError as error:
            raise ValueError(f"scenario 'bodycal': {error}") from None
        return iter([NPose(3.0), tpose, NPose()])
    activity = make_activity(name, params, sensor_ids=sensor_ids, seed=seed)
    activity.duration_s = None
    if name == "npose":
        return iter([activity])
    return iter([NPose(1.0, sway_deg=0.0 if name.startswith("mag_") else 0.3), activity])


@dataclass
class _Entry:
    start_s: float
    activity: Activity
    state: BaseState
    label: str
    marker: str
    blend_s: float
    #: Whether this entry's poses may include a hand-held bundle (it or a predecessor holds one).
    carries_bundle: bool


class Schedule:
    """Activities on a timeline, extended lazily from an iterator; poses at any times.

    ``pose(t)`` is a pure function of ``t`` for the entries already placed: evaluating the same
    time twice gives identical results, whatever else was evaluated in between.
    """

    def __init__(self, activities: Iterator[Activity], start_s: float = 0.0, state: BaseState = BaseState()) -> None:
        self._entries: list[_Entry] = []
        self._starts: list[float] = []
        self._source: Iterator[Activity] | None = iter(activities)
        self._pending_start = start_s
        self._pending_state = state
        self._append_next()

    @property
    def entries(self) -> list[tuple[float, str]]:
        """(start time, label) of every activity placed so far."""
        return [(e.start_s, e.label) for e in self._entries]

    @property
    def markers(self) -> list[tuple[float, str]]:
        """(start time, marker label) of every activity placed so far."""
        return [(e.start_s, e.marker) for e in self._entries]

    def _append_next(self) -> bool:
        if self._source is None:
            return False
        try:
            activity = next(self._source)
        except StopIteration:
            self._source = None
            return False
        self._add(self._pending_start, activity)
        return True

    def _add(self, start_s: float, activity: Activity) -> None:
        blend_s = activity.blend_in_s
        if self._entries:
            pose = self._pose_of_entry(len(self._entries) - 1, np.array([start_s]))
            state = BaseState(float(pose.heading_rad[0]), (float(pose.root_xy_m[0, 0]), float(pose.root_xy_m[0, 1])))
            blend_s = max(blend_s, self._entries[-1].activity.blend_out_s)
        else:
            state = self._pending_state
        carries = isinstance(activity, HoldSensors) or bool(self._entries and self._entries[-1].carries_bundle)
        self._entries.append(_Entry(start_s, activity, state, activity.describe(), activity.marker_label(),
                                    blend_s, carries))
        self._starts.append(start_s)
        if activity.duration_s is not None:
            self._pending_start = start_s + activity.duration_s

    def extend_to(self, t_s: float) -> None:
        """Place scripted activities until the timeline covers ``t_s``."""
        while self._source is not None and self._entries[-1].activity.duration_s is not None \
                and self._pending_start <= t_s:
            if not self._append_next():
                break

    def switch(self, t_s: float, activities: Iterator[Activity]) -> None:
        """From ``t_s`` on, follow ``activities`` instead (blended in; later scripted entries dropped)."""
        keep = bisect.bisect_right(self._starts, t_s)
        if keep == 0:
            raise ValueError("cannot switch activity before the schedule starts")
        del self._entries[keep:]
        del self._starts[keep:]
        self._source = iter(activities)
        self._pending_start = t_s
        self._append_next()

    def forget_before(self, t_s: float) -> None:
        """Drop activities no longer needed for times at or after ``t_s`` (bounded memory when
        streaming for hours); later poses are unchanged.

        Entry ``j`` consults entry ``j-1`` only for times in ``[start_j, start_j + blend_j)``
        (including the warped times of a bundle being put down, which are ≥ ``start_j``), so
        walking back from the entry running at ``t_s`` finds the oldest entry still needed.
        """
        if not self._entries:
            return
        keep = max(bisect.bisect_right(self._starts, t_s) - 1, 0)
        lowest = t_s
        while keep > 0 and lowest < self._entries[keep].start_s + self._entries[keep].blend_s:
            lowest = min(lowest, self._entries[keep].start_s)
            keep -= 1
        if keep:
            del self._entries[:keep]
            del self._starts[:keep]

    def _pose_of_entry(self, index: int, t: np.ndarray) -> BodyPose:
        entry = self._entries[index]
        tau = t - entry.start_s
        pose = entry.activity.pose(tau, entry.state)
        if index == 0:
            return pose
        weight = minimum_jerk(tau / entry.blend_s)
        partial = weight < 1.0
        if not np.any(partial):
            return pose
        if self._entries[index - 1].carries_bundle:
            # A bundle being put down (or handed to the next activity) slows to a stop during
            # the blend: its previous motion is followed on the warped clock start + B·(x − x²/2),
            # x = tau / B, which starts at full speed and ends at rest.
            x = np.clip(tau[partial] / entry.blend_s, 0.0, 1.0)
            warped = entry.start_s + entry.blend_s * (x - 0.5 * x * x)
            k = x.shape[0]
            both = self._pose_of_entry(index - 1, np.concatenate((t[partial], warped)))
            previous, slowed = both.take(np.arange(k)), both.take(np.arange(k, 2 * k))
            previous.bundle_q, previous.bundle_p_m = slowed.bundle_q, slowed.bundle_p_m
            previous.bundle_weight, previous.axis_turned = slowed.bundle_weight, np.full(k, -1, dtype=np.int64)
        else:
            previous = self._pose_of_entry(index - 1, t[partial])
        blended = blend(previous, pose.take(partial), weight[partial])
        if np.all(partial):
            return blended
        # Make both sides carry the same joints and held sensors before writing back.
        full = blend(pose, pose, np.zeros(t.shape[0]))
        _align_keys(full, blended)
        full.put(partial, blended)
        return full

    def pose(self, t_s: np.ndarray) -> BodyPose:
        """The subject at times ``t_s`` (m,) (any order, at or after the schedule start)."""
        t = np.asarray(t_s, dtype=np.float64)
        self.extend_to(float(t.max()))
        index = np.searchsorted(np.asarray(self._starts), t, side="right") - 1
        if np.any(index < 0):
            index = np.maximum(index, 0)
        pieces = [(i, index == i) for i in np.unique(index)]
        if len(pieces) == 1:
            return self._pose_of_entry(int(pieces[0][0]), t)
        poses = [(mask, self._pose_of_entry(int(i), t[mask])) for i, mask in pieces]
        result = _empty_like(poses, t.shape[0])
        for mask, pose in poses:
            _align_keys(result, pose)
            result.put(mask, pose)
        return result

    def entry_start(self, t_s: np.ndarray) -> np.ndarray:
        """Start time (s) of the activity running at each of ``t_s`` (m,)."""
        starts = np.asarray(self._starts)
        index = np.maximum(np.searchsorted(starts, np.asarray(t_s, dtype=np.float64), side="right") - 1, 0)
        return starts[index]

    def label_at(self, t_s: float) -> str:
        """Label of the activity running at ``t_s``."""
        self.extend_to(t_s)
        index = max(bisect.bisect_right(self._starts, t_s) - 1, 0)
        return self._entries[index].label


def _align_keys(target: BodyPose, source: BodyPose) -> None:
    """Give ``target`` and ``source`` the same joint and held-sensor keys (missing ones zero)."""
    for pose, other in ((target, source), (source, target)):
        n = pose.plant.shape[0]
        for joint in other.joint_angles_deg:
            pose.joint_angles_deg.setdefault(joint, np.zeros((n, 3)))
        for sensor_id in other.held:
            pose.held.setdefault(sensor_id, np.zeros(n))


def _empty_like(poses: list[tuple[np.ndarray, BodyPose]], n: int) -> BodyPose:
    result = BodyPose(heading_rad=np.zeros(n), root_xy_m=np.zeros((n, 2)), q_body_from_pelvis=np.tile([1.0, 0, 0, 0], (n, 1)),
                      joint_angles_deg={}, plant=np.zeros(n))
    for _, pose in poses:
        _align_keys(result, pose)
    return result
