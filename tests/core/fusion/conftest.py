"""Synthetic recordings with exact ground truth for the fusion tests."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from mimucap.core import rotation as rot

GRAVITY = 9.81
#: Earth field in the world (ENU): 20 µT north, 40 µT down (dip 63°).
FIELD_WORLD_UT = np.array([0.0, 20.0, -40.0])


@dataclass
class Recording:
    t_s: np.ndarray
    gyr: np.ndarray
    acc: np.ndarray
    mag: np.ndarray
    q_true: np.ndarray
    bias: np.ndarray


def make_recording(duration_s: float = 20.0, rate_hz: float = 100.0, *, amplitude_deg: float = 40.0,
                   bias_dps=(0.4, -0.3, 0.25), gyr_noise_dps: float = 0.05,
                   acc_noise: float = 0.02, mag_noise_uT: float = 0.2, seed: int = 0,
                   still_s: float = 0.0) -> Recording:
    """A sensor turning smoothly (sinusoidal body rates), sampled with bias and white noise.

    Gyro sample k is the mean body rate over (t_{k-1}, t_k] (10 sub-steps), the truth is the
    exponential-map integral of the same sub-steps; acc = R⁻¹·g_up, mag = R⁻¹·field.
    The first ``still_s`` seconds the sensor does not move.
    """
    rng = np.random.default_rng(seed)
    n = int(round(duration_s * rate_hz)) + 1
    sub = 10
    dt = 1.0 / rate_hz
    t = np.arange(n) * dt
    ts = (np.arange((n - 1) * sub) + 0.5) * dt / sub
    amp = np.radians(amplitude_deg)
    freq = np.array([0.31, 0.23, 0.17])
    phase = np.array([0.0, 1.0, 2.0])
    rate = amp * 2 * np.pi * freq * np.cos(2 * np.pi * freq * ts[:, None] + phase)
    if still_s > 0:
        rate[ts < still_s] = 0.0
    increments = rate * (dt / sub)
    q = np.empty((n, 4))
    q[0] = rot.from_axis_angle([0.3, -0.2, 1.0], 0.8)
    current = q[0]
    steps = rot.from_rotvec(increments)
    for k in range(1, n):
        for j in range((k - 1) * sub, k * sub):
            current = rot.multiply(current, steps[j])
        q[k] = current
    mean_rate = np.zeros((n, 3))
    mean_rate[1:] = rate.reshape(n - 1, sub, 3).mean(axis=1)
    mean_rate[0] = rate[0]
    bias = np.radians(np.asarray(bias_dps, dtype=float))
    gyr = mean_rate + bias + rng.normal(0, np.radians(gyr_noise_dps), (n, 3))
    q_inv = rot.conjugate(q)
    acc = rot.rotate(q_inv, np.array([0.0, 0.0, GRAVITY])) + rng.normal(0, acc_noise, (n, 3))
    mag = rot.rotate(q_inv, FIELD_WORLD_UT) + rng.normal(0, mag_noise_uT, (n, 3))
    return Recording(t, gyr, acc, mag, q, bias)


@pytest.fixture(scope="session")
def recording() -> Recording:
    return make_recording()


@pytest.fixture(scope="session")
def recording_factory():
    return make_recording
