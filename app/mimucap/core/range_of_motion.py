"""Range of motion of joint-angle curves over a time window (pure numpy).

The range of motion (ROM) of a joint-angle column is its largest minus its smallest value over
the samples whose time lies in the window, as goniometry reports it (e.g. Norkin & White,
"Measurement of Joint Motion: A Guide to Goniometry"). Samples that are not finite (a gap in
the pose) are left out.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RangeOfMotion:
    """One column's extremes over a window: ``min_deg``, ``max_deg`` and ``rom_deg`` = max − min
    (degrees), from ``samples`` finite samples."""

    min_deg: float
    max_deg: float
    rom_deg: float
    samples: int


def window_mask(t_s: np.ndarray, start_s: float | None = None, end_s: float | None = None) -> np.ndarray:
    """Boolean mask (T,) of the times ``t_s`` (T,) s in ``[start_s, end_s]`` (open ends when None);
    ``ValueError`` when ``end_s`` comes before ``start_s``."""
    t = np.asarray(t_s, dtype=float)
    if start_s is not None and end_s is not None and end_s < start_s:
        raise ValueError(f"the window ends ({end_s:.3f} s) before it starts ({start_s:.3f} s)")
    mask = np.ones(t.shape, dtype=bool)
    if start_s is not None:
        mask &= t >= start_s
    if end_s is not None:
        mask &= t <= end_s
    return mask


def range_of_motion(t_s: np.ndarray, angles_deg: Mapping[str, np.ndarray], start_s: float | None = None,
                    end_s: float | None = None) -> dict[str, RangeOfMotion]:
    """Column → :class:`RangeOfMotion` of joint-angle curves ``angles_deg`` (column → (T,) deg)
    sampled at ``t_s`` (T,) s, over ``[start_s, end_s]``. A column without a finite sample in
    the window is left out; ``ValueError`` when a column's length differs from ``t_s``."""
    t = np.asarray(t_s, dtype=float)
    mask = window_mask(t, start_s, end_s)
    found: dict[str, RangeOfMotion] = {}
    for column, values in angles_deg.items():
        values = np.asarray(values, dtype=float)
        if values.shape != t.shape:
            raise ValueError(f"joint angle {column}: {values.shape[0] if values.ndim else 0} samples "
                             f"for {t.shape[0]} times")
        chosen = values[mask]
        chosen = chosen[np.isfinite(chosen)]
        if chosen.size:
            low, high = float(chosen.min()), float(chosen.max())
            found[column] = RangeOfMotion(low, high, high - low, int(chosen.size))
    return found


__all__ = ["RangeOfMotion", "window_mask", "range_of_motion"]
