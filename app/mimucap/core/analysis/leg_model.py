"""Stride length from the orientations of the thighs and shanks: the double-pendulum leg model
of Aminian et al. 2002 ("Spatio-temporal parameters of gait measured by an ambulatory system
using miniature gyroscopes", J. Biomech. 35:689-699), written with full 3D segment
orientations instead of the sagittal angles they integrate from gyroscopes.

Each leg is a chain hip → knee → ankle of a thigh (length ``L_t``) and a shank (``L_s``); the
ankle's position ahead of the hip along the walking direction ``f`` (horizontal unit vector,
the pelvis's forward axis) is ``x(t) = −f · (L_t·y_thigh(t) + L_s·y_shank(t))``, with ``y`` the
segment's long axis (ISB: pointing to its proximal joint) in the world. While a foot is on the
ground the hip advances over it by the decrease of that foot's ``x``. For a stride of one
foot (IC → FC → next IC):

* from IC to FC this foot carries the body: the hip advances ``x(IC) − x(FC)``;
* from FC to the next IC the other foot carries it: ``x_o(FC) − x_o(next IC)``;
* the foot ends ``x(next IC)`` ahead of the hip where it started ``x(IC)`` ahead;

so the stride length is ``x(next IC) − x(FC) + x_o(FC) − x_o(next IC)``. Inputs: quaternions
scalar first ``q_world_from_segment`` (T, 4) on a time grid ``t_s`` (T,) s; lengths in m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mimucap.core import rotation as rot


def heading_rad(q_world_from_segment: np.ndarray) -> np.ndarray:
    """Heading (T,) rad of a segment's forward (x) axis projected on the ground (ENU, 0 =
    north, positive counter-clockwise from above), unwrapped."""
    x_world = rot.rotate(np.asarray(q_world_from_segment, dtype=np.float64), np.array([1.0, 0.0, 0.0]))
    return np.unwrap(np.arctan2(-x_world[..., 0], x_world[..., 1]))


@dataclass(frozen=True)
class LegChain:
    """Thigh and shank orientations of both legs and the pelvis on one time grid ``t_s`` (T,):
    ``q_thigh`` / ``q_shank`` side ("left"/"right") → (T, 4) world ENU, ``q_pelvis`` (T, 4);
    ``thigh_m`` and ``shank_m`` segment lengths (m)."""

    t_s: np.ndarray
    q_thigh: dict[str, np.ndarray]
    q_shank: dict[str, np.ndarray]
    q_pelvis: np.ndarray
    thigh_m: float
    shank_m: float

    def _at(self, values: np.ndarray, t: float) -> np.ndarray:
        index = int(np.clip(np.searchsorted(self.t_s, t), 0, self.t_s.shape[0] - 1))
        return values[index]

    def ankle_ahead_m(self, side: str, t: float, forward: np.ndarray) -> float:
        """How far (m) the ankle of ``side`` is ahead of its hip along ``forward`` at ``t``."""
        y = np.array([0.0, 1.0, 0.0])
        leg = (self.thigh_m * rot.rotate(self._at(self.q_thigh[side], t), y)
               + self.shank_m * rot.rotate(self._at(self.q_shank[side], t), y))
        return float(-forward @ leg)

    def forward(self, t0: float, t1: float) -> np.ndarray:
        """Mean horizontal forward direction (3,) of the pelvis over ``t0 .. t1``."""
        a, b = np.searchsorted(self.t_s, [t0, t1])
        q = self.q_pelvis[max(a, 0):max(b, a + 1)]
        x = rot.rotate(q, np.array([1.0, 0.0, 0.0])).mean(axis=0)
        x[2] = 0.0
        norm = np.linalg.norm(x)
        return x / norm if norm > 1e-9 else np.array([0.0, 1.0, 0.0])

    def stride_length_m(self, side: str, ic_s: float, fc_s: float, next_ic_s: float) -> float:
        """Stride length (m) of the stride of ``side`` (module doc)."""
        other = "left" if side == "right" else "right"
        f = self.forward(ic_s, next_ic_s)
        return (self.ankle_ahead_m(side, next_ic_s, f) - self.ankle_ahead_m(side, fc_s, f)
                + self.ankle_ahead_m(other, fc_s, f) - self.ankle_ahead_m(other, next_ic_s, f))

    def heading_change_deg(self, t0: float, t1: float) -> float:
        """Change of the pelvis heading (deg) from ``t0`` to ``t1``."""
        a, b = (int(np.clip(np.searchsorted(self.t_s, t), 0, self.t_s.shape[0] - 1)) for t in (t0, t1))
        psi = heading_rad(self.q_pelvis[a:b + 1])
        return float(np.degrees(psi[-1] - psi[0])) if psi.size else float("nan")
