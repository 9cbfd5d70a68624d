"""Magnetometer-calibration motions of one hand-held sensor, with ground truth.

Protocols (the single-axis protocol of Choe, Zhao, Qiu and So, "Study of calibration method
of low-cost MEMS magnetometer", and two common alternatives):

* ``"single_axis"``: the sensor is turned ``turns`` full turns about its x axis, then its y
  axis, then its z axis; before each, the hand re-grasps it so that the axis to be turned is
  roughly horizontal (within ±10° of level, pointing within ±45° of east, so that nearly the
  whole field sweeps a circle). Each turn starts and stops smoothly (minimum-jerk profile);
  the hand adds a small wobble (about 2°, 0.1–0.8 Hz) and the sensor sits a few
  centimetres off the turning axis.
* ``"figure8"``: ``turns`` figure-8 gestures (6 s each) sweeping yaw ±90°, pitch ±50° and
  roll ±60° while the hand traces a figure 8 in the air.
* ``"tumble"``: random smooth tumbling (``turns`` periods of 10 s), three Euler angles each a
  sum of random slow sinusoids.

Frames: world ENU, ``q_world_from_sensor`` scalar-first. Units: s, m/s², rad/s, µT.
The returned :class:`CalibrationMotion` holds the raw measurements (error model of
:mod:`mimucap.core.simulate.sensor_errors`), the true orientation, the true hard/soft iron and the
field, and which sensor axis is being turned at each sample (single-axis protocol).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mimucap.core import rotation as rot
from mimucap.core.simulate.magnetic_field import EarthField
from mimucap.core.simulate.minimum_jerk import minimum_jerk
from mimucap.core.simulate.sensor_errors import (
    SensorErrorModel,
    SensorNoise,
    SensorParameters,
    draw_sensor_parameters,
    error_model,
    measure,
    sample_kinematics,
)

PROTOCOLS = ("single_axis", "figure8", "tumble")

#: Seconds of one full turn, of the pauses around it and of the re-grasp between axes.
TURN_DURATION_S = 5.0
HOLD_S = 1.0
REGRASP_S = 1.5
FIGURE8_PERIOD_S = 6.0
TUMBLE_PERIOD_S = 10.0
REST_S = 1.0
#: Height (m, world z) at which the hand holds the sensor.
HAND_HEIGHT_M = 1.0

_X, _Y, _Z = np.eye(3)


@dataclass(frozen=True)
class CalibrationMotion:
    """One sensor's raw calibration recording with its truth.

    ``t_s`` (n,) s; ``acc`` (n,3) m/s²; ``gyr`` (n,3) rad/s; ``mag_uT`` (n,3) µT (all sensor
    frame, no drops); ``q_world_from_sensor`` (n,4) true orientation; ``position_m`` (n,3) true
    position (world); ``mag_A`` (3,3), ``mag_b_uT`` (3,) true distortion
    (``mag = A·R_sensor_from_world·field + b + noise``); ``field_world_uT`` (3,); ``gyr_bias_rad_s``
    (n,3); ``axis_turned`` (n,) int: 0/1/2 while turning about sensor x/y/z, −1 otherwise;
    ``parameters`` all true unit parameters.
    """

    sensor_id: str
    protocol: str
    turns: int
    rate_hz: float
    t_s: np.ndarray
    acc: np.ndarray
    gyr: np.ndarray
    mag_uT: np.ndarray
    q_world_from_sensor: np.ndarray
    position_m: np.ndarray
    mag_A: np.ndarray
    mag_b_uT: np.ndarray
    field_world_uT: np.ndarray
    gyr_bias_rad_s: np.ndarray
    axis_turned: np.ndarray
    parameters: SensorParameters


class _Wobble:
    """Small smooth hand tremor: world-frame rotation vector and position offset, sums of sinusoids."""

    def __init__(self, rng: np.random.Generator, angle_deg: float = 2.0, offset_m: float = 0.01) -> None:
        self.frequencies = rng.uniform(0.1, 0.8, size=(2, 3, 3))
        self.phases = rng.uniform(0.0, 2.0 * np.pi, size=(2, 3, 3))
        self.angle = np.deg2rad(angle_deg) / np.sqrt(4.5)
        self.offset = offset_m / np.sqrt(4.5)

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        waves = np.sin(2.0 * np.pi * self.frequencies[None] * t[:, None, None, None] + self.phases[None])
        sums = waves.sum(axis=-1)
        return rot.from_rotvec(self.angle * sums[:, 0]), self.offset * sums[:, 1]


class SingleAxisPath:
    """The single-axis protocol as a function of time: ``path(t)`` gives ``q_world_from_sensor``
    (n,4) and position (n,3) m at times ``t`` (n,) s; :meth:`base` gives the orientation without
    the hand's wobble and the sensor axis being turned (n,) (−1: none); ``duration_s``."""

    def __init__(self, rng: np.random.Generator, turns: int) -> None:
        self.turns = turns
        self.wobble = _Wobble(rng)
        # Start orientations: sensor axis a mapped onto a roughly horizontal direction near east.
        align = (rot.identity(), rot.from_axis_angle(_Z, -np.pi / 2), rot.from_axis_angle(_Y, np.pi / 2))
        self.start = []
        for axis in range(3):
            azimuth = rng.uniform(-np.pi / 4, np.pi / 4)
            tilt = rng.uniform(-np.deg2rad(10.0), np.deg2rad(10.0))
            spin = rng.uniform(-np.pi, np.pi)
            q_world_from_aligned = rot.multiply(
                rot.from_axis_angle(_Z, azimuth), rot.from_axis_angle(_Y, tilt)
            )
            unit = np.eye(3)[axis]
            q = rot.multiply(q_world_from_aligned, rot.multiply(align[axis], rot.from_axis_angle(unit, spin)))
            self.start.append(q)
        offset = rng.normal(size=3)
        self.lever_m = 0.03 * offset / np.linalg.norm(offset)
        # Timeline: REST, then per axis [regrasp (not for x), HOLD, turn, HOLD], REST.
        segments = []
        t = REST_S
        for axis in range(3):
            if axis > 0:
                segments.append(("regrasp", axis, t, t + REGRASP_S))
                t += REGRASP_S
            t += HOLD_S
            turn = TURN_DURATION_S * turns
            segments.append(("turn", axis, t, t + turn))
            t += turn + HOLD_S
        self.segments = segments
        self.duration_s = t + REST_S

    def base(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = np.broadcast_to(self.start[0], t.shape + (4,)).copy()
        axis_turned = np.full(t.shape, -1, dtype=np.int64)
        for kind, axis, t0, t1 in self.segments:
            after = t >= t0
            progress = minimum_jerk((t[after] - t0) / (t1 - t0))
            if kind == "regrasp":
                q[after] = rot.slerp(self.start[axis - 1], self.start[axis], progress)
            else:
                angle = 2.0 * np.pi * self.turns * progress
                q[after] = rot.multiply(self.start[axis], rot.from_axis_angle(np.eye(3)[axis], angle))
                turning = after & (t < t1)
                axis_turned[turning] = axis
        return q, axis_turned

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q_base, _ = self.base(t)
        q_wobble, p_wobble = self.wobble(t)
        q = rot.multiply(q_wobble, q_base)
        position = np.array([0.0, 0.0, HAND_HEIGHT_M]) + p_wobble + rot.rotate(q, self.lever_m)
        return q, position


class Figure8Path:
    """The figure-8 protocol as a function of time (same interface as :class:`SingleAxisPath`)."""

    def __init__(self, rng: np.random.Generator, turns: int) -> None:
        self.turns = turns
        self.wobble = _Wobble(rng, angle_deg=1.5)
        self.q_base = rot.from_rotvec(rng.normal(size=3) * 0.5)
        self.duration_s = 2 * REST_S + turns * FIGURE8_PERIOD_S

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        moving = np.clip(t - REST_S, 0.0, self.turns * FIGURE8_PERIOD_S)
        phase = 2.0 * np.pi * moving / FIGURE8_PERIOD_S
        total = self.turns * FIGURE8_PERIOD_S
        envelope = minimum_jerk(moving / 1.5) * minimum_jerk((total - moving) / 1.5)
        yaw = np.deg2rad(90.0) * np.sin(phase) * envelope
        pitch = np.deg2rad(50.0) * np.sin(2.0 * phase) * envelope
        roll = np.deg2rad(60.0) * np.sin(phase + np.pi / 3.0) * envelope
        q_gesture = rot.multiply(
            rot.multiply(rot.from_axis_angle(_Z, yaw), rot.from_axis_angle(_Y, pitch)),
            rot.from_axis_angle(_X, roll),
        )
        q_wobble, p_wobble = self.wobble(t)
        q = rot.multiply(q_wobble, rot.multiply(q_gesture, self.q_base))
        path = np.stack(
            (0.25 * np.sin(phase) * envelope, np.zeros_like(t), 0.12 * np.sin(2.0 * phase) * envelope), axis=-1
        )
        return q, np.array([0.0, 0.0, HAND_HEIGHT_M]) + path + p_wobble


class TumblePath:
    """Random smooth tumbling as a function of time (same interface as :class:`SingleAxisPath`)."""

    def __init__(self, rng: np.random.Generator, turns: int) -> None:
        self.turns = turns
        self.frequencies = rng.uniform(0.05, 0.25, size=(3, 4))
        self.phases = rng.uniform(0.0, 2.0 * np.pi, size=(3, 4))
        self.amplitudes = rng.uniform(0.6, 1.2, size=(3, 4))
        self.position_frequencies = rng.uniform(0.1, 0.5, size=(3, 2))
        self.q_base = rot.from_rotvec(rng.normal(size=3))
        self.duration_s = 2 * REST_S + turns * TUMBLE_PERIOD_S

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        moving = np.clip(t - REST_S, 0.0, self.turns * TUMBLE_PERIOD_S)
        total = self.turns * TUMBLE_PERIOD_S
        envelope = minimum_jerk(moving / 2.0) * minimum_jerk((total - moving) / 2.0)
        waves = self.amplitudes * (
            np.sin(2.0 * np.pi * self.frequencies * moving[:, None, None] + self.phases) - np.sin(self.phases)
        )
        angles = waves.sum(axis=-1) * envelope[:, None]
        q_motion = rot.multiply(
            rot.multiply(rot.from_axis_angle(_Z, angles[:, 0]), rot.from_axis_angle(_Y, angles[:, 1])),
            rot.from_axis_angle(_X, angles[:, 2]),
        )
        q = rot.multiply(q_motion, self.q_base)
        offsets = 0.05 * np.sin(2.0 * np.pi * self.position_frequencies[:, 0] * moving[:, None]) * envelope[:, None]
        return q, np.array([0.0, 0.0, HAND_HEIGHT_M]) + offsets


#: Protocol name → path class, each built as ``Path(rng, turns)``.
HAND_PATHS = {"single_axis": SingleAxisPath, "figure8": Figure8Path, "tumble": TumblePath}


def calibration_motion(
    protocol: str = "single_axis",
    turns: int = 1,
    *,
    rate_hz: float = 100.0,
    seed: int = 0,
    errors: str | SensorErrorModel = "default",
    earth_field: EarthField = EarthField(),
    sensor_id: str = "S01",
    mag_A: np.ndarray | None = None,
    mag_b_uT: np.ndarray | None = None,
) -> CalibrationMotion:
    """Simulate one hand-held sensor doing a magnetometer-calibration motion.

    ``protocol`` one of :data:`PROTOCOLS`; ``turns`` (1–5) full turns per axis (single_axis),
    figure-8 gestures (figure8) or 10-s tumbling periods (tumble); ``errors`` an error-model
    preset name (``"mpu9250"`` for AK8963-like noise and quantisation) or a
    :class:`SensorErrorModel`; ``mag_A`` (3,3)/``mag_b_uT`` (3,) override the drawn distortion.
    Deterministic for a given ``seed``.
    """
    if protocol not in PROTOCOLS:
        raise ValueError(f"unknown calibration protocol {protocol!r}; use one of {', '.join(PROTOCOLS)}")
    if int(turns) != turns or not 1 <= turns <= 5:
        raise ValueError(f"turns must be an integer from 1 to 5, got {turns}")
    if not 10.0 <= rate_hz <= 2000.0:
        raise ValueError(f"sample rate {rate_hz} Hz is outside 10..2000 Hz")
    turns = int(turns)
    model = error_model(errors)
    rng = np.random.default_rng([int(seed) & 0xFFFFFFFF, 303, PROTOCOLS.index(protocol)])
    path = HAND_PATHS[protocol](rng, turns)
    params = draw_sensor_parameters(seed, 0, sensor_id, model)
    if mag_A is not None or mag_b_uT is not None:
        params = params.with_magnetometer(
            params.mag_A if mag_A is None else mag_A, params.mag_b_uT if mag_b_uT is None else mag_b_uT
        )
    dt = 1.0 / rate_hz
    n = int(round(path.duration_s * rate_hz))
    t = np.arange(n) * dt
    q, q_prev, position, acc_world = sample_kinematics(path, t, dt)
    field = earth_field.field_world_uT()
    noise = SensorNoise(seed, params, model, rate_hz).block(0, n)
    m = measure(params, model, noise, t, q, q_prev, acc_world, field, dt)
    if protocol == "single_axis":
        _, axis_turned = path.base(t)
    else:
        axis_turned = np.full(n, -1, dtype=np.int64)
    return CalibrationMotion(
        sensor_id=sensor_id, protocol=protocol, turns=turns, rate_hz=float(rate_hz), t_s=t,
        acc=m.acc, gyr=m.gyr, mag_uT=m.mag_uT, q_world_from_sensor=q, position_m=position,
        mag_A=params.mag_A, mag_b_uT=params.mag_b_uT, field_world_uT=field,
        gyr_bias_rad_s=m.gyr_bias, axis_turned=axis_turned, parameters=params,
    )
