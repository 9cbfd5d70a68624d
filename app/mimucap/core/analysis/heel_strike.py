"""The heel strike as the accelerometer feels it: the impact.

When the heel hits the ground, the foot, and through the leg the shank, is stopped within a
few milliseconds: its acceleration jumps by several g. Rampp et al. 2015 ("Inertial
sensor-based stride parameter calculation from gait sequences in geriatric patients", IEEE
TBME 62:1089-1097) time the initial contact where "the foot decelerates rapidly when it hits the
ground", in the antero-posterior acceleration near the angular-rate minimum that follows the
swing; Selles et al. 2005 ("Automated estimation of initial and terminal contact timing using
accelerometers; development and validation in transtibial amputees and controls", IEEE TNSRE
13:81-88) time both contacts with accelerometers on the shank. Here the impact is looked for in the acceleration
in the sagittal plane (antero-posterior and vertical components, :mod:`.sagittal`), whose
change does not depend on how the sensor is turned within that plane:

* it *exists* when the acceleration changes by at least ``min_change_m_s2`` within
  ``span_s``. Free limb movement cannot do that: the foot's swing accelerations of a few g vary
  at the stride's harmonics (below about 10 Hz), which changes them by less than 1 g in 10 ms;
* it is *timed* at its half-rise: the first sample interval whose change reaches half of the
  largest one in the search window, at that interval's midpoint (the contact happened between
  its two samples; a later, larger impact such as the forefoot landing does not move it).

Times in seconds on a uniform grid; acceleration (N, 2) m/s².
"""

from __future__ import annotations

import math

import numpy as np


def impact_time(t_s: np.ndarray, acc_sagittal: np.ndarray, first: int, last: int, rate_hz: float,
                min_change_m_s2: float, span_s: float) -> float:
    """Time (s) of the first impact within samples ``first .. last`` (inclusive) of
    ``acc_sagittal`` (N, 2) m/s² on the uniform grid ``t_s`` (N,) at ``rate_hz`` (module doc),
    or NaN when the acceleration shows none there."""
    first, last = max(int(first), 0), min(int(last), t_s.shape[0] - 1)
    span = max(int(round(span_s * rate_hz)), 1)
    if last - first < span:
        return math.nan
    window = acc_sagittal[first:last + 1]
    change = np.linalg.norm(window[span:] - window[:-span], axis=1)
    if not float(change.max()) >= min_change_m_s2:
        return math.nan
    step = np.linalg.norm(np.diff(window, axis=0), axis=1)
    k = int(np.argmax(step >= 0.5 * float(step.max())))
    return float(0.5 * (t_s[first + k] + t_s[first + k + 1]))
