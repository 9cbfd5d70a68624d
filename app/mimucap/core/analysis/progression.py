"""How far the body walks: its progression over the ground from the legs' orientations and the
feet's contacts, sample by sample.

The leg model of :mod:`.leg_model` (Aminian et al. 2002, "Spatio-temporal parameters of gait
measured by an ambulatory system using miniature gyroscopes", J. Biomech. 35:689-699, with the
foot's rockers) carries the body over the foot on the ground, continuously: with ``a(t)`` the
carrying foot's ankle relative to the pelvis root (world axes, forward kinematics of the segment
orientations) and ``g(t)`` that ankle's own travel over the floor as the foot rolls over its heel
and then its toe (:meth:`~.leg_model.LegChain.rocker_travel_m`, along the walking direction), the
root moves by ``dp = dg − da`` (horizontal components). The foot that landed last carries: a
foot alone on the floor, and in double support the leading foot, whose heel rocker the model
times (from its initial contact to the trailing foot's final contact) while the trailing foot's
rise onto its toe is not known. With both feet on the floor and neither landed (standing), each
counts half. This is the stride length of the leg model spread over time, so the distance
walked and the strides agree.

The distance walked is the progression along the walking direction: each step's displacement
projected on the pelvis's forward direction low-passed at ``heading_lowpass_hz``, so that the
pelvis's sway from foot to foot does not lengthen the path; the rockers' travel is along that
direction too.

Inputs: a :class:`~.leg_model.LegChain` (``t_s`` (T,) s, ankles relative to the root (T, 3) m,
pelvis and shank orientations (T, 4)) and swing events per foot
(:class:`~.gait_events.SwingEvents`: a foot swings from its final contact to its initial
contact). Outputs on ``t_s``: positions (T, 2) m and distance (T,) m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mimucap.core import rotation as rot
from mimucap.core.analysis.gait_events import SwingEvents
from mimucap.core.analysis.leg_model import LegChain
from mimucap.core.analysis.signals import check_time, lowpass

SIDES = ("left", "right")


@dataclass(frozen=True)
class ProgressionSettings:
    """``heading_lowpass_hz`` smoothing of the walking direction."""

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


def _contacts(events: dict[str, SwingEvents]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each foot's timed swings (final contact, initial contact), both (K,) s, in time order;
    a swing whose final or initial contact could not be timed is left out."""
    found = {}
    for side in SIDES:
        fc = ic = np.zeros(0)
        if events.get(side) is not None:
            fc, ic = (np.asarray(v, dtype=float) for v in (events[side].t_fc_s, events[side].t_ic_s))
            keep = np.isfinite(fc) & np.isfinite(ic) & (fc < ic)
            order = np.argsort(fc[keep])
            fc, ic = fc[keep][order], ic[keep][order]
        found[side] = (fc, ic)
    return found


def stance_weights(t_s: np.ndarray, events: dict[str, SwingEvents]) -> np.ndarray:
    """Which foot carries the body (T, 2) (left, right; 1 or 0, ½ each when both stand and
    neither landed, or neither is on the floor): the foot that landed last (module doc). A foot
    without events is on the floor throughout."""
    t = check_time(t_s, "stance weights")
    contacts = _contacts(events)
    on_ground = np.ones((t.shape[0], 2), dtype=bool)
    landed = np.full((t.shape[0], 2), -np.inf)
    for column, side in enumerate(SIDES):
        fc, ic = contacts[side]
        for a, b in zip(fc, ic):
            on_ground[(t > a) & (t < b), column] = False
        k = np.searchsorted(ic, t, side="right") - 1
        landed[k >= 0, column] = ic[k[k >= 0]]
    weights = on_ground.astype(float)
    both = on_ground.all(axis=1)
    leading = (landed[:, 1] > landed[:, 0]).astype(int)
    rows = np.flatnonzero(both)
    weights[rows, 1 - leading[rows]] = 0.0
    even = (both & ~np.isfinite(landed).any(axis=1)) | ~on_ground.any(axis=1)
    weights[even] = 0.5
    return weights


def rocker_travel(legs: LegChain, events: dict[str, SwingEvents]) -> np.ndarray:
    """Each foot's ankle travel over the floor (T, 2) m (left, right; cumulative, sample by
    sample on ``legs.t_s``) from its rockers in each of its stances: the stance from an initial
    contact (or the recording's start) to the next final contact, with the other foot's final and
    initial contact within it (:meth:`~.leg_model.LegChain.rocker_travel_m`)."""
    t = legs.t_s
    contacts = _contacts(events)
    travel = np.zeros((t.shape[0], 2))
    for column, side in enumerate(SIDES):
        other_fc, other_ic = contacts[SIDES[1 - column]]
        fc, ic = contacts[side]
        starts = np.concatenate(([-np.inf], ic))
        ends = np.concatenate((fc, [np.inf]))
        for start, end in zip(starts, ends):
            lifts = other_fc[(other_fc > start) & (other_fc < end)]
            if start >= end or not lifts.size:
                continue
            lift = float(lifts[0])
            lands = other_ic[(other_ic > lift) & (other_ic < end)]
            land = float(lands[0]) if lands.size else math.nan
            first, last = np.searchsorted(t, start, side="left"), np.searchsorted(t, end, side="right")
            if first >= last:
                continue
            rolled = legs.rocker_travel_m(side, start if math.isfinite(start) else math.nan, lift, land, t[first:last])
            travel[first:last, column] += rolled - rolled[0]
            travel[last:, column] += rolled[-1] - rolled[0]
    return travel


def progression(legs: LegChain, events: dict[str, SwingEvents],
                settings: ProgressionSettings = DEFAULT_PROGRESSION_SETTINGS) -> Progression:
    """The root's way over the ground and the distance walked (module doc)."""
    t = check_time(legs.t_s, "progression")
    weights = stance_weights(t, events)
    forward = rot.rotate(np.asarray(legs.q_pelvis, dtype=float), np.array([1.0, 0.0, 0.0]))[:, :2]
    forward = lowpass(forward, 1.0 / float(np.median(np.diff(t))), settings.heading_lowpass_hz)
    forward /= np.maximum(np.linalg.norm(forward, axis=1, keepdims=True), 1e-9)
    heading = 0.5 * (forward[1:] + forward[:-1])
    rolled = np.diff(rocker_travel(legs, events), axis=0)
    steps = np.zeros((t.shape[0] - 1, 2))
    for column, side in enumerate(SIDES):
        ankle = np.asarray(legs.ankle_from_root_m[side], dtype=float)[:, :2]
        steps += weights[:-1, column:column + 1] * (rolled[:, column:column + 1] * heading - np.diff(ankle, axis=0))
    along = np.sum(steps * heading, axis=1)
    position = np.concatenate((np.zeros((1, 2)), np.cumsum(steps, axis=0)))
    distance = np.concatenate(([0.0], np.cumsum(along)))
    return Progression(t, position, distance, weights)
