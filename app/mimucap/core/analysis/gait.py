"""Gait analysis of one recording: each foot's events from its foot or shank sensor, strides
with lengths and heading changes, refusals, bouts and turns, then the parameters.

* A foot sensor gives events by the foot rules and each stride's length and heading change by
  zero-velocity-update integration (:mod:`.foot`).
* A shank sensor gives events by the shank rules; stride length and heading change come from
  the segment orientations (:class:`~.leg_model.LegChain`: the double-pendulum leg model and the
  pelvis heading) when those are given, and are left out (NaN) otherwise.
* With segment orientations, turns are found first from the pelvis heading (:mod:`.turns`);
  foot sensors alone give turns from their strides' heading changes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from mimucap.core import rotation as rot
from mimucap.core.analysis.foot import foot_strides
from mimucap.core.analysis.gait_events import DEFAULT_EVENT_SETTINGS, EventSettings, SwingEvents, detect_swing_events
from mimucap.core.analysis.gait_parameters import GaitParameters, gait_parameters
from mimucap.core.analysis.leg_model import LegChain
from mimucap.core.analysis.sagittal import SagittalAxes
from mimucap.core.analysis.turns import find_turns
from mimucap.core.analysis.strides import (
    DEFAULT_STRIDE_SETTINGS,
    SIDES,
    Interval,
    Stride,
    StrideSettings,
    bouts_and_turns,
    classify,
    pair_strides,
)

LENGTH_METHODS = {
    "foot": "zero-velocity-update integration of the foot sensor (Skog et al. 2010; Rampp et al. 2015)",
    "shank": "double-pendulum leg model on thigh and shank orientations (Aminian et al. 2002)",
}


@dataclass(frozen=True)
class GaitInput:
    """One foot's sensor: ``side`` left/right, ``placement`` foot/shank, ``sensor_id``,
    ``t_s`` (N,) s, ``sagittal_rate`` (N,) rad/s; a foot sensor also needs ``acc`` (N, 3)
    m/s² and ``gyr`` (N, 3) rad/s in its own frame. ``sagittal_acc`` (N, 2) m/s², the
    antero-posterior and vertical acceleration (:mod:`.sagittal`), times the initial contacts
    at the heel strike's impact; without it they come from the angular rate alone."""

    side: str
    placement: str
    sensor_id: str
    t_s: np.ndarray
    sagittal_rate: np.ndarray
    acc: np.ndarray | None = None
    gyr: np.ndarray | None = None
    sagittal_acc: np.ndarray | None = None

    @classmethod
    def from_axes(cls, side: str, placement: str, sensor_id: str, t_s: np.ndarray, acc: np.ndarray,
                  gyr: np.ndarray, axes: SagittalAxes) -> GaitInput:
        """The input of a sensor whose sagittal ``axes`` are known (from the body calibration,
        or found in the recording: :func:`.sagittal.axes_from_data`)."""
        return cls(side, placement, sensor_id, t_s, axes.rate(gyr), acc, gyr, axes.acceleration(acc))


@dataclass
class GaitAnalysis:
    """Everything found: ``strides`` (both feet, time order; refused ones with the reason),
    ``bouts`` and ``turns`` (:class:`~.strides.Interval`), ``parameters``, ``events`` side →
    :class:`~.gait_events.SwingEvents`, ``sources`` side → what gave its events and lengths."""

    strides: list[Stride]
    bouts: list[Interval]
    turns: list[Interval]
    parameters: GaitParameters
    events: dict[str, SwingEvents] = field(default_factory=dict)
    sources: dict[str, str] = field(default_factory=dict)

    @property
    def analysed(self) -> list[Stride]:
        return [s for s in self.strides if s.analysed]


def analyse_gait(inputs: list[GaitInput], legs: LegChain | None = None,
                 event_settings: EventSettings = DEFAULT_EVENT_SETTINGS,
                 stride_settings: StrideSettings = DEFAULT_STRIDE_SETTINGS) -> GaitAnalysis:
    """Analyse the feet of ``inputs`` (at most one per side); see the module doc."""
    if not inputs:
        raise ValueError("gait analysis needs a foot or shank sensor on at least one side")
    sides = [i.side for i in inputs]
    if len(set(sides)) != len(sides) or any(s not in SIDES for s in sides):
        raise ValueError(f"give at most one sensor per side (left, right); got {', '.join(sides)}")
    strides: list[Stride] = []
    events: dict[str, SwingEvents] = {}
    sources: dict[str, str] = {}
    shank_items = []
    for item in inputs:
        if item.placement == "foot":
            if item.acc is None or item.gyr is None:
                raise ValueError(f"foot sensor {item.sensor_id}: needs accelerometer and gyroscope samples")
            found, events[item.side] = foot_strides(item.side, item.t_s, item.acc, item.gyr, item.sagittal_rate,
                                                    event_settings, item.sagittal_acc)
            sources[item.side] = f"foot sensor {item.sensor_id}; stride length: {LENGTH_METHODS['foot']}"
        elif item.placement == "shank":
            events[item.side] = detect_swing_events(item.t_s, item.sagittal_rate, "shank", event_settings,
                                                    item.sagittal_acc)
            found = pair_strides(item.side, events[item.side].t_ic_s, events[item.side].t_fc_s)
            shank_items.append(item.side)
            if legs is not None:
                sources[item.side] = f"shank sensor {item.sensor_id}; stride length: {LENGTH_METHODS['shank']}"
            else:
                sources[item.side] = f"shank sensor {item.sensor_id}; stride length not estimable (no leg orientations)"
        else:
            raise ValueError(f"sensor {item.sensor_id}: placement must be foot or shank, got {item.placement!r}")
        strides.extend(found)
    if legs is not None:
        strides = [_with_leg_model(s, legs, events) if s.side in shank_items else s for s in strides]
    strides.sort(key=lambda s: (s.ic_s, s.side))
    found_turns = None
    if legs is not None and legs.t_s.shape[0] >= 10:
        found_turns = find_turns(legs.t_s, np.unwrap(rot.heading_rad(legs.q_pelvis)))
    strides = classify(strides, stride_settings, found_turns)
    strides, bouts, turns = bouts_and_turns(strides, stride_settings, found_turns)
    return GaitAnalysis(strides, bouts, turns, gait_parameters(strides), events, sources)


def _with_leg_model(stride: Stride, legs: LegChain, events: dict[str, SwingEvents]) -> Stride:
    """The stride with its leg-model length (the other foot's contacts in its stance, when
    known) and its pelvis heading change."""
    if not math.isfinite(stride.fc_s):
        return stride
    other = events.get("left" if stride.side == "right" else "right")
    other_fc = other_ic = math.nan
    if other is not None:
        fcs = other.t_fc_s[(other.t_fc_s > stride.ic_s) & (other.t_fc_s < stride.fc_s)]
        ics = other.t_ic_s[(other.t_ic_s > stride.ic_s) & (other.t_ic_s < stride.fc_s)]
        if fcs.size and ics.size:
            other_fc, other_ic = float(fcs.min()), float(ics.max())
    length = legs.stride_length_m(stride.side, stride.ic_s, stride.fc_s, stride.next_ic_s, other_fc, other_ic)
    return replace(stride, stride_length_m=_finite_or_nan(length),
                   heading_change_deg=legs.heading_change_deg(stride.ic_s, stride.next_ic_s))


def _finite_or_nan(value: float) -> float:
    return value if math.isfinite(value) and value > 0 else math.nan
