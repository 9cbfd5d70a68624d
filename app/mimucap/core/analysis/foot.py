"""Strides of a foot-worn sensor: events (:mod:`.gait_events`, foot rules), then each
stride's length and heading change by zero-velocity-update integration (:mod:`.zupt`).

Inputs: ``t_s`` (N,) s, ``acc`` (N, 3) m/s² and ``gyr`` (N, 3) rad/s in the sensor frame,
``sagittal_rate`` (N,) rad/s and, where known, ``sagittal_acc`` (N, 2) m/s² (antero-posterior
and vertical; see :mod:`.sagittal`). Irregular sampling is resampled to the median interval
first.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from mimucap.core.analysis.gait_events import DEFAULT_EVENT_SETTINGS, EventSettings, SwingEvents, detect_swing_events
from mimucap.core.analysis.signals import check_finite, check_time, resample, uniform_grid
from mimucap.core.analysis.strides import Stride, pair_strides
from mimucap.core.analysis.zupt import integrate_stride, rest_index

#: Length (s) of the quietest window that marks mid-stance (Rampp et al. 2015 use 100 ms).
REST_WINDOW_S = 0.1
#: How long after the last initial contact of a walk the foot's rest is looked for (s).
LAST_REST_SEARCH_S = 1.0


def foot_strides(side: str, t_s: np.ndarray, acc: np.ndarray, gyr: np.ndarray, sagittal_rate: np.ndarray,
                 settings: EventSettings = DEFAULT_EVENT_SETTINGS,
                 sagittal_acc: np.ndarray | None = None) -> tuple[list[Stride], SwingEvents]:
    """Candidate strides of one foot with length and heading change, and its swing events."""
    t = check_time(t_s, f"{side} foot sensor")
    acc = check_finite(acc, f"{side} foot accelerometer")
    gyr = check_finite(gyr, f"{side} foot gyroscope")
    if acc.shape != (t.shape[0], 3) or gyr.shape != (t.shape[0], 3):
        raise ValueError(f"{side} foot sensor: acc and gyr must have shape ({t.shape[0]}, 3), got {acc.shape}, {gyr.shape}")
    events = detect_swing_events(t, sagittal_rate, "foot", settings, sagittal_acc)
    strides = pair_strides(side, events.t_ic_s, events.t_fc_s)
    if not strides:
        return strides, events
    grid, rate_hz = uniform_grid(t)
    acc_u, gyr_u = resample(t, acc, grid), resample(t, gyr, grid)
    window = max(int(round(REST_WINDOW_S * rate_hz)), 3)
    index = lambda time: int(np.clip(np.searchsorted(grid, time), 0, grid.shape[0] - 1))  # noqa: E731
    # The rest in the stance that starts at swing k's initial contact: up to swing k+1's final
    # contact, or (after the last swing) within a second.
    rests = []
    for k in range(len(events)):
        start = events.t_ic_s[k]
        end = events.t_fc_s[k + 1] if k + 1 < len(events) else start + LAST_REST_SEARCH_S
        if not (math.isfinite(start) and math.isfinite(end)) or end <= start:
            rests.append(None)
            continue
        rests.append(rest_index(gyr_u, index(start), index(end), window))
    result = []
    for k, stride in enumerate(strides):
        a, b = rests[k], rests[k + 1]
        if a is None or b is None or b <= a:
            result.append(stride)
            continue
        moved = integrate_stride(acc_u, gyr_u, rate_hz, a, b, rest_half_window=window // 2)
        result.append(replace(stride, stride_length_m=moved.length_m,
                              heading_change_deg=math.degrees(moved.heading_change_rad)))
    return result, events
