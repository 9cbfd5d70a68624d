"""Scripted activities of the simulated subject: standing poses, turning, arm raises, squats,
single-joint excursions and holding sensors for a magnetometer calibration.

An *activity* maps local time ``tau`` (s since it started) and its start state (heading and
horizontal position, :class:`~mimucap.core.simulate.body_pose.BaseState`) to a
:class:`~mimucap.core.simulate.body_pose.BodyPose`. Walking is in
:mod:`mimucap.core.simulate.walking`; the schedule that strings activities together in
:mod:`mimucap.core.simulate.schedule`. Frames and units as in
:mod:`mimucap.core.simulate.body_pose`.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

import numpy as np

from mimucap.core import phase_markers
from mimucap.core.simulate.body_pose import BaseState, BodyPose, pelvis_rotation, standing_sway
from mimucap.core.simulate.hand_held import HAND_HEIGHT_M, HAND_PATHS
from mimucap.core.simulate.minimum_jerk import minimum_jerk

#: Seconds over which a new activity is blended in.
BLEND_S = 0.5
#: Height (m) and distance in front of the pelvis (m) at which hand-held sensors are turned.
HELD_HEIGHT_M = 1.05
HELD_FORWARD_M = 0.35

_TWO_PI = 2.0 * np.pi


class Activity(ABC):
    """Base of all activities: ``duration_s`` (None: indefinite) and :meth:`pose`."""

    name = "activity"
    #: Label of the marker written where the activity starts (:mod:`mimucap.core.phase_markers`).
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
        lean, obliquity = standing_sway(tau, sway_deg)
        return BodyPose(
            heading_rad=np.full(n, start.heading_rad), root_xy_m=np.tile(start.xy_m, (n, 1)),
            q_body_from_pelvis=pelvis_rotation(np.zeros(n), obliquity, lean), joint_angles_deg={},
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
    marker = phase_markers.NPOSE

    def __init__(self, duration_s: float | None = None, sway_deg: float = 0.3) -> None:
        self.duration_s = duration_s
        self.sway_deg = float(sway_deg)

    def pose(self, tau, start):
        return self._standing(tau, start, self.sway_deg)


class TPose(Activity):
    """Arms raised sideways to ``angle_deg`` (default 88°: Z-X'-Y'' is singular at exactly 90°)
    in ``raise_s`` seconds (minimum jerk), then held; ``arms`` right, left or both."""

    name = "tpose"
    marker = phase_markers.TPOSE

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


class Turn(Activity):
    """Turning on the spot by ``angle_deg`` (positive: to the left, counter-clockwise from above)
    in ``turn_s`` seconds with small stepping, then standing ``pause_s``; repeated ``turns``
    times (None: forever)."""

    name = "turn"
    marker = phase_markers.TURN

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
    marker = phase_markers.ARM_RAISE

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
    marker = phase_markers.SQUAT

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
        pose.q_body_from_pelvis = pelvis_rotation(zeros, zeros, 30.0 * s)
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
    horizontal), "figure8" or "tumble" (see :mod:`mimucap.core.simulate.hand_held`);
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
        self.marker = {"single_axis": phase_markers.MAG_TURNS, "figure8": phase_markers.MAG_FIGURE8,
                       "tumble": phase_markers.MAG_TUMBLE}[protocol]
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
