"""Where the figure stands: the root's position from the feet's contact with the floor (no Qt, no I/O).

Inertial sensors on body segments give orientations, not positions. The skeleton's position
follows from one assumption instead: the lowest foot point (an ankle, or a foot segment's ends
in larger models) rests on the floor and does not slide while it is the lowest. Each pose is
placed by forward kinematics so that this support point stays where it touched down; when the
other foot becomes lower (by more than :data:`SWITCH_HYSTERESIS_M`, so that double support does
not flicker) the support moves to it. This is the contact-based translation of inertial motion
capture suits (e.g. Roetenberg, Luinge, Slycke, "Xsens MVN: full 6DOF human motion tracking
using miniature inertial sensors", Xsens Technologies, 2009, section on contact detection);
it needs no position sensor and drifts with the orientation errors only.

Frames and units: world ENU (z up), metres; the root position is the root segment's proximal
point (:func:`mimucap.core.skeleton.forward_kinematics_stacked`).
"""

from __future__ import annotations

import numpy as np

from mimucap.core import skeleton

#: The support moves to another point only when that point is this much lower (m).
SWITCH_HYSTERESIS_M = 0.01
#: Segments whose distal ends (and, for feet, proximal ends) can touch the floor.
CONTACT_SEGMENTS = ("shank_l", "shank_r", "foot_l", "foot_r")


class RootTracker:
    """The root position of successive poses (see the module docstring).

    Args:
        model: the skeleton model.
        height_m: the subject's height (m).
    """

    def __init__(self, model: skeleton.SkeletonModel, height_m: float) -> None:
        self.model = model
        self.height_m = float(height_m)
        names = model.segment_names
        self._distal = [names.index(s) for s in CONTACT_SEGMENTS if s in names]
        if not self._distal:
            raise ValueError(f"the {model.name} model has no leg segment to stand on")
        neutral = np.broadcast_to(skeleton.q_world_from_body_facing(0.0), (len(names), 4))
        _proximal, distal = skeleton.forward_kinematics_stacked(model, neutral, self.height_m)
        #: height (m) of the lowest contact point above the floor when standing upright
        self.contact_height_m = float(np.min(distal[self._distal, 2]))
        self.reset()

    def reset(self) -> None:
        """Stand at the origin again (the next pose is placed over (0, 0))."""
        self._support: int | None = None
        self._anchor_xy = np.zeros(2)
        self.root_m = np.array([0.0, 0.0, self.model.root_height_ratio * self.height_m])

    def _contacts(self, q_stacked: np.ndarray) -> np.ndarray:
        """Contact points (P, 3) relative to the root for one pose ``q_stacked`` (S, 4)."""
        _proximal, distal = skeleton.forward_kinematics_stacked(self.model, q_stacked, self.height_m, np.zeros(3))
        return distal[self._distal]

    def update(self, q_world_from_segment: np.ndarray) -> np.ndarray:
        """The root position (3,) m of the next pose ``q_world_from_segment`` (S, 4), segments
        in model order."""
        points = self._contacts(np.asarray(q_world_from_segment, dtype=np.float64))
        lowest = int(np.argmin(points[:, 2]))
        if self._support is None:
            self._support = lowest
            self._anchor_xy = self.root_m[:2] + points[lowest, :2]
        elif lowest != self._support and points[lowest, 2] < points[self._support, 2] - SWITCH_HYSTERESIS_M:
            # The new support point touches down where it is now.
            self._anchor_xy = self.root_m[:2] + points[lowest, :2]
            self._support = lowest
        support = points[self._support]
        z = self.contact_height_m - float(np.min(points[:, 2]))
        self.root_m = np.array([self._anchor_xy[0] - support[0], self._anchor_xy[1] - support[1], z])
        return self.root_m.copy()


def root_positions(model: skeleton.SkeletonModel, height_m: float, q_world_from_segment: np.ndarray) -> np.ndarray:
    """Root positions (T, 3) m of a sequence of poses ``q_world_from_segment`` (S, T, 4) (segments
    in model order), starting over the origin: what :class:`RootTracker` gives pose by pose."""
    tracker = RootTracker(model, height_m)
    q = np.asarray(q_world_from_segment, dtype=np.float64)
    return np.array([tracker.update(q[:, k]) for k in range(q.shape[1])]).reshape(-1, 3)
