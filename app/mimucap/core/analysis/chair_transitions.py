"""Standing up from a chair and sitting down on it, from the thighs and the trunk.

Seated, the thighs lie level (inclination about 90° from vertical); standing, they hang
(below about 20°). A **sit-to-stand** is a passage of the mean inclination of both thighs from
above ``seated_deg`` to below ``standing_deg``, a **stand-to-sit** the reverse; its middle
(``mid_s``) is where the thighs pass halfway, 45°: "more than halfway up" is how Jones, Rikli
and Beam ("A 30-s chair-stand test as a measure of lower body strength in community-residing
older adults", 1999) decide whether a last stand counts.

Its start and end come from the trunk, which moves first and settles last (Schenkman, Berger,
Riley, Mann, Hodge, "Whole-body movements during rising to standing from sitting", 1990: the
trunk flexes forward, then hips, knees and trunk extend together; sitting down is the reverse):
the trunk's flexion rate (:func:`~.segment_motion.flexion_rate_dps`) has a forward-flexion peak
before the middle and an extension peak after it. The transition starts where, going back
from the flexion peak, the rate falls below ``rest_fraction`` of that peak (or ``rest_dps``,
whichever is larger), and ends where, going on from the extension peak, it comes back within
that fraction of the extension peak. The peaks are searched within ``max_phase_s`` of the
middle and never beyond the middle of a neighbouring transition; a passage whose trunk does not
both flex and extend faster than ``min_peak_dps`` is no transition (the thigh sensors handled
off the body, before the test, can pass through the same angles).

Inputs: ``t_s`` (T,) s, ``thigh_inclination_deg`` (T,) the mean of both thighs, and
``trunk_flexion_dps`` (T,) on the same grid. Output: :class:`ChairTransition` in time order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mimucap.core.analysis.signals import check_finite, check_time

SIT_TO_STAND = "sit-to-stand"
STAND_TO_SIT = "stand-to-sit"


@dataclass(frozen=True)
class TransitionSettings:
    """``seated_deg``/``standing_deg`` thigh inclinations (deg) that mean seated and standing;
    ``halfway_deg`` the middle; ``rest_fraction`` and ``rest_dps`` (deg/s) when the trunk is
    taken to be still; ``max_phase_s`` (s) the longest trunk flexion or extension phase;
    ``min_peak_dps`` (deg/s) the slowest trunk flexion and extension of a transition."""

    seated_deg: float = 60.0
    standing_deg: float = 25.0
    halfway_deg: float = 45.0
    rest_fraction: float = 0.05
    rest_dps: float = 2.0
    max_phase_s: float = 3.0
    min_peak_dps: float = 10.0

    def __post_init__(self) -> None:
        if not 0.0 < self.standing_deg < self.halfway_deg < self.seated_deg < 90.0:
            raise ValueError("transition settings need 0 < standing_deg < halfway_deg < seated_deg < 90")
        if not 0.0 < self.rest_fraction < 0.5 or self.rest_dps < 0 or self.max_phase_s <= 0:
            raise ValueError("transition settings need 0 < rest_fraction < 0.5, rest_dps >= 0, max_phase_s > 0")


DEFAULT_TRANSITION_SETTINGS = TransitionSettings()


@dataclass(frozen=True)
class ChairTransition:
    """One transition: ``kind`` :data:`SIT_TO_STAND` or :data:`STAND_TO_SIT`; ``start_s`` and
    ``end_s`` from the trunk, ``mid_s`` the thighs halfway (s); ``peak_flexion_dps`` and
    ``peak_extension_dps`` the trunk's peak rates (deg/s, both positive)."""

    kind: str
    start_s: float
    mid_s: float
    end_s: float
    peak_flexion_dps: float
    peak_extension_dps: float

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


def find_transitions(t_s: np.ndarray, thigh_inclination_deg: np.ndarray, trunk_flexion_dps: np.ndarray,
                     settings: TransitionSettings = DEFAULT_TRANSITION_SETTINGS) -> list[ChairTransition]:
    """Every sit-to-stand and stand-to-sit (module doc), in time order."""
    t = check_time(t_s, "chair transitions")
    thigh = check_finite(thigh_inclination_deg, "thigh inclination")
    trunk = check_finite(trunk_flexion_dps, "trunk flexion rate")
    if thigh.shape != t.shape or trunk.shape != t.shape:
        raise ValueError(f"chair transitions: {thigh.shape[0]} thigh and {trunk.shape[0]} trunk samples "
                         f"for {t.shape[0]} time stamps")
    middles = _middles(t, thigh, settings)
    found = []
    for k, (kind, mid) in enumerate(middles):
        before = middles[k - 1][1] if k > 0 else -np.inf
        after = middles[k + 1][1] if k + 1 < len(middles) else np.inf
        low = max(mid - settings.max_phase_s, 0.5 * (before + mid))
        high = min(mid + settings.max_phase_s, 0.5 * (mid + after))
        timed = _trunk_bounds(t, trunk, low, mid, high, settings)
        if timed is not None:
            found.append(ChairTransition(kind, timed[0], mid, timed[1], timed[2], timed[3]))
    return found


def _middles(t: np.ndarray, thigh: np.ndarray, settings: TransitionSettings) -> list[tuple[str, float]]:
    """(kind, time the thighs pass halfway) of every passage between seated and standing."""
    state = None
    last_index = 0
    middles = []
    for index in np.flatnonzero((thigh > settings.seated_deg) | (thigh < settings.standing_deg)):
        now = "seated" if thigh[index] > settings.seated_deg else "standing"
        if state is not None and now != state:
            span = slice(last_index, index + 1)
            middles.append((SIT_TO_STAND if now == "standing" else STAND_TO_SIT,
                            _last_crossing(t[span], thigh[span], settings.halfway_deg)))
        state = now
        last_index = index
    return middles


def _last_crossing(t: np.ndarray, values: np.ndarray, level: float) -> float:
    """Time of the last crossing of ``level`` (linear between samples)."""
    above = values > level
    k = int(np.flatnonzero(above[1:] != above[:-1])[-1])
    a, b = values[k] - level, values[k + 1] - level
    return float(t[k] + a / (a - b) * (t[k + 1] - t[k]))


def _trunk_bounds(t: np.ndarray, rate: np.ndarray, low: float, mid: float, high: float,
                  settings: TransitionSettings) -> tuple[float, float, float, float] | None:
    """(start, end, flexion peak, extension peak) from the trunk's flexion rate around ``mid``."""
    first, centre, last = np.searchsorted(t, [low, mid, high])
    last = min(last, t.shape[0] - 1)
    if centre - first < 2 or last - centre < 2:
        return None
    flex = first + int(np.argmax(rate[first:centre + 1]))
    ext = centre + int(np.argmin(rate[centre:last + 1]))
    peak_flex, peak_ext = float(rate[flex]), float(-rate[ext])
    if min(peak_flex, peak_ext) < settings.min_peak_dps:
        return None
    start_level = max(settings.rest_fraction * peak_flex, settings.rest_dps)
    end_level = max(settings.rest_fraction * peak_ext, settings.rest_dps)
    k = flex
    while k > first and rate[k] > start_level:
        k -= 1
    start = _level_time(t, rate, k, start_level)
    k = ext
    while k < last and -rate[k] > end_level:
        k += 1
    end = _level_time(t, -rate, k - 1, end_level)
    return start, end, peak_flex, peak_ext


def _level_time(t: np.ndarray, values: np.ndarray, k: int, level: float) -> float:
    """Time between samples ``k`` and ``k + 1`` where ``values`` crosses ``level`` (linear);
    the nearer sample's time when it does not cross there."""
    k = int(np.clip(k, 0, t.shape[0] - 2))
    a, b = values[k] - level, values[k + 1] - level
    if a == b or a * b > 0:
        return float(t[k] if abs(a) < abs(b) else t[k + 1])
    return float(t[k] + a / (a - b) * (t[k + 1] - t[k]))
