"""The heel strike as the accelerometer feels it: the impact.

When the heel hits the ground, the foot, and through the leg the shank, is stopped within a
few milliseconds: its acceleration jumps by several g. Rampp et al. 2015 ("Inertial
sensor-based stride parameter calculation from gait sequences in geriatric patients", IEEE
TBME 62:1089-1097) time the initial contact where "the foot decelerates rapidly when it hits the
ground", in the antero-posterior acceleration near the angular-rate minimum that follows the
swing; Selles et al. 2005 ("Automated estimation of initial and terminal contact timing using
accelerometers; development and validation in transtibial amputees and controls", IEEE TNSRE
13:81-88) time both contacts with accelerometers on the shank. An extremum of one
acceleration axis depends on how the sensor is mounted (the heel's impact, mostly along the leg,
and the forefoot's slap share each axis in proportions that turn with the sensor). Here the
impact is looked for in the acceleration in the sagittal plane (antero-posterior and vertical
components, :mod:`.sagittal`), whose change does not depend on how the sensor is turned within
that plane:

* it *begins* where the acceleration first changes by at least ``min_change_m_s2`` within
  ``span_s``. Free limb movement cannot do that: the foot's swing accelerations of a few g vary
  at the stride's harmonics (below about 10 Hz), which changes them by less than 1 g in 10 ms;
* the contact is *timed* at the impact's onset, the instant the floor starts to push: the
  steepest step of the rise (how far the acceleration has moved from where it was before the
  impact, over the following two spans, up to its furthest) is extended back to zero, as a force
  plate times a contact where its force starts to rise. A rise within one sample interval puts
  the onset at the interval's start; a rise spread over several samples (a soft heel, a lower
  sampling rate) puts it where the rise, extended, leaves the level before it. Only this first
  impact counts: a later one in the window (the forefoot landing) does not move it.

Times in seconds on a uniform grid; acceleration (N, 2) m/s².
"""

from __future__ import annotations

import math

import numpy as np


def impact_time(t_s: np.ndarray, acc_sagittal: np.ndarray, first: int, last: int, rate_hz: float,
                min_change_m_s2: float, span_s: float) -> float:
    """Time (s) of the onset of the first impact within samples ``first .. last`` (inclusive)
    of ``acc_sagittal`` (N, 2) m/s² on the uniform grid ``t_s`` (N,) at ``rate_hz`` (module
    doc), or NaN when the acceleration shows none there."""
    first, last = max(int(first), 0), min(int(last), t_s.shape[0] - 1)
    span = max(int(round(span_s * rate_hz)), 1)
    if last - first < span:
        return math.nan
    window = acc_sagittal[first:last + 1]
    change = np.linalg.norm(window[span:] - window[:-span], axis=1)
    begins = np.flatnonzero(change >= min_change_m_s2)
    if not begins.size:
        return math.nan
    k = first + int(begins[0])
    stop = min(k + 2 * span, acc_sagittal.shape[0] - 1)
    moved = np.linalg.norm(acc_sagittal[k:stop + 1] - acc_sagittal[k], axis=1)
    furthest = int(np.argmax(moved))
    if furthest == 0:
        return float(t_s[k])
    steps = np.diff(moved[:furthest + 1])
    steepest = int(np.argmax(steps))
    onset = t_s[k + steepest] - moved[steepest] / steps[steepest] / rate_hz
    return float(max(onset, t_s[k]))
