"""How far the body walks: its progression over the ground from the legs' orientations and the
feet's contacts, sample by sample.

The double-pendulum leg model of Aminian et al. 2002 ("Spatio-temporal parameters of gait
measured by an ambulatory system using miniature gyroscopes", J. Biomech. 35:689-699; see
:mod:`.leg_model`) carries the body over the foot on the ground: while a foot carries the body,
the pelvis root moves by the opposite of that ankle's motion relative to the root. Here that
holds continuously: with ``a_i(t)`` each ankle's position relative to the root (world axes,
forward kinematics of the segment orientations) and ``w_i(t)`` the share of foot ``i`` in
carrying the body, the root moves by ``dp = −Σ w_i da_i`` (horizontal components). A foot
carries alone in its single support; in double support the load passes linearly from the
trailing foot to the leading one, from the leading foot's initial contact to the trailing
foot's final contact (at most ``max_double_support_s``), as the ground reaction forces of
walking show it (the vertical force of the trailing foot falls as that of the leading foot
rises). Without that hand-over (each foot half the load in double support) the stride comes
out several per cent short, because each leg's rocker over heel and forefoot, which the chain
leaves out, biases the two legs in opposite directions.

The distance walked is the progression along the walking direction: each step's displacement
projected on the pelvis's forward direction low-passed at ``heading_lowpass_hz``, so that the
pelvis's sway from foot to foot does not lengthen the path.

Inputs: ``t_s`` (T,) s; ankle positions (T, 3) m; swing events per foot
(:class:`~.gait_events.SwingEvents`: a foot swings from its final contact to its initial
contact); ``q_pelvis`` (T, 4). Outputs on ``t_s``: positions (T, 2) m and distance (T,) m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mimucap.core import rotation as rot
from mimucap.core.analysis.gait_events import SwingEvents
from mimucap.core.analysis.signals import check_time, lowpass

SIDES = ("left", "right")


@dataclass(frozen=True)
class ProgressionSettings:
    """``max_double_support_s`` longest load hand-over (s); ``heading_lowpass_hz`` smoothing of
    the walking direction."""

    max_double_support_s: float = 0.5
    heading_lowpass_hz: float = 0.5


DEFAULT_PROGRESSION_SETTINGS = ProgressionSettings()


@dataclass(frozen=True)
class Progression:
    """``t_s`` (T,), ``position_m`` (T, 2) the root over the ground (world x, y, starting at
    0), ``distance_m`` (T,) walked along the way (starting at 0), ``weights`` (T, 2) the left
    and right feet's shares."""

    t_s: np.ndarray
    position_m: np.ndarray
    distance_m: np.ndarray
    weights: np.ndarray

    def distance_at(self, t_s: float) -> float:
        """Distance (m) walked by ``t_s`` (linear between samples)."""
        return float(np.interp(t_s, self.t_s, self.distance_m))

    def time_at_distance(self, distance_m: float, after_s: float = -math.inf) -> float:
        """First time after ``after_s`` at which the walked distance reaches ``distance_m``
        (linear between samples); NaN when it never does."""
        d = self.distance_m
        index = np.flatnonzero((d >= distance_m) & (self.t_s >= after_s))
        if index.size == 0:
            return math.nan
        k = int(index[0])
        if k == 0 or d[k] == d[k - 1]:
            return float(self.t_s[k])
        return float(self.t_s[k - 1] + (distance_m - d[k - 1]) / (d[k] - d[k - 1]) * (self.t_s[k] - self.t_s[k - 1]))


def stance_weights(t_s: np.ndarray, events: dict[str, SwingEvents],
                   settings: ProgressionSettings = DEFAULT_PROGRESSION_SETTINGS) -> np.ndarray:
    """Each foot's share (T, 2) (left, right) in carrying the body (module doc). A foot without
    events is on the ground throughout; a swing without a timed final contact is left out."""
    t = check_time(t_s, "stance weights")
    on_ground = np.ones((t.shape[0], 2), dtype=bool)
    landings: list[list[float]] = [[], []]
    lifts: list[list[float]] = [[], []]
    for column, side in enumerate(SIDES):
        found = events.get(side)
        if found is None:
            continue
        for fc, ic in zip(found.t_fc_s, found.t_ic_s):
            if math.isfinite(fc) and math.isfinite(ic) and fc < ic:
                on_ground[(t > fc) & (t < ic), column] = False
                landings[column].append(float(ic))
                lifts[column].append(float(fc))
    weights = on_ground.astype(float)
    weights[~on_ground.any(axis=1)] = 0.5
    both = np.flatnonzero(on_ground.all(axis=1))
    if both.size:
        weights[both] = _hand_over(t[both], landings, lifts, settings.max_double_support_s)
    return weights


def _hand_over(t: np.ndarray, landings: list[list[float]], lifts: list[list[float]], longest: float) -> np.ndarray:
    """(left, right) shares (n, 2) at instants ``t`` (n,) of double support: the foot that
    landed last takes the load over linearly until the other foot lifts (half each when no
    foot landed within ``longest`` seconds: standing)."""
    last = np.full((t.shape[0], 2), -np.inf)
    lift = np.full((t.shape[0], 2), np.inf)
    for c in (0, 1):
        down = np.sort(np.asarray(landings[c], dtype=float))
        up = np.sort(np.asarray(lifts[c], dtype=float))
        k = np.searchsorted(down, t, side="right") - 1
        last[k >= 0, c] = down[k[k >= 0]]
        j = np.searchsorted(up, t, side="left")
        lift[j < up.shape[0], c] = up[j[j < up.shape[0]]]
    leading = (last[:, 1] > last[:, 0]).astype(int)
    rows = np.arange(t.shape[0])
    landed = last[rows, leading]
    span = np.minimum(lift[rows, 1 - leading] - landed, longest)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.clip((t - landed) / span, 0.0, 1.0)
    share = np.where(span > 0, share, 1.0)
    standing = ~np.isfinite(landed) | (t - landed > longest)
    share[standing] = 0.5
    out = np.empty((t.shape[0], 2))
    out[rows, leading] = share
    out[rows, 1 - leading] = 1.0 - share
    return out


def progression(t_s: np.ndarray, ankle_from_root_m: dict[str, np.ndarray], weights: np.ndarray,
                q_pelvis: np.ndarray, settings: ProgressionSettings = DEFAULT_PROGRESSION_SETTINGS) -> Progression:
    """The root's way over the ground and the distance walked (module doc)."""
    t = check_time(t_s, "progression")
    steps = np.zeros((t.shape[0] - 1, 2))
    for column, side in enumerate(SIDES):
        ankle = np.asarray(ankle_from_root_m[side], dtype=float)[:, :2]
        steps -= weights[:-1, column:column + 1] * np.diff(ankle, axis=0)
    forward = rot.rotate(np.asarray(q_pelvis, dtype=float), np.array([1.0, 0.0, 0.0]))[:, :2]
    forward = lowpass(forward, 1.0 / float(np.median(np.diff(t))), settings.heading_lowpass_hz)
    forward /= np.maximum(np.linalg.norm(forward, axis=1, keepdims=True), 1e-9)
    along = np.sum(steps * 0.5 * (forward[1:] + forward[:-1]), axis=1)
    position = np.concatenate((np.zeros((1, 2)), np.cumsum(steps, axis=0)))
    distance = np.concatenate(([0.0], np.cumsum(along)))
    return Progression(t, position, distance, np.asarray(weights, dtype=float))
