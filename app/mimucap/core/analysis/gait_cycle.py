"""Joint angles over the gait cycle: every analysed stride time-normalised to 0-100 % (initial
contact to the next initial contact of the same foot, 101 points), then mean ± SD per side,
with the stance/swing boundary at the mean final contact (% of the stride).

Normative bands (per joint and axis, per % of the cycle: a mean and SD, or a lower and upper
limit) are held by :class:`NormativeBand`; reading them from a file is
:mod:`mimucap.io.normative_bands`. Angles in degrees, columns named as
``core.skeleton.joint_angle_columns`` (``<joint>_<l|r>_<axis>_deg``, ``lumbar_flexion_deg``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from mimucap.core.analysis.strides import SIDES, Stride

#: Points of a normalised cycle: 0, 1, ..., 100 %.
CYCLE_PERCENT = np.linspace(0.0, 100.0, 101)
_SIDED = re.compile(r"^(?P<joint>[a-z]+)_(?P<side>[lr])_(?P<axis>[a-z_]+)_deg$")
_UNSIDED = re.compile(r"^(?P<joint>[a-z]+)_(?P<axis>[a-z_]+)_deg$")


def split_column(column: str) -> tuple[str, str | None, str]:
    """``(joint, side or None, axis)`` of a joint-angle column name (``knee_r_flexion_deg`` →
    ``("knee", "right", "flexion")``)."""
    m = _SIDED.match(column)
    if m:
        return m["joint"], {"l": "left", "r": "right"}[m["side"]], m["axis"]
    m = _UNSIDED.match(column)
    if m:
        return m["joint"], None, m["axis"]
    raise ValueError(f"not a joint-angle column name: {column!r}")


def normalise_stride(t_s: np.ndarray, values: np.ndarray, ic_s: float, next_ic_s: float) -> np.ndarray:
    """``values`` (T,) at ``t_s`` (T,) resampled to 101 points from ``ic_s`` to ``next_ic_s``
    (linear interpolation); NaN when the stride is not covered by the samples."""
    if not (t_s[0] <= ic_s and next_ic_s <= t_s[-1]):
        return np.full(CYCLE_PERCENT.shape, np.nan)
    return np.interp(ic_s + CYCLE_PERCENT / 100.0 * (next_ic_s - ic_s), t_s, values)


@dataclass(frozen=True)
class CycleCurve:
    """One angle column over the cycle for one side: ``mean_deg``/``sd_deg`` (101,),
    ``n_strides``, ``stance_percent`` the mean final contact (% of the stride)."""

    column: str
    side: str
    mean_deg: np.ndarray
    sd_deg: np.ndarray
    n_strides: int
    stance_percent: float


def cycle_curves(t_s: np.ndarray, angles_deg: dict[str, np.ndarray], strides: list[Stride]) -> dict[str, CycleCurve]:
    """Mean ± SD curve of every angle column over the analysed strides of its side (a sided
    column such as ``knee_r_flexion_deg`` over the right foot's strides; an unsided column
    such as ``lumbar_flexion_deg`` once per side, keyed ``<column>@left``/``@right``)."""
    t = np.asarray(t_s, dtype=np.float64)
    curves: dict[str, CycleCurve] = {}
    for column, values in angles_deg.items():
        try:
            _, side, _ = split_column(column)
        except ValueError:
            continue
        sides = [side] if side else list(SIDES)
        for s in sides:
            chosen = [st for st in strides if st.side == s and st.analysed]
            rows = [normalise_stride(t, np.asarray(values, dtype=float), st.ic_s, st.next_ic_s) for st in chosen]
            rows = [r for r in rows if np.all(np.isfinite(r))]
            if not rows:
                continue
            stack = np.stack(rows)
            stance = [100.0 * st.stance_s / st.stride_time_s for st in chosen if math.isfinite(st.fc_s)]
            key = column if side else f"{column}@{s}"
            curves[key] = CycleCurve(column, s, stack.mean(axis=0),
                                     stack.std(axis=0, ddof=1) if len(rows) > 1 else np.zeros(101),
                                     len(rows), float(np.mean(stance)) if stance else math.nan)
    return curves


@dataclass(frozen=True)
class NormativeBand:
    """A normal band of one joint and axis over the cycle: ``percent`` (K,) ascending in
    0..100, ``lower_deg``/``upper_deg`` (K,); ``source`` says where it comes from. A file
    with mean and SD gives mean ± ``sd_factor``·SD (1 SD by default)."""

    joint: str
    axis: str
    percent: np.ndarray
    lower_deg: np.ndarray
    upper_deg: np.ndarray
    source: str = ""

    def on_cycle(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper limits (101,) on :data:`CYCLE_PERCENT`."""
        return (np.interp(CYCLE_PERCENT, self.percent, self.lower_deg),
                np.interp(CYCLE_PERCENT, self.percent, self.upper_deg))

    def fraction_inside(self, curve_deg: np.ndarray) -> float:
        """Share (0..1) of a curve's 101 points inside the band."""
        low, high = self.on_cycle()
        return float(np.mean((curve_deg >= low) & (curve_deg <= high)))
