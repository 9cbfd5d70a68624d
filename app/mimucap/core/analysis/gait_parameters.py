"""Gait parameters of the analysed strides, per side and for both sides, with their
variability across strides and the left/right symmetry.

Per stride (times in s, from :class:`~mimucap.core.analysis.strides.Stride`):

* stride time ``next_ic − ic``; cadence ``120 / stride time`` steps/min (two steps a stride);
* step time: from the other foot's last initial contact before ``next_ic`` to ``next_ic``;
* stance and swing as % of the stride: ``(fc − ic)``, ``(next_ic − fc)``;
* double support as % of the stride: initial double support from ``ic`` to the other foot's
  final contact, plus terminal double support from the other foot's initial contact to
  ``fc`` (both feet on the ground; needs the other foot's events);
* stride length (m, from the foot's zero-velocity-update integration or the leg model) and
  gait speed = stride length / stride time (m/s).

Each parameter: number of strides, mean, standard deviation and coefficient of variation
(CV = SD / mean × 100 %). Symmetry of a parameter: the symmetry index
``SI = 100 · |L − R| / (0.5 · (L + R))`` % of the left and right means (Robinson et al. 1987,
"Use of force platform variables to quantify the effects of chiropractic manipulation on gait
symmetry", J. Manipulative Physiol. Ther. 10:172-176); 0 % is perfect symmetry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mimucap.core.analysis.strides import SIDES, Stride

#: (name, unit, description) of every parameter, in report order.
PARAMETERS: tuple[tuple[str, str, str], ...] = (
    ("cadence", "steps/min", "Cadence"),
    ("stride_time", "s", "Stride time"),
    ("step_time", "s", "Step time"),
    ("stance", "%", "Stance"),
    ("swing", "%", "Swing"),
    ("double_support", "%", "Double support"),
    ("stride_length", "m", "Stride length"),
    ("gait_speed", "m/s", "Gait speed"),
)
UNITS = {name: unit for name, unit, _ in PARAMETERS}
LABELS = {name: label for name, _, label in PARAMETERS}
#: Parameters whose left/right symmetry index is given.
SYMMETRY_PARAMETERS = ("stride_time", "step_time", "stance", "swing", "stride_length")


@dataclass(frozen=True)
class ParameterSummary:
    """One parameter of one side (``left``, ``right`` or ``both``): ``n`` strides, ``mean``,
    ``sd`` and ``cv_percent`` (NaN where fewer than 2 strides or no values)."""

    parameter: str
    side: str
    n: int
    mean: float
    sd: float
    cv_percent: float

    @property
    def unit(self) -> str:
        return UNITS[self.parameter]


@dataclass(frozen=True)
class GaitParameters:
    """Summaries keyed by (parameter, side) and symmetry indices (%) keyed by parameter."""

    summaries: dict[tuple[str, str], ParameterSummary]
    symmetry_percent: dict[str, float]

    def get(self, parameter: str, side: str) -> ParameterSummary:
        return self.summaries[(parameter, side)]


def _other_events(strides: list[Stride], side: str) -> tuple[np.ndarray, np.ndarray]:
    other = [s for s in strides if s.side != side]
    ics = sorted({s.ic_s for s in other} | {s.next_ic_s for s in other})
    fcs = sorted({s.fc_s for s in other if math.isfinite(s.fc_s)})
    return np.asarray(ics, dtype=float), np.asarray(fcs, dtype=float)


def stride_values(stride: Stride, other_ic_s: np.ndarray, other_fc_s: np.ndarray) -> dict[str, float]:
    """Every parameter of one stride (module doc); NaN where it cannot be computed."""
    t = stride.stride_time_s
    values = {
        "stride_time": t,
        "cadence": 120.0 / t,
        "stance": 100.0 * stride.stance_s / t,
        "swing": 100.0 * stride.swing_s / t,
        "stride_length": stride.stride_length_m,
        "gait_speed": stride.stride_length_m / t,
        "step_time": math.nan,
        "double_support": math.nan,
    }
    before = other_ic_s[(other_ic_s < stride.next_ic_s) & (other_ic_s > stride.ic_s)]
    if before.size:
        values["step_time"] = stride.next_ic_s - float(before.max())
    fc_other = other_fc_s[(other_fc_s > stride.ic_s) & (other_fc_s < stride.fc_s)]
    ic_other = other_ic_s[(other_ic_s > stride.ic_s) & (other_ic_s < stride.fc_s)]
    if fc_other.size and ic_other.size:
        initial = float(fc_other.min()) - stride.ic_s
        terminal = stride.fc_s - float(ic_other.max())
        if initial >= 0 and terminal >= 0:
            values["double_support"] = 100.0 * (initial + terminal) / t
    return values


def _summary(parameter: str, side: str, values: list[float]) -> ParameterSummary:
    v = np.asarray([x for x in values if math.isfinite(x)], dtype=float)
    if v.size == 0:
        return ParameterSummary(parameter, side, 0, math.nan, math.nan, math.nan)
    mean = float(v.mean())
    sd = float(v.std(ddof=1)) if v.size >= 2 else math.nan
    cv = 100.0 * sd / abs(mean) if v.size >= 2 and mean != 0 else math.nan
    return ParameterSummary(parameter, side, int(v.size), mean, sd, cv)


def symmetry_index(left: float, right: float) -> float:
    """``100 · |L − R| / (0.5 · (L + R))`` % (NaN when undefined)."""
    total = 0.5 * (left + right)
    if not (math.isfinite(left) and math.isfinite(right)) or total == 0:
        return math.nan
    return 100.0 * abs(left - right) / abs(total)


def gait_parameters(strides: list[Stride]) -> GaitParameters:
    """Parameters of the analysed strides (``stride.analysed``) per side and for both; the
    other foot's events (for step time and double support) come from all its strides."""
    per_stride: dict[str, list[dict[str, float]]] = {side: [] for side in SIDES}
    for side in SIDES:
        other_ic, other_fc = _other_events(strides, side)
        for stride in strides:
            if stride.side == side and stride.analysed:
                per_stride[side].append(stride_values(stride, other_ic, other_fc))
    summaries = {}
    for name, _, _ in PARAMETERS:
        for side in SIDES:
            summaries[(name, side)] = _summary(name, side, [v[name] for v in per_stride[side]])
        summaries[(name, "both")] = _summary(name, "both", [v[name] for side in SIDES for v in per_stride[side]])
    symmetry = {name: symmetry_index(summaries[(name, "left")].mean, summaries[(name, "right")].mean)
                for name in SYMMETRY_PARAMETERS}
    return GaitParameters(summaries, symmetry)
