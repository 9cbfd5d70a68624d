"""Accuracy of the estimated joint angles against a simulation's ground truth (no Qt).

The simulated suit knows every true joint angle; the estimate comes from its sensors only. This
module compares the two, for the on-screen accuracy check (live and in review), the tests and
the end-to-end benchmark. Truth is never an input of the estimate: it enters here, and only here.

Angles in degrees; times in seconds on one clock (the truth's samples are interpolated onto the
estimate's instants).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class AngleError:
    """One joint-angle column's error over a span: ``rms_deg``, ``max_abs_deg``, ``mean_deg``
    (bias, estimate − truth) and ``samples`` compared."""

    column: str
    rms_deg: float
    max_abs_deg: float
    mean_deg: float
    samples: int


def truth_at(t_s: np.ndarray, truth_t_s: np.ndarray, truth_deg: np.ndarray) -> np.ndarray:
    """The true angle (deg) at the instants ``t_s`` (linear interpolation; NaN outside the truth)."""
    return np.interp(t_s, truth_t_s, truth_deg, left=np.nan, right=np.nan)


def angle_errors(t_s: np.ndarray, angles_deg: Mapping[str, np.ndarray], truth_t_s: np.ndarray,
                 truth_deg: Mapping[str, np.ndarray], span_s: tuple[float, float] | None = None) -> dict[str, AngleError]:
    """Error of every column the estimate and the truth both have, over ``span_s`` (the whole
    overlap when None). Columns without a sample in the span are left out."""
    t_s = np.asarray(t_s, dtype=np.float64)
    keep = np.ones(t_s.shape, dtype=bool) if span_s is None else (t_s >= span_s[0]) & (t_s <= span_s[1])
    errors = {}
    for column, values in angles_deg.items():
        if column not in truth_deg:
            continue
        reference = truth_at(t_s[keep], np.asarray(truth_t_s), np.asarray(truth_deg[column]))
        diff = np.asarray(values)[keep] - reference
        diff = diff[np.isfinite(diff)]
        if not diff.size:
            continue
        errors[column] = AngleError(column, float(np.sqrt(np.mean(diff ** 2))), float(np.max(np.abs(diff))),
                                    float(np.mean(diff)), int(diff.size))
    return errors


def rms_over_spans(t_s: np.ndarray, angles_deg: Mapping[str, np.ndarray], truth_t_s: np.ndarray,
                   truth_deg: Mapping[str, np.ndarray], spans_s, columns) -> dict[str, float]:
    """RMS error (deg) of each of ``columns`` over all the time spans ``spans_s`` (``(start, end)``
    s pairs) together, each span's samples counted alike (:func:`angle_errors` per span)."""
    squared: dict[str, list[tuple[float, int]]] = {column: [] for column in columns}
    for span in spans_s:
        errors = angle_errors(t_s, angles_deg, truth_t_s, truth_deg, span_s=span)
        for column in columns:
            if column in errors:
                squared[column].append((errors[column].rms_deg ** 2, errors[column].samples))
    return {column: float(np.sqrt(sum(s * n for s, n in parts) / sum(n for _, n in parts)))
            for column, parts in squared.items() if parts}


#: The joint angles the on-screen accuracy check and the benchmark sum up.
FLEXION_COLUMNS = ("hip_l_flexion_deg", "hip_r_flexion_deg", "knee_l_flexion_deg", "knee_r_flexion_deg",
                   "elbow_l_flexion_deg", "elbow_r_flexion_deg")


def accuracy_phrase(rms_deg_by_column: Mapping[str, float]) -> str:
    """What the status bar adds for a source with truth: ``"; vs. truth: flexion RMS m° (worst
    w°)"`` over :data:`FLEXION_COLUMNS` (RMS errors in degrees, column → value); "" when none
    of them is known."""
    flexion = [rms_deg_by_column[c] for c in FLEXION_COLUMNS if c in rms_deg_by_column]
    if not flexion:
        return ""
    return f"; vs. truth: flexion RMS {sum(flexion) / len(flexion):.1f}° (worst {max(flexion):.1f}°)"
