"""The magnetic field the simulated sensors sit in: the earth field and local disturbances.

Frames: world ENU (x east, y north, z up); fields in µT; positions in m; times in s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mimucap.core.simulate.minimum_jerk import minimum_jerk

_DEG = np.pi / 180.0


@dataclass(frozen=True)
class EarthField:
    """The undisturbed geomagnetic field.

    ``magnitude_uT`` total intensity (default 49.3 µT, central Europe); ``dip_deg`` inclination
    below the horizontal (default 60°); ``declination_deg`` angle of magnetic north east of the
    world y axis (default 0: the world frame is magnetic ENU).
    """

    magnitude_uT: float = 49.3
    dip_deg: float = 60.0
    declination_deg: float = 0.0

    def __post_init__(self) -> None:
        if not 1.0 <= self.magnitude_uT <= 200.0:
            raise ValueError(f"earth field magnitude {self.magnitude_uT} µT is outside 1..200 µT")
        if not -90.0 <= self.dip_deg <= 90.0:
            raise ValueError(f"field dip {self.dip_deg}° is outside -90..90°")

    def field_world_uT(self) -> np.ndarray:
        """The field vector (3,) in world ENU coordinates, µT (negative z for a positive dip)."""
        dip = self.dip_deg * _DEG
        dec = self.declination_deg * _DEG
        horizontal = self.magnitude_uT * np.cos(dip)
        return np.array(
            [horizontal * np.sin(dec), horizontal * np.cos(dec), -self.magnitude_uT * np.sin(dip)]
        )


@dataclass(frozen=True)
class MagneticDisturbance:
    """A local field added to the earth field during a time window, near a place.

    ``field_uT`` (3,) world-frame field added at full strength; active from ``start_s`` to
    ``end_s`` (s) with smooth ramps of ``ramp_s``; if ``center_m`` is given the strength falls
    off as ``exp(-|p - center|² / (2 radius_m²))`` with the sensor position ``p`` (m, world);
    ``sensor_ids`` restricts it to some sensors (empty: all).
    """

    field_uT: tuple[float, float, float]
    start_s: float
    end_s: float
    ramp_s: float = 0.5
    center_m: tuple[float, float, float] | None = None
    radius_m: float = 0.3
    sensor_ids: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.end_s <= self.start_s:
            raise ValueError(f"disturbance window must end after it starts ({self.start_s}..{self.end_s} s)")
        if self.ramp_s < 0 or self.radius_m <= 0:
            raise ValueError("disturbance ramp_s must be >= 0 and radius_m > 0")

    def strength(self, t_s: np.ndarray, position_m: np.ndarray | None) -> np.ndarray:
        """Weight in [0, 1] at times ``t_s`` (n,) and positions (n,3) (``None``: no fall-off)."""
        t = np.asarray(t_s, dtype=np.float64)
        ramp = max(self.ramp_s, 1e-9)
        rise = minimum_jerk((t - self.start_s) / ramp)
        fall = minimum_jerk((self.end_s - t) / ramp)
        weight = rise * fall
        if self.center_m is not None and position_m is not None:
            d2 = np.sum((np.asarray(position_m) - np.asarray(self.center_m)) ** 2, axis=-1)
            weight = weight * np.exp(-0.5 * d2 / self.radius_m**2)
        return weight



def disturbed_field(
    field_world_uT: np.ndarray,
    disturbances: tuple[MagneticDisturbance, ...],
    sensor_id: str,
    t_s: np.ndarray,
    position_m: np.ndarray | None,
) -> np.ndarray:
    """Field (n,3) µT in the world at a sensor: the earth field plus active disturbances."""
    t = np.asarray(t_s, dtype=np.float64)
    result = np.broadcast_to(np.asarray(field_world_uT, dtype=np.float64), t.shape + (3,)).copy()
    for disturbance in disturbances:
        if disturbance.sensor_ids and sensor_id not in disturbance.sensor_ids:
            continue
        weight = disturbance.strength(t, position_m)
        result += weight[:, None] * np.asarray(disturbance.field_uT, dtype=np.float64)
    return result
