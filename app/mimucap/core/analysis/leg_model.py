"""Stride length from the orientations of the thighs and shanks: the double-pendulum leg model
of Aminian et al. 2002 ("Spatio-temporal parameters of gait measured by an ambulatory system
using miniature gyroscopes", J. Biomech. 35:689-699), written with full 3D segment
orientations instead of the sagittal angles they integrate from gyroscopes, with the foot's
rockers added.

Each leg is a chain pelvis root → hip → knee → ankle (the skeleton model's segment lengths and
hip offsets, forward kinematics of the segment orientations); ``x(t)`` is the ankle's position
ahead of the pelvis root along the walking direction ``f`` (horizontal unit vector, the
pelvis's mean forward axis over the stride). While a foot carries the body, the hip advances
by the ankle's own travel over the floor minus the change of ``x``. The ankle does travel: the
foot rolls over the heel after heel strike (heel rocker) and over the toe after the heel rises
(toe rocker; Perry & Burnfield, "Gait Analysis: Normal and Pathological Function", 2010), and
the ankle turns with it about the heel or toe of a foot of the subject's proportions
(:func:`~mimucap.core.skeleton.foot_sole_m`). How far it has turned follows from two facts of
normal gait and the level floor:

* at heel strike the ankle is at neutral, so the foot is pitched as the shank is (Perry &
  Burnfield: 0° at initial contact), and its heel is on the floor: this gives the foot's pitch
  and the pelvis's height above the floor;
* the foot is flat by the end of the loading response, which is the other foot's toe-off (and
  so at our own toe-off for the other foot).

For a stride of one foot (IC → other FC → other IC → FC → next IC): from IC to the other foot's
FC this foot rolls over its heel to flat; from there to the other foot's IC it carries the body
alone and rises onto its toe, as far as puts its ankle where the leg is when the other heel
strikes (the pelvis's height from that heel); from the other foot's IC to our FC the other foot
carries it, rolling over its heel to flat; from our FC to the next IC the other foot rises onto
its toe as far as our next heel strike puts it. The stride length is the ankle's displacement
from IC to the next IC: the hip's advance plus ``x(next IC) − x(IC)``. Without the other foot's
contacts, each phase is the one foot's and the rockers are left out. The rockers of one stance
over time (:meth:`LegChain.rocker_travel_m`) are what :mod:`.progression` carries the body on
from instant to instant. Inputs: quaternions
scalar first ``q_world_from_segment`` (T, 4) on a time grid ``t_s`` (T,) s; lengths in m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mimucap.core import rotation as rot
from mimucap.core import skeleton


@dataclass(frozen=True)
class LegChain:
    """Both ankles relative to the pelvis root (the mid-point of the hip joint centres) on one
    time grid ``t_s`` (T,): ``ankle_from_root_m`` side ("left"/"right") → (T, 3) world axes, m;
    ``q_pelvis`` (T, 4) and ``q_shank`` side → (T, 4) world ENU, scalar first; ``sole_m`` the
    sole's heel and toe points (3,) in the foot frame from the ankle
    (:func:`~mimucap.core.skeleton.foot_sole_m`). Build it from segment orientations with
    :meth:`from_segments` (forward kinematics of the skeleton model: thigh and shank lengths,
    and the hip joints' offsets from the root, so that the pelvis's rotation is included)."""

    t_s: np.ndarray
    ankle_from_root_m: dict[str, np.ndarray]
    q_pelvis: np.ndarray
    q_shank: dict[str, np.ndarray]
    sole_m: tuple[np.ndarray, np.ndarray]

    @classmethod
    def from_segments(cls, model: skeleton.SkeletonModel, height_m: float, t_s: np.ndarray,
                      q_world_from_segment: dict[str, np.ndarray]) -> LegChain:
        """From segment orientations (T, 4) of every model segment on ``t_s`` (T,)."""
        fk = skeleton.forward_kinematics(model, q_world_from_segment, height_m, np.zeros(3))
        return cls(np.asarray(t_s, dtype=float),
                   {"left": fk["shank_l"].distal_m, "right": fk["shank_r"].distal_m},
                   np.asarray(q_world_from_segment[model.root], dtype=float),
                   {"left": np.asarray(q_world_from_segment["shank_l"], dtype=float),
                    "right": np.asarray(q_world_from_segment["shank_r"], dtype=float)},
                   skeleton.foot_sole_m(height_m))

    def _at(self, values: np.ndarray, t: float) -> np.ndarray:
        index = int(np.clip(np.searchsorted(self.t_s, t), 0, self.t_s.shape[0] - 1))
        return values[index]

    def ankle_ahead_m(self, side: str, t: float, forward: np.ndarray) -> float:
        """How far (m) the ankle of ``side`` is ahead of the pelvis root along ``forward`` at ``t``."""
        return float(forward @ self._at(self.ankle_from_root_m[side], t))

    def forward(self, t0: float, t1: float) -> np.ndarray:
        """Mean horizontal forward direction (3,) of the pelvis over ``t0 .. t1``."""
        a, b = np.searchsorted(self.t_s, [t0, t1])
        q = self.q_pelvis[max(a, 0):max(b, a + 1)]
        x = rot.rotate(q, np.array([1.0, 0.0, 0.0])).mean(axis=0)
        x[2] = 0.0
        norm = np.linalg.norm(x)
        return x / norm if norm > 1e-9 else np.array([0.0, 1.0, 0.0])

    def _pivot_offset(self, pivot: str, pitch_rad: float | np.ndarray) -> np.ndarray:
        """The ankle's offset (forward, up) (2,) or (2, n) m from the heel or toe a foot of
        ``pitch_rad`` (scalar or (n,); toe up positive) stands on: the sole's point turned in the
        sagittal plane."""
        heel, toe = self.sole_m
        point = heel if pivot == "heel" else toe
        c, s = np.cos(pitch_rad), np.sin(pitch_rad)
        x, z = -point[0], -point[1]
        return np.array([c * x - s * z, s * x + c * z])

    def _pitch_at_strike(self, side: str, t: float) -> float:
        """The foot's pitch (rad, toe up) at a heel strike: the shank's (ankle at neutral)."""
        x = rot.rotate(self._at(self.q_shank[side], t), np.array([1.0, 0.0, 0.0]))
        return float(np.arctan2(x[2], np.hypot(x[0], x[1])))

    def _toe_pitch(self, side: str, t: float, striking: str) -> float:
        """The pitch (rad, ≤ 0) of the foot of ``side`` on its toe at ``t``, when the heel of
        ``striking`` meets the floor: the pelvis's height from that heel, the ankle's height
        above the floor from it, and the pitch about the toe that holds the ankle there."""
        pitch = self._pitch_at_strike(striking, t)
        heel_below_ankle = self._pivot_offset("heel", pitch)[1]
        pelvis_height = heel_below_ankle - self._at(self.ankle_from_root_m[striking], t)[2]
        ankle_height = pelvis_height + self._at(self.ankle_from_root_m[side], t)[2]
        low, high = -np.radians(85.0), 0.0
        if ankle_height <= self._pivot_offset("toe", 0.0)[1]:
            return 0.0
        for _ in range(40):  # the ankle rises as the heel does
            middle = 0.5 * (low + high)
            if self._pivot_offset("toe", middle)[1] > ankle_height:
                low = middle
            else:
                high = middle
        return 0.5 * (low + high)

    def rocker_travel_m(self, side: str, ic_s: float, other_fc_s: float, other_ic_s: float,
                        t_s: np.ndarray) -> np.ndarray:
        """How far forward (m) the ankle of ``side`` has travelled over the floor by the instants
        ``t_s`` (n,) of its stance from the heel strike ``ic_s`` (module doc): rolling over the
        heel to flat until the other foot's final contact ``other_fc_s``, then rising onto the
        toe until the other foot's initial contact ``other_ic_s``, as far as that heel strike
        puts it. Within each rocker the foot's pitch is taken to change at a steady rate (only
        the rocker's total is known). A stance whose heel strike is unknown (NaN: it began
        standing) starts flat; without the other foot's contacts there is no rocker (zeros)."""
        t = np.asarray(t_s, dtype=float)
        travel = np.zeros(t.shape)
        if not np.isfinite(other_fc_s):
            return travel
        if np.isfinite(ic_s) and ic_s < other_fc_s:
            strike = self._pitch_at_strike(side, ic_s)
            pitch = strike * (1.0 - np.clip((t - ic_s) / (other_fc_s - ic_s), 0.0, 1.0))
            travel += self._pivot_offset("heel", pitch)[0] - self._pivot_offset("heel", strike)[0]
        if np.isfinite(other_ic_s) and other_fc_s < other_ic_s:
            other = "left" if side == "right" else "right"
            pitch = self._toe_pitch(side, other_ic_s, other) * np.clip((t - other_fc_s) / (other_ic_s - other_fc_s), 0.0, 1.0)
            travel += self._pivot_offset("toe", pitch)[0] - self._pivot_offset("toe", 0.0)[0]
        return travel

    def stride_length_m(self, side: str, ic_s: float, fc_s: float, next_ic_s: float,
                        other_fc_s: float = float("nan"), other_ic_s: float = float("nan")) -> float:
        """Stride length (m) of the stride of ``side`` (module doc); ``other_fc_s`` and
        ``other_ic_s`` the other foot's final and initial contact within the stance."""
        other = "left" if side == "right" else "right"
        f = self.forward(ic_s, next_ic_s)
        x = lambda leg, t: self.ankle_ahead_m(leg, t, f)  # noqa: E731
        advance = lambda leg, a, b: x(leg, a) - x(leg, b)  # noqa: E731
        foot = x(side, next_ic_s) - x(side, ic_s)
        if not ic_s < other_fc_s < other_ic_s < fc_s:
            return foot + advance(side, ic_s, fc_s) + advance(other, fc_s, next_ic_s)
        end = np.array([np.inf])
        rockers = (self.rocker_travel_m(side, ic_s, other_fc_s, other_ic_s, end)
                   + self.rocker_travel_m(other, other_ic_s, fc_s, next_ic_s, end))
        return foot + advance(side, ic_s, other_ic_s) + advance(other, other_ic_s, next_ic_s) + float(rockers[0])

    def heading_change_deg(self, t0: float, t1: float) -> float:
        """Change of the pelvis heading (deg) from ``t0`` to ``t1``."""
        a, b = (int(np.clip(np.searchsorted(self.t_s, t), 0, self.t_s.shape[0] - 1)) for t in (t0, t1))
        psi = np.unwrap(rot.heading_rad(self.q_pelvis[a:b + 1]))
        return float(np.degrees(psi[-1] - psi[0])) if psi.size else float("nan")
