"""Initial contact (IC) and final contact (FC, toe-off) of one foot from a sensor on the foot
or on the shank: its sagittal angular velocity (see :mod:`.sagittal`; rad/s, positive when the
distal end swings forward) and, where given, its acceleration in the sagittal plane.

Both placements share the swing: a long positive excursion of the sagittal rate whose peak
(mid-swing) exceeds ``min_swing_peak_rad_s`` and whose angle exceeds ``min_swing_angle_rad``,
found on a 5 Hz low-passed copy (Aminian et al. 2002, "Spatio-temporal parameters of gait
measured by an ambulatory system using miniature gyroscopes", J. Biomech. 35:689-699; Salarian
et al. 2004, "Gait assessment in Parkinson's disease: toward an ambulatory system for
long-term monitoring", IEEE TBME 51:1434-1443: mid-swing peaks above 50 °/s). The events are
then timed on a copy low-passed at ``event_lowpass_hz`` (zero phase, so no delay):

* **Initial contact is the heel strike itself**: the onset of the impact in the sagittal-plane
  acceleration (:mod:`.heel_strike`) after the swing, searched from ``heel_strike_window_s[0]``
  before to ``heel_strike_window_s[1]`` after the end of the swing's forward rotation (the
  + → − zero crossing of the rate). The foot's forward rotation ends in terminal swing, at or
  before the heel strikes (Perry & Burnfield, "Gait Analysis: Normal and Pathological
  Function", 2010: terminal swing is the last 13 % of the cycle, 0.14 s at 1.1 s per stride):
  where the foot reaches its highest pitch well before the heel lands (a flat, slow approach)
  the crossing is up to that much early, and the impact is not (after Rampp et al. 2015,
  "Inertial sensor-based stride parameter calculation from gait sequences in geriatric
  patients", IEEE TBME 62:1089-1097: the angular-rate minimum after the swing, refined where
  the acceleration shows the foot stopped by the ground). Without an acceleration, or where
  it shows no impact (a soft landing, a smooth synthetic signal), the placement's angular-rate
  rule below gives the contact.
* **Foot** (Rampp et al. 2015 and the gaitmap definitions): FC is the minimum of the sagittal
  rate in the push-off before the swing (the foot's fastest plantar-flexion as the toe leaves
  the ground); the angular-rate IC is the zero crossing that ends the swing: the forward
  rotation of the foot stops and the foot starts to roll down onto the ground.
* **Shank** (Salarian et al. 2004; Aminian et al. 2002; compared in Trojaniello et al. 2014,
  "Estimation of step-by-step spatio-temporal parameters of normal and impaired gait using
  shank-mounted magneto-inertial sensors", J. NeuroEng. Rehabil. 11:152): FC is the local
  minimum of the rate nearest before the swing (Salarian: "the local minimum prior to the
  mid-swing peak"; the shank's backward rotation in pre-swing may have more than one); the
  angular-rate IC is the first local minimum
  after the swing's zero crossing when it is sharp (the shank is stopped and thrown back at
  heel strike); where no such impact follows within ``shank_ic_window_s`` (a smooth signal),
  the zero crossing itself, the instant the shank's forward swing ends.

Every threshold is in physical units (s, rad/s, m/s²), so that the rules hold at any sampling
rate; times in seconds on the signal's own clock; events that cannot be timed are NaN.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mimucap.core.analysis.heel_strike import impact_time
from mimucap.core.analysis.signals import (
    check_finite,
    check_time,
    extremum_time,
    lowpass,
    resample,
    uniform_grid,
    zero_crossing_time,
)

PLACEMENTS = ("foot", "shank")


@dataclass(frozen=True)
class EventSettings:
    """Event detection settings.

    ``min_swing_peak_rad_s`` lowest mid-swing peak (1.0 rad/s = 57 °/s; Salarian et al. use
    50 °/s); ``min_swing_angle_rad`` lowest rotation during a swing (0.15 rad = 8.6°: low
    enough for the short pivoting steps of a turn, high enough that a weight shift is no step); ``min_swing_s``/``max_swing_s`` plausible swing
    durations (s); ``swing_lowpass_hz`` cut-off of the copy that finds swings;
    ``event_lowpass_hz`` cut-off of the copy that times events; ``fc_window_s`` how far
    before a swing the push-off minimum is searched (s); ``shank_ic_window_s`` how far after
    the end of a swing the shank's heel-strike minimum is searched (s);
    ``shank_impact_rad_s`` how sharply the rate must climb out of it to count as an impact;
    ``heel_strike_window_s`` (before, after) the end of the forward rotation, where the
    heel strike's impact is looked for (s); ``impact_min_m_s2`` and ``impact_span_s`` the
    least change of the sagittal acceleration within that time that is an impact (2 g in 10 ms:
    twice what free limb movement can do, :mod:`.heel_strike`).
    """

    min_swing_peak_rad_s: float = 1.0
    min_swing_angle_rad: float = 0.15
    min_swing_s: float = 0.15
    max_swing_s: float = 1.2
    swing_lowpass_hz: float = 5.0
    event_lowpass_hz: float = 30.0
    fc_window_s: float = 0.35
    shank_ic_window_s: float = 0.06
    shank_impact_rad_s: float = 0.35
    heel_strike_window_s: tuple[float, float] = (0.03, 0.15)
    impact_min_m_s2: float = 2.0 * 9.81
    impact_span_s: float = 0.01

    def __post_init__(self) -> None:
        for name in ("min_swing_peak_rad_s", "min_swing_angle_rad", "min_swing_s", "max_swing_s",
                     "swing_lowpass_hz", "event_lowpass_hz", "fc_window_s", "shank_ic_window_s",
                     "shank_impact_rad_s", "impact_min_m_s2", "impact_span_s"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"event setting {name} must be a positive number, got {value}")
        before, after = self.heel_strike_window_s
        if not (np.isfinite(before) and np.isfinite(after) and before >= 0 and after > 0):
            raise ValueError(f"heel_strike_window_s must be (before >= 0, after > 0) s, got {self.heel_strike_window_s}")
        if self.max_swing_s <= self.min_swing_s:
            raise ValueError("max_swing_s must exceed min_swing_s")


DEFAULT_EVENT_SETTINGS = EventSettings()


@dataclass(frozen=True)
class SwingEvents:
    """The swings of one foot, in time order: ``t_fc_s`` (K,) final contact before each swing,
    ``t_ic_s`` (K,) initial contact ending it, ``t_mid_swing_s`` (K,) its peak (s; NaN where an
    event could not be timed); ``ic_at_impact`` (K,) True where the initial contact is the
    heel strike's impact, False where the angular-rate rule gave it; ``placement`` foot or
    shank; ``rate_hz`` the analysis rate."""

    placement: str
    t_fc_s: np.ndarray
    t_ic_s: np.ndarray
    t_mid_swing_s: np.ndarray
    rate_hz: float
    ic_at_impact: np.ndarray

    def __len__(self) -> int:
        return int(self.t_ic_s.shape[0])


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, end) index pairs (end exclusive) of the True runs of ``mask``."""
    padded = np.concatenate(([False], mask, [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return list(zip(edges[0::2], edges[1::2]))


def detect_swing_events(t_s: np.ndarray, sagittal_rate: np.ndarray, placement: str,
                        settings: EventSettings = DEFAULT_EVENT_SETTINGS,
                        sagittal_acc: np.ndarray | None = None) -> SwingEvents:
    """Swings with their FC and IC from the sagittal rate (N,) rad/s at times ``t_s`` (N,) s
    of a ``placement`` ("foot" or "shank") sensor, and its sagittal-plane acceleration (N, 2)
    m/s² when given (:meth:`.sagittal.SagittalAxes.acceleration`); see the module doc.
    Irregular sampling (dropped samples) is resampled to the median interval first."""
    if placement not in PLACEMENTS:
        raise ValueError(f"sensor placement must be one of {', '.join(PLACEMENTS)}, got {placement!r}")
    t = check_time(t_s, f"{placement} sensor")
    rate = check_finite(sagittal_rate, f"{placement} sagittal angular velocity")
    if rate.shape != t.shape:
        raise ValueError(f"{placement} sensor: {rate.shape[0]} rate samples for {t.shape[0]} time stamps")
    acc = None
    if sagittal_acc is not None:
        acc = check_finite(sagittal_acc, f"{placement} sagittal acceleration")
        if acc.shape != (t.shape[0], 2):
            raise ValueError(f"{placement} sensor: sagittal acceleration must have shape ({t.shape[0]}, 2), got {acc.shape}")
    grid, rate_hz = uniform_grid(t)
    signal = resample(t, rate, grid)
    if acc is not None:
        acc = resample(t, acc, grid)
    slow = lowpass(signal, rate_hz, settings.swing_lowpass_hz)
    fast = lowpass(signal, rate_hz, settings.event_lowpass_hz)
    dt = 1.0 / rate_hz
    n = grid.shape[0]
    fc_window = max(int(round(settings.fc_window_s * rate_hz)), 2)
    ic_window = max(int(round(settings.shank_ic_window_s * rate_hz)), 2)
    strike_before = int(round(settings.heel_strike_window_s[0] * rate_hz))
    strike_after = max(int(round(settings.heel_strike_window_s[1] * rate_hz)), 1)
    t_fc, t_ic, t_mid, at_impact = [], [], [], []
    previous_ic_index = 0
    for start, end in _runs(slow > 0.0):
        segment = slow[start:end]
        peak = start + int(np.argmax(segment))
        duration = (end - start) * dt
        if slow[peak] < settings.min_swing_peak_rad_s or np.sum(segment) * dt < settings.min_swing_angle_rad:
            continue
        if not settings.min_swing_s <= duration <= settings.max_swing_s:
            continue
        # Swing on the event copy: from the last − → + crossing before the peak to the first
        # + → − crossing after it.
        rise = peak
        while rise > 0 and fast[rise - 1] > 0.0:
            rise -= 1
        fall = peak
        while fall < n - 1 and fast[fall + 1] > 0.0:
            fall += 1
        if fall >= n - 1 or rise == 0:
            continue  # the recording cuts the swing: its contacts are not in it
        ic = zero_crossing_time(grid, fast, fall)
        if placement == "shank":
            # The heel-strike minimum: the first local minimum after the crossing that the rate
            # climbs out of by at least ``shank_impact_rad_s`` (an impact, not a smooth turn).
            stop = min(fall + 1 + ic_window, n - 1)
            for i in range(fall + 1, stop):
                if fast[i] < fast[i - 1] and fast[i] <= fast[i + 1]:
                    if np.max(fast[i:min(i + ic_window, n)]) - fast[i] >= settings.shank_impact_rad_s:
                        ic = extremum_time(grid, fast, i)
                    break
        impact = math.nan
        if acc is not None:
            impact = impact_time(grid, acc, fall - strike_before, fall + strike_after, rate_hz,
                                 settings.impact_min_m_s2, settings.impact_span_s)
        low = max(rise - fc_window, previous_ic_index)
        fc = float("nan")
        if rise - low >= 2:
            if placement == "foot":
                index = low + int(np.argmin(fast[low:rise + 1]))
            else:
                index = rise - 1  # the local minimum nearest before the swing
                while index > low and not (fast[index] < fast[index - 1] and fast[index] <= fast[index + 1]):
                    index -= 1
            if low < index < rise:
                fc = extremum_time(grid, fast, index)
        t_fc.append(fc)
        t_ic.append(impact if math.isfinite(impact) else ic)
        at_impact.append(math.isfinite(impact))
        t_mid.append(extremum_time(grid, slow, peak))
        previous_ic_index = fall + 1
    return SwingEvents(placement, np.asarray(t_fc, dtype=float), np.asarray(t_ic, dtype=float),
                       np.asarray(t_mid, dtype=float), float(rate_hz), np.asarray(at_impact, dtype=bool))
