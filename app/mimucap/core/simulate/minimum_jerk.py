"""The minimum-jerk profile (Flash & Hogan, "The coordination of arm movements: an
experimentally confirmed mathematical model"): the smooth 0 → 1 step with zero rate and
acceleration at both ends that shapes every simulated movement, blend and field ramp."""

from __future__ import annotations

import numpy as np


def minimum_jerk(x: np.ndarray) -> np.ndarray:
    """Minimum-jerk profile ``10x³ − 15x⁴ + 6x⁵`` clipped to [0, 1] (zero rate and acceleration
    at both ends; C²-continuous step from 0 at x ≤ 0 to 1 at x ≥ 1)."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return x * x * x * (10.0 + x * (-15.0 + 6.0 * x))
