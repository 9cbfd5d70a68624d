"""Helpers for the acquisition tests: a small synthetic motion source with known values."""

from __future__ import annotations

import numpy as np
import pytest


class SyntheticMotion:
    """Each sensor turns about z at a constant rate; readings follow from physics.

    Sensor ``i`` turns at ``0.5 + 0.1·i`` rad/s about the world vertical, lying flat: acc
    reads +9.81 m/s² along z, gyr the turn rate about z, the field 20 µT north + 40 µT down
    rotated into the sensor frame, and the on-board quaternion the true orientation.
    """

    def __init__(self, n_sensors: int, rate_hz: float) -> None:
        self.n_sensors = n_sensors
        self.rate_hz = rate_hz
        self.k = 0

    def advance(self, n_samples: int) -> dict[str, np.ndarray]:
        t = (self.k + np.arange(n_samples)) / self.rate_hz
        self.k += n_samples
        w = 0.5 + 0.1 * np.arange(self.n_sensors)[:, None]
        angle = w * t[None, :]                       # (S, N) heading of sensor in world
        zeros, ones = np.zeros_like(angle), np.ones_like(angle)
        acc = np.stack([zeros, zeros, 9.81 * ones], axis=-1)
        gyr = np.stack([zeros, zeros, w * ones], axis=-1)
        # field in world (0, 20, -40) seen from a sensor rotated by `angle` about z
        mag = np.stack([20.0 * np.sin(angle), 20.0 * np.cos(angle), -40.0 * ones], axis=-1)
        q = np.stack([np.cos(angle / 2), zeros, zeros, np.sin(angle / 2)], axis=-1)
        return {"acc": acc, "gyr": gyr, "mag_uT": mag, "q_world_from_sensor": q}


@pytest.fixture
def synthetic_motion():
    return SyntheticMotion
