"""Sitting on a chair, standing up from it and sitting down: the simulated subject's chair moves.

Seated: thighs horizontal (hips about 98° flexed with the pelvis leaning 8° forward), knees 90°,
shanks vertical, feet flat on the floor; the pelvis is as low as the legs put it (about 0.5 m
for a 1.75 m subject, a chair's seat). The feet stay planted while the body rises or sits, the
pelvis moving forward over them, as in a squat. Rising follows the phases of a sit-to-stand
(Schenkman, Berger, Riley, Mann, Hodge, "Whole-body movements during rising to standing from
sitting"): the trunk first flexes forward (here up to 30° more at mid-rise, the shanks tilting
12° forward), then hips and knees extend together to standing; sitting down is the reverse.
Each transition follows a minimum-jerk profile over its duration (1-2 s for the subjects of
the clinical test scenarios).

Frames and units as in :mod:`mimucap.core.simulate.body_pose`.
"""

from __future__ import annotations

import numpy as np

from mimucap.core import phase_markers
from mimucap.core.simulate.activities import Activity
from mimucap.core.simulate.body_pose import BodyPose, pelvis_rotation
from mimucap.core.simulate.minimum_jerk import minimum_jerk

#: Thigh angle from vertical (deg) when seated, and the pelvis's forward lean seated (deg).
SEATED_THIGH_DEG = 90.0
SEATED_LEAN_DEG = 8.0
#: Extra forward trunk lean and shank tilt (deg) at the middle of a rise or a sit-down.
TRANSITION_LEAN_DEG = 30.0
TRANSITION_SHANK_DEG = 12.0


def chair_pose(tau: np.ndarray, start, seated: np.ndarray, transition: np.ndarray, arms_crossed: bool,
               sway_deg: float = 0.2) -> BodyPose:
    """The subject at local times ``tau`` (n,) with ``seated`` (n,) in [0, 1] (1 on the chair,
    0 standing) and ``transition`` (n,) in [0, 1] (the bump of trunk lean and shank tilt, 0 at
    rest); ``arms_crossed`` crosses the arms over the chest (chair stand test)."""
    n = tau.shape[0]
    thigh = SEATED_THIGH_DEG * seated
    shank = TRANSITION_SHANK_DEG * transition
    lean = SEATED_LEAN_DEG * seated + TRANSITION_LEAN_DEG * transition
    zeros = np.zeros(n)
    sway = sway_deg * np.sin(2.0 * np.pi * 0.23 * tau + 0.4)
    pose = BodyPose(heading_rad=np.full(n, start.heading_rad), root_xy_m=np.tile(start.xy_m, (n, 1)),
                    q_body_from_pelvis=pelvis_rotation(zeros, zeros, lean + sway), joint_angles_deg={},
                    plant=np.ones(n))
    for side in ("l", "r"):
        pose.joint_angles_deg[f"hip_{side}"] = np.stack((thigh + lean, -2.0 * seated, zeros), axis=-1)
        pose.joint_angles_deg[f"knee_{side}"] = np.stack((thigh + shank, zeros, zeros), axis=-1)
        pose.joint_angles_deg[f"ankle_{side}"] = np.stack((shank, zeros, zeros), axis=-1)
        if arms_crossed:
            pose.joint_angles_deg[f"shoulder_{side}"] = np.stack((np.full(n, 35.0), np.full(n, 15.0), zeros), axis=-1)
            pose.joint_angles_deg[f"elbow_{side}"] = np.stack((np.full(n, 115.0), zeros, zeros), axis=-1)
    pose.joint_angles_deg["lumbar"] = np.stack((-0.3 * lean, zeros, zeros), axis=-1)
    pose.joint_angles_deg["neck"] = np.stack((-0.3 * lean, zeros, zeros), axis=-1)
    return pose


class Sit(Activity):
    """Sitting still on the chair for ``duration_s`` (None: indefinitely)."""

    name = "sit"
    marker = phase_markers.SITTING

    def __init__(self, duration_s: float | None = None, arms_crossed: bool = False) -> None:
        self.duration_s = duration_s
        self.arms_crossed = bool(arms_crossed)

    def pose(self, tau, start):
        ones = np.ones(tau.shape[0])
        return chair_pose(tau, start, ones, 0.0 * ones, self.arms_crossed)


class ChairTransition(Activity):
    """Standing up from the chair (``rise`` True) or sitting down on it in ``move_s`` seconds
    (minimum jerk), then standing or sitting still for ``hold_s``."""

    def __init__(self, rise: bool, move_s: float = 1.5, hold_s: float = 0.0, arms_crossed: bool = False) -> None:
        if not 0.5 <= move_s <= 5.0 or hold_s < 0.0:
            raise ValueError(f"a sit-to-stand or stand-to-sit takes 0.5..5 s and holds >= 0 s, got {move_s}, {hold_s}")
        self.rise = bool(rise)
        self.move_s = float(move_s)
        self.duration_s = self.move_s + float(hold_s)
        self.arms_crossed = bool(arms_crossed)
        self.name = "sit_to_stand" if rise else "stand_to_sit"
        self.marker = phase_markers.SIT_TO_STAND if rise else phase_markers.STAND_TO_SIT

    def pose(self, tau, start):
        x = np.clip(tau / self.move_s, 0.0, 1.0)
        progress = minimum_jerk(x)
        seated = 1.0 - progress if self.rise else progress
        transition = np.sin(np.pi * x) ** 2
        return chair_pose(tau, start, seated, transition, self.arms_crossed)
