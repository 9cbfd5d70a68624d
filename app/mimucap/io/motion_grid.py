"""A uniform time grid for the motion files that need one (C3D frames, BVH frames).

The pipeline's pose grid ``t_s`` (T,) s follows one sensor's samples, which a dropped packet
leaves uneven; C3D and BVH store a frame rate instead of times. :func:`uniform_grid` lays frames
at the median step from the first pose to the last; :func:`sample_series` interpolates values
linearly onto it and :func:`sample_orientations` interpolates unit quaternions (w, x, y, z) by
slerp (the shorter arc), so a pose grid that was uniform already comes through unchanged.
"""

from __future__ import annotations

import numpy as np

from mimucap.core.analysis import signals
from mimucap.core.pipeline.instants import orientation_at


def uniform_grid(t_s: np.ndarray) -> tuple[np.ndarray, float]:
    """``(t_uniform (F,), rate_hz)`` from ``t_s[0]`` to ``t_s[-1]`` at the median step of ``t_s``
    (:func:`mimucap.core.analysis.signals.uniform_grid`), for poses at increasing times."""
    t = np.asarray(t_s, dtype=np.float64)
    if t.ndim != 1 or t.size < 2 or np.any(~np.isfinite(t)) or np.any(np.diff(t) <= 0.0):
        raise ValueError("a motion file needs at least two poses at strictly increasing times")
    return signals.uniform_grid(t)


def sample_series(t_src: np.ndarray, values: np.ndarray, t_dst: np.ndarray) -> np.ndarray:
    """``values`` (N, ...) at ``t_src`` (N,) linearly interpolated at ``t_dst`` (F,) → (F, ...)."""
    values = np.asarray(values, dtype=np.float64)
    flat = signals.resample(t_src, values.reshape(len(values), -1), t_dst)
    return flat.reshape((len(t_dst),) + values.shape[1:])


def sample_orientations(t_src: np.ndarray, q: np.ndarray, t_dst: np.ndarray) -> np.ndarray:
    """Unit quaternions ``q`` (N, 4) at ``t_src`` (N,) slerped at ``t_dst`` (F,) → (F, 4), as
    :func:`mimucap.core.pipeline.instants.orientation_at` samples an orientation track (the grid of
    :func:`uniform_grid` lies within ``t_src``'s span)."""
    return orientation_at(np.asarray(t_dst, dtype=np.float64), np.asarray(t_src, dtype=np.float64),
                          np.asarray(q, dtype=np.float64))
