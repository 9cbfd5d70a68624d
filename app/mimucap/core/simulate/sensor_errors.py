"""Sensor error model of the simulator: what a magnetic-inertial unit reports for a true motion.

Frames: ``world`` is ENU (x east, y north, z up); ``sensor`` the device axes. Quaternions are
Hamilton, scalar first, ``q_world_from_sensor`` maps sensor coordinates into the world.
Units: acc m/s² (specific force), gyr rad/s, mag µT, time s.

Measurement equations for sample ``k`` at true time ``t_k = k / rate_hz``:

* gyroscope ``gyr_k = S_g · ω_k + bias_k + noise``, where ``ω_k`` is the *mean* angular rate
  over the sample interval, ``ω_k = log(q_{k-1}⁻¹ ⊗ q_k) / dt`` in the sensor frame (so that
  ``q_k = q_{k-1} ⊗ exp(ω_k·dt)`` holds exactly), ``S_g`` a diagonal scale matrix and
  ``bias_k`` a constant initial bias plus a random walk;
* accelerometer ``acc_k = S_a · R_sensor_from_world (a_world + g·e_z) + b_a + noise`` with the
  linear acceleration ``a_world`` of the sensor point;
* magnetometer ``mag_k = A · R_sensor_from_world · m_world + b + noise``, optionally quantised,
  with the hard-iron offset ``b`` (µT) and the symmetric soft-iron matrix ``A``;
* device clock ``device_time = (1 + drift) · t + offset``;
* packet drops (independent, probability ``drop_probability`` per sample);
* optional on-board orientation ``q_world_from_sensor`` like a BNO055's fusion output, with a
  slowly varying error of about ``onboard_error_deg`` and 2⁻¹⁴ quantisation.

Randomness is deterministic: per-sample noise of sensor ``index`` comes from fixed chunks of
:data:`NOISE_CHUNK` samples, each drawn from its own generator seeded with
``(seed, index, chunk)``; any partition of the sample range into blocks therefore gives
bit-identical values, which the streaming simulator relies on.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from mimucap.core import rotation as rot

#: Gravity magnitude (m/s²) used by the simulator: a sensor at rest reads this along world up.
GRAVITY_MPS2 = 9.81
#: Samples per noise chunk (the unit of deterministic random generation).
NOISE_CHUNK = 1024
#: Columns of the per-chunk normal draws.
_GYR_NOISE, _GYR_WALK, _ACC_NOISE, _MAG_NOISE = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12)
_N_NORMAL = 12
_STREAM_NOISE = 101
_STREAM_PARAMETERS = 202
_DEG = np.pi / 180.0


@dataclass(frozen=True)
class SensorErrorModel:
    """Error magnitudes of one kind of sensor unit (defaults: a BNO055/MPU-class MEMS unit at 100 Hz).

    Gyroscope: ``gyr_bias_dps`` range (min, max) of the initial bias vector's norm (°/s),
    ``gyr_bias_walk_dps_per_sqrt_s`` bias random walk, ``gyr_noise_dps`` white noise rms per
    sample and axis, ``gyr_scale_error`` std of the per-axis scale factor error (fraction).
    Accelerometer: ``acc_noise_mps2`` rms per sample and axis, ``acc_bias_mps2`` std of the
    constant bias per axis, ``acc_scale_error`` std of the scale error.
    Magnetometer: ``mag_noise_uT`` rms per sample and axis, ``mag_lsb_uT`` quantisation step
    (0: none), ``mag_hard_iron_uT`` maximum |offset| per axis, ``mag_soft_iron_scale`` maximum
    |A_ii − 1|, ``mag_soft_iron_cross`` maximum |A_ij| (A symmetric).
    Clock: ``clock_offset_s`` maximum |offset|, ``clock_drift_ppm`` std of the rate error.
    Link: ``drop_probability`` per sample. On-board fusion: ``onboard_orientation`` whether
    the unit sends ``q_world_from_sensor``, ``onboard_error_deg`` rms of its slowly varying error.
    """

    gyr_bias_dps: tuple[float, float] = (0.5, 2.0)
    gyr_bias_walk_dps_per_sqrt_s: float = 0.01
    gyr_noise_dps: float = 0.1
    gyr_scale_error: float = 0.01
    acc_noise_mps2: float = 0.02
    acc_bias_mps2: float = 0.05
    acc_scale_error: float = 0.005
    mag_noise_uT: float = 0.3
    mag_lsb_uT: float = 0.0
    mag_hard_iron_uT: float = 40.0
    mag_soft_iron_scale: float = 0.1
    mag_soft_iron_cross: float = 0.05
    clock_offset_s: float = 5.0
    clock_drift_ppm: float = 50.0
    drop_probability: float = 0.0
    onboard_orientation: bool = False
    onboard_error_deg: float = 1.0

    def __post_init__(self) -> None:
        low, high = self.gyr_bias_dps
        if not 0.0 <= low <= high:
            raise ValueError(f"gyr_bias_dps must be a range (min, max) with 0 <= min <= max, got {self.gyr_bias_dps}")
        for name in (
            "gyr_bias_walk_dps_per_sqrt_s", "gyr_noise_dps", "gyr_scale_error", "acc_noise_mps2",
            "acc_bias_mps2", "acc_scale_error", "mag_noise_uT", "mag_lsb_uT", "mag_hard_iron_uT",
            "mag_soft_iron_scale", "mag_soft_iron_cross", "clock_offset_s", "clock_drift_ppm",
            "onboard_error_deg",
        ):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"sensor error setting {name} must be finite and >= 0, got {value}")
        if self.mag_soft_iron_scale >= 0.5 or self.mag_soft_iron_cross >= 0.2:
            raise ValueError("soft-iron settings too large (scale < 0.5, cross < 0.2 keep A positive definite)")
        if not 0.0 <= self.drop_probability < 0.9:
            raise ValueError(f"drop_probability must be in [0, 0.9), got {self.drop_probability}")


#: A perfect unit: no bias, noise, scale error, distortion, clock error or drops.
IDEAL_SENSOR = SensorErrorModel(
    gyr_bias_dps=(0.0, 0.0), gyr_bias_walk_dps_per_sqrt_s=0.0, gyr_noise_dps=0.0, gyr_scale_error=0.0,
    acc_noise_mps2=0.0, acc_bias_mps2=0.0, acc_scale_error=0.0, mag_noise_uT=0.0, mag_lsb_uT=0.0,
    mag_hard_iron_uT=0.0, mag_soft_iron_scale=0.0, mag_soft_iron_cross=0.0, clock_offset_s=0.0,
    clock_drift_ppm=0.0, drop_probability=0.0, onboard_error_deg=0.0,
)
#: MPU-9250 (AK8963 magnetometer): ~0.6 µT rms noise, 0.15 µT/LSB in 16-bit mode.
MPU9250_SENSOR = SensorErrorModel(mag_noise_uT=0.6, mag_lsb_uT=0.15, gyr_noise_dps=0.1, acc_noise_mps2=0.03)
#: BNO055 with its on-board fusion output enabled (raw channels as the default model).
BNO055_SENSOR = SensorErrorModel(onboard_orientation=True, mag_noise_uT=0.4, mag_lsb_uT=1.0 / 16.0)

ERROR_PRESETS: dict[str, SensorErrorModel] = {
    "default": SensorErrorModel(),
    "ideal": IDEAL_SENSOR,
    "mpu9250": MPU9250_SENSOR,
    "bno055": BNO055_SENSOR,
}


def error_model(name_or_model: str | SensorErrorModel) -> SensorErrorModel:
    """Resolve a preset name (``default``, ``ideal``, ``mpu9250``, ``bno055``) or pass a model through."""
    if isinstance(name_or_model, SensorErrorModel):
        return name_or_model
    try:
        return ERROR_PRESETS[name_or_model]
    except KeyError:
        raise ValueError(
            f"unknown sensor error preset {name_or_model!r}; use one of {', '.join(ERROR_PRESETS)}"
        ) from None


@dataclass(frozen=True)
class SensorParameters:
    """The fixed (true) error parameters of one simulated unit.

    ``gyr_bias0_rad_s`` (3,) initial bias; ``gyr_scale`` (3,3) and ``acc_scale`` (3,3) scale
    matrices; ``acc_bias_mps2`` (3,); ``mag_A`` (3,3) symmetric soft iron; ``mag_b_uT`` (3,)
    hard iron; clock ``offset``/``drift``; ``onboard_*`` the frequencies (Hz, (3,3)), phases
    (rad, (3,3)) and amplitude (rad) of the on-board orientation error.
    """

    sensor_id: str
    index: int
    gyr_bias0_rad_s: np.ndarray
    gyr_scale: np.ndarray
    acc_bias_mps2: np.ndarray
    acc_scale: np.ndarray
    mag_A: np.ndarray
    mag_b_uT: np.ndarray
    clock_offset_s: float
    clock_drift: float
    onboard_frequency_hz: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    onboard_phase_rad: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    onboard_amplitude_rad: float = 0.0

    def with_magnetometer(self, mag_A: np.ndarray, mag_b_uT: np.ndarray) -> SensorParameters:
        """A copy with a given soft-iron matrix (3,3) and hard-iron offset (3,) µT."""
        return replace(self, mag_A=np.asarray(mag_A, float), mag_b_uT=np.asarray(mag_b_uT, float))


def draw_sensor_parameters(seed: int, index: int, sensor_id: str, errors: SensorErrorModel) -> SensorParameters:
    """Draw the true parameters of unit ``index`` (deterministic in ``seed`` and ``index``)."""
    rng = np.random.default_rng([int(seed) & 0xFFFFFFFF, int(index), _STREAM_PARAMETERS])
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    low, high = errors.gyr_bias_dps
    bias0 = direction * rng.uniform(low, high) * _DEG
    gyr_scale = np.diag(1.0 + errors.gyr_scale_error * rng.normal(size=3))
    acc_bias = errors.acc_bias_mps2 * rng.normal(size=3)
    acc_scale = np.diag(1.0 + errors.acc_scale_error * rng.normal(size=3))
    a = np.diag(1.0 + rng.uniform(-1.0, 1.0, size=3) * errors.mag_soft_iron_scale)
    cross = rng.uniform(-1.0, 1.0, size=3) * errors.mag_soft_iron_cross
    a[0, 1] = a[1, 0] = cross[0]
    a[0, 2] = a[2, 0] = cross[1]
    a[1, 2] = a[2, 1] = cross[2]
    b = rng.uniform(-1.0, 1.0, size=3) * errors.mag_hard_iron_uT
    offset = rng.uniform(-1.0, 1.0) * errors.clock_offset_s
    drift = rng.normal() * errors.clock_drift_ppm * 1e-6
    frequencies = rng.uniform(0.005, 0.05, size=(3, 3))
    phases = rng.uniform(0.0, 2.0 * np.pi, size=(3, 3))
    # Three sinusoids per axis with amplitude a give an rms of a·sqrt(3/2) per axis, a·sqrt(9/2) total.
    amplitude = errors.onboard_error_deg * _DEG / np.sqrt(4.5)
    return SensorParameters(
        sensor_id=sensor_id, index=int(index), gyr_bias0_rad_s=bias0, gyr_scale=gyr_scale,
        acc_bias_mps2=acc_bias, acc_scale=acc_scale, mag_A=a, mag_b_uT=b, clock_offset_s=float(offset),
        clock_drift=float(drift), onboard_frequency_hz=frequencies, onboard_phase_rad=phases,
        onboard_amplitude_rad=float(amplitude),
    )


@dataclass(frozen=True)
class NoiseBlock:
    """Per-sample random parts for samples ``k0 .. k0+n-1`` of one sensor.

    ``gyr_noise`` (n,3) rad/s; ``gyr_bias`` (n,3) rad/s (initial bias plus random walk);
    ``acc_noise`` (n,3) m/s²; ``mag_noise`` (n,3) µT; ``keep`` (n,) bool (False: dropped).
    """

    gyr_noise: np.ndarray
    gyr_bias: np.ndarray
    acc_noise: np.ndarray
    mag_noise: np.ndarray
    keep: np.ndarray


class SensorNoise:
    """Deterministic per-sample noise of one sensor, identical for any partition into blocks.

    State: the random-walk value at the start of every chunk generated so far (chunks must be
    reached in order the first time; later calls may revisit any earlier chunk).
    """

    def __init__(self, seed: int, params: SensorParameters, errors: SensorErrorModel, rate_hz: float) -> None:
        self._seed = int(seed) & 0xFFFFFFFF
        self._params = params
        self._errors = errors
        dt = 1.0 / rate_hz
        self._scales = np.concatenate(
            (
                np.full(3, errors.gyr_noise_dps * _DEG),
                np.full(3, errors.gyr_bias_walk_dps_per_sqrt_s * _DEG * np.sqrt(dt)),
                np.full(3, errors.acc_noise_mps2),
                np.full(3, errors.mag_noise_uT),
            )
        )
        self._walk_start: list[np.ndarray] = [np.zeros(3)]
        self._cache: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def _chunk(self, chunk: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        cached = self._cache.get(chunk)
        if cached is not None:
            return cached
        while len(self._walk_start) <= chunk:
            previous = len(self._walk_start) - 1
            _, _, walk = self._chunk(previous)
            self._walk_start.append(walk[-1].copy())
        rng = np.random.default_rng([self._seed, self._params.index, _STREAM_NOISE, chunk])
        normal = rng.standard_normal((NOISE_CHUNK, _N_NORMAL)) * self._scales
        uniform = rng.random(NOISE_CHUNK)
        walk = self._walk_start[chunk] + np.cumsum(normal[:, _GYR_WALK], axis=0)
        if len(self._cache) >= 4:
            self._cache.pop(min(self._cache))
        self._cache[chunk] = (normal, uniform, walk)
        return normal, uniform, walk

    def block(self, k0: int, n: int) -> NoiseBlock:
        """Noise for samples ``k0 .. k0+n-1`` (``k0 >= 0``)."""
        if k0 < 0 or n < 0:
            raise ValueError(f"noise block must start at a sample index >= 0, got {k0} (+{n})")
        parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        k = k0
        end = k0 + n
        while k < end:
            chunk, offset = divmod(k, NOISE_CHUNK)
            stop = min(NOISE_CHUNK, offset + end - k)
            normal, uniform, walk = self._chunk(chunk)
            parts.append((normal[offset:stop], uniform[offset:stop], walk[offset:stop]))
            k += stop - offset
        if parts:
            normal = np.concatenate([p[0] for p in parts])
            uniform = np.concatenate([p[1] for p in parts])
            walk = np.concatenate([p[2] for p in parts])
        else:
            normal, uniform, walk = np.zeros((0, _N_NORMAL)), np.zeros(0), np.zeros((0, 3))
        return NoiseBlock(
            gyr_noise=normal[:, _GYR_NOISE],
            gyr_bias=self._params.gyr_bias0_rad_s + walk,
            acc_noise=normal[:, _ACC_NOISE],
            mag_noise=normal[:, _MAG_NOISE],
            keep=uniform >= self._errors.drop_probability,
        )


@dataclass(frozen=True)
class Measurements:
    """What one unit reports for ``n`` samples (before dropping): ``acc`` (n,3) m/s², ``gyr``
    (n,3) rad/s, ``mag_uT`` (n,3) µT, ``q_world_from_sensor`` (n,4) on-board orientation or
    ``None``, ``device_time_s`` (n,), ``keep`` (n,) bool, ``gyr_bias`` (n,3) rad/s (truth)."""

    acc: np.ndarray
    gyr: np.ndarray
    mag_uT: np.ndarray
    q_world_from_sensor: np.ndarray | None
    device_time_s: np.ndarray
    keep: np.ndarray
    gyr_bias: np.ndarray


def true_angular_rate(q_prev: np.ndarray, q_now: np.ndarray, dt: float) -> np.ndarray:
    """Mean angular rate (..., 3) rad/s in the sensor frame over one interval:
    ``log(q_prev⁻¹ ⊗ q_now) / dt`` for ``q_world_from_sensor`` at the interval's ends."""
    return rot.to_rotvec(rot.multiply(rot.conjugate(q_prev), q_now)) / dt


def stack_parameters(parameters: list[SensorParameters]) -> SensorParameters:
    """Parameters of several units stacked along a leading sensor axis (S,...), for
    :func:`measure` on arrays shaped (n, S, ...); ``sensor_id`` joins the ids with commas."""
    if not parameters:
        raise ValueError("stack_parameters needs at least one sensor")
    stacked = {
        name: np.stack([np.asarray(getattr(p, name), dtype=np.float64) for p in parameters])
        for name in ("gyr_bias0_rad_s", "gyr_scale", "acc_bias_mps2", "acc_scale", "mag_A", "mag_b_uT",
                     "clock_offset_s", "clock_drift", "onboard_frequency_hz", "onboard_phase_rad",
                     "onboard_amplitude_rad")
    }
    return SensorParameters(sensor_id=",".join(p.sensor_id for p in parameters), index=-1, **stacked)


def stack_noise(blocks: list[NoiseBlock]) -> NoiseBlock:
    """Noise blocks of several units stacked along axis 1: fields (n, S, ...)."""
    return NoiseBlock(**{name: np.stack([getattr(b, name) for b in blocks], axis=1)
                         for name in ("gyr_noise", "gyr_bias", "acc_noise", "mag_noise", "keep")})


def _apply(matrix: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """``matrix @ vector`` over leading axes, summed in a fixed order (no BLAS: results do not
    depend on the array length, which block-wise simulation relies on)."""
    m = np.asarray(matrix)
    return (m[..., 0] * vectors[..., 0:1] + m[..., 1] * vectors[..., 1:2]) + m[..., 2] * vectors[..., 2:3]


def measure(
    params: SensorParameters,
    errors: SensorErrorModel,
    noise: NoiseBlock,
    t_s: np.ndarray,
    q_world_from_sensor: np.ndarray,
    q_world_from_sensor_prev: np.ndarray,
    acc_world_mps2: np.ndarray,
    field_world_uT: np.ndarray,
    dt: float,
) -> Measurements:
    """Apply the error model to true kinematics of ``n`` samples.

    ``t_s`` (n,) true times; ``q_world_from_sensor`` (n,4) at ``t_s`` and ``..._prev`` (n,4)
    one sample earlier; ``acc_world_mps2`` (n,3) linear acceleration of the sensor point
    (without gravity) averaged over the interval (:func:`mean_acceleration`); ``field_world_uT`` (n,3) or (3,) field at the sensor; ``dt`` sample
    interval (s). With parameters from :func:`stack_parameters` and noise from
    :func:`stack_noise` every per-sample array has shape (n, S, ...) instead.
    """
    q_sensor_from_world = rot.conjugate(q_world_from_sensor)
    omega = true_angular_rate(q_world_from_sensor_prev, q_world_from_sensor, dt)
    gyr = _apply(params.gyr_scale, omega) + noise.gyr_bias + noise.gyr_noise
    specific_force = np.asarray(acc_world_mps2, dtype=np.float64) + np.array([0.0, 0.0, GRAVITY_MPS2])
    # The interval's mean specific force, seen from the sensor at mid-interval.
    q_sensor_from_world_mid = rot.conjugate(rot.slerp(q_world_from_sensor_prev, q_world_from_sensor, 0.5))
    acc = (_apply(params.acc_scale, rot.rotate(q_sensor_from_world_mid, specific_force)) + params.acc_bias_mps2
           + noise.acc_noise)
    mag_true = rot.rotate(q_sensor_from_world, np.broadcast_to(field_world_uT, specific_force.shape))
    mag = _apply(params.mag_A, mag_true) + params.mag_b_uT + noise.mag_noise
    if errors.mag_lsb_uT > 0.0:
        mag = np.round(mag / errors.mag_lsb_uT) * errors.mag_lsb_uT
    onboard = None
    if errors.onboard_orientation:
        onboard = onboard_orientation(params, t_s, q_world_from_sensor)
    t = np.asarray(t_s, dtype=np.float64)
    t = t.reshape(t.shape + (1,) * np.ndim(params.clock_drift))
    device_time = (1.0 + params.clock_drift) * t + params.clock_offset_s
    return Measurements(acc=acc, gyr=gyr, mag_uT=mag, q_world_from_sensor=onboard,
                        device_time_s=device_time, keep=noise.keep, gyr_bias=noise.gyr_bias)


def onboard_orientation(params: SensorParameters, t_s: np.ndarray, q_world_from_sensor: np.ndarray) -> np.ndarray:
    """On-board fusion output (n,4) (or (n,S,4) for stacked parameters):
    ``q_err(t) ⊗ q_world_from_sensor`` with a slowly varying world-frame error rotation,
    quantised to 2⁻¹⁴ like the BNO055 and renormalised."""
    frequency = np.asarray(params.onboard_frequency_hz)
    t = np.asarray(t_s, dtype=np.float64)
    t = t.reshape(t.shape + (1,) * frequency.ndim)
    waves = np.sin(2.0 * np.pi * frequency * t + params.onboard_phase_rad)
    error_rotvec = np.asarray(params.onboard_amplitude_rad)[..., None] * waves.sum(axis=-1)
    q = rot.multiply(rot.from_rotvec(error_rotvec), q_world_from_sensor)
    q = np.round(rot.canonical(q) * 16384.0) / 16384.0
    return rot.normalize(q)


#: Step (s) of the backward differences that give the sensor point's velocity at the ends of
#: a sample interval.
ACC_DIFF_STEP_S = 1e-4


def mean_acceleration(p_now: np.ndarray, p_now_before: np.ndarray, p_prev: np.ndarray, p_prev_before: np.ndarray,
                      dt: float) -> np.ndarray:
    """The mean linear acceleration over each sample interval (m/s²): the change of velocity
    from the interval's start to its end over ``dt``, the velocities from positions at both
    ends (``p_now``, ``p_prev``) and :data:`ACC_DIFF_STEP_S` before them (``…_before``). An
    accelerometer's decimation filter averages what happens between two samples, so an impact
    shorter than the interval is neither missed nor aliased; the gyroscope's sample is likewise
    the mean rate over the interval."""
    h = ACC_DIFF_STEP_S
    return ((p_now - p_now_before) - (p_prev - p_prev_before)) / (h * dt)


def sample_kinematics(pose_fn, t_s: np.ndarray, dt: float):
    """Evaluate a pose function at the times the error model needs, in one vectorised call.

    ``pose_fn(t)`` maps times (m,) to ``(q_world_from_sensor (m, ..., 4), position_m (m, ..., 3))``.
    Returns ``(q (n, ..., 4), q_prev (n, ..., 4), position_m (n, ..., 3), acc_world_mps2 (n, ..., 3))``
    at ``t_s`` (n,), with ``q_prev`` one interval ``dt`` earlier and the linear acceleration
    averaged over that interval (:func:`mean_acceleration`).
    """
    t = np.asarray(t_s, dtype=np.float64)
    n = t.shape[0]
    h = ACC_DIFF_STEP_S
    times = np.concatenate((t, t - dt, t - h, t - dt - h))
    q, p = pose_fn(times)
    q_now, q_prev = q[:n], q[n:2 * n]
    acc = mean_acceleration(p[:n], p[2 * n:3 * n], p[n:2 * n], p[3 * n:], dt)
    return q_now, q_prev, p[:n], acc
