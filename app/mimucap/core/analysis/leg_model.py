"""Stride length from the orientations of the thighs and shanks: the double-pendulum leg model
of Aminian et al. 2002 ("Spatio-temporal parameters of gait measured by an ambulatory system
using miniature gyroscopes", J. Biomech. 35:689-699), written with full 3D segment
orientations instead of the sagittal angles they integrate from gyroscopes.

Each leg is a chain pelvis root → hip → knee → ankle (the skeleton model's segment lengths and
hip offsets, forward kinematics of the segment orientations); ``x(t)`` is the ankle's position
ahead of the pelvis root along the walking direction ``f`` (horizontal unit vector, the
pelvis's mean forward axis over the stride). While a foot is on the ground the body advances
over it by the decrease of that foot's ``x``. For a stride of one
foot (IC → FC → next IC):

* from IC to FC this foot carries the body: the hip advances ``x(IC) − x(FC)``;
* from FC to the next IC the other foot carries it: ``x_o(FC) − x_o(next IC)``;
* the foot ends ``x(next IC)`` ahead of the hip where it started ``x(IC)`` ahead;

so the stride length is ``x(next IC) − x(FC) + x_o(FC) − x_o(next IC)``. In the two
double-support phases both feet are on the ground and either leg measures the hip's advance;
where the other foot's contacts are known, their mean is used there (the legs' rocker motion
about heel and forefoot, which the chain ignores, biases the two in opposite directions). Inputs: quaternions
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
    ``q_pelvis`` (T, 4) world ENU, scalar first. Build it from segment orientations with
    :meth:`from_segments` (forward kinematics of the skeleton model: thigh and shank lengths,
    and the hip joints' offsets from the root, so that the pelvis's rotation is included)."""

    t_s: np.ndarray
    ankle_from_root_m: dict[str, np.ndarray]
    q_pelvis: np.ndarray

    @classmethod
    def from_segments(cls, model: skeleton.SkeletonModel, height_m: float, t_s: np.ndarray,
                      q_world_from_segment: dict[str, np.ndarray]) -> LegChain:
        """From segment orientations (T, 4) of every model segment on ``t_s`` (T,)."""
        fk = skeleton.forward_kinematics(model, q_world_from_segment, height_m, np.zeros(3))
        return cls(np.asarray(t_s, dtype=float),
                   {"left": fk["shank_l"].distal_m, "right": fk["shank_r"].distal_m},
                   np.asarray(q_world_from_segment[model.root], dtype=float))

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

    def stride_length_m(self, side: str, ic_s: float, fc_s: float, next_ic_s: float,
                        other_fc_s: float = float("nan"), other_ic_s: float = float("nan")) -> float:
        """Stride length (m) of the stride of ``side`` (module doc). With the other foot's final
        contact ``other_fc_s`` and initial contact ``other_ic_s`` within the stance, the hip's
        advance during the two double-support phases is the mean of what either leg gives."""
        other = "left" if side == "right" else "right"
        f = self.forward(ic_s, next_ic_s)
        x = lambda leg, t: self.ankle_ahead_m(leg, t, f)  # noqa: E731
        advance = lambda leg, a, b: x(leg, a) - x(leg, b)  # noqa: E731
        foot = x(side, next_ic_s) - x(side, ic_s)
        swing = advance(other, fc_s, next_ic_s)
        if ic_s < other_fc_s < other_ic_s < fc_s:
            both = lambda a, b: 0.5 * (advance(side, a, b) + advance(other, a, b))  # noqa: E731
            stance = both(ic_s, other_fc_s) + advance(side, other_fc_s, other_ic_s) + both(other_ic_s, fc_s)
        else:
            stance = advance(side, ic_s, fc_s)
        return foot + stance + swing

    def heading_change_deg(self, t0: float, t1: float) -> float:
        """Change of the pelvis heading (deg) from ``t0`` to ``t1``."""
        a, b = (int(np.clip(np.searchsorted(self.t_s, t), 0, self.t_s.shape[0] - 1)) for t in (t0, t1))
        psi = np.unwrap(rot.heading_rad(self.q_pelvis[a:b + 1]))
        return float(np.degrees(psi[-1] - psi[0])) if psi.size else float("nan")
