"""Error-state EKF for orientation: an online object and a batch function, S sensors at once.

Inputs per sensor (sensor frame): ``gyr_rad_s`` (rad/s), ``acc_m_s2`` (specific force, m/s²;
about +9.81 along world up at rest), ``mag_uT`` (calibrated field, µT), time stamps ``t_s``
(s, variable intervals and gaps allowed). Output: ``q_world_from_sensor`` (scalar-first, world =
ENU with magnetic north along +y), the gyro bias estimate (rad/s, sensor frame) and per-sample
flags (:mod:`mimucap.core.fusion.state`).

Shapes: one sensor ``gyr (N, 3)``, ``t_s (N,)``; S sensors ``gyr (S, N, 3)`` with ``t_s (N,)``
shared or ``(S, N)``. ``acc`` and ``mag`` have the shape of ``gyr`` or are ``None`` (channel
absent). NaN or out-of-range samples are skipped and counted, never fed to the state.

:class:`OrientationEKF` keeps the state between calls: ``update`` takes one sample,
``update_batch`` a block, and feeding a recording in blocks gives exactly the result of one
call (:func:`fuse`). The loop over the samples is the compiled kernel
:func:`~mimucap.core.fusion.kernels.ekf_sensors`, from the module compiled ahead of time or
through numba's JIT (:mod:`mimucap.core.fusion.kernel_selection`); numba is imported only in the latter case,
at the first call.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mimucap.core.fusion.algorithms import ALGORITHMS
from mimucap.core.fusion.kernel_selection import fusion_kernels
from mimucap.core.fusion.params import DEFAULT_FUSION_PARAMS, FusionParams, pack_params
from mimucap.core.fusion.state import (
    AUX_COUNT, AX_HI_ON, AX_INIT, AX_MAG_CAND_T, AX_MAG_REF_OK, FusionState, decode_flags,
)

#: Standard deviation (rad) of a heading about which nothing is known: that of an angle
#: uniformly distributed over the circle, π/√3 (104°).
UNKNOWN_HEADING_STD_RAD = math.pi / math.sqrt(3.0)

@dataclass(frozen=True)
class FusionResult:
    """Output of a block or batch: arrays with the sensor axis first when S sensors were given.

    ``q_world_from_sensor`` (N, 4) or (S, N, 4) (NaN rows before the first valid
    accelerometer sample; without an accelerometer channel the filter starts at the identity),
    ``bias_rad_s`` (N, 3) / (S, N, 3), ``flags`` (N,) / (S, N) uint8 (bits in
    :mod:`mimucap.core.fusion.state`; :meth:`flag_masks` decodes them) and ``counters`` (one
    dict per sensor, cumulated over everything the filter had seen at the end of the block;
    a :class:`~mimucap.core.fusion.state.SensorCounters` decodes them when read).
    """

    q_world_from_sensor: np.ndarray
    bias_rad_s: np.ndarray
    flags: np.ndarray
    counters: Sequence[dict[str, int]]

    def flag_masks(self) -> dict[str, np.ndarray]:
        """Boolean arrays ``rest``, ``mag_rejected``, ``acc_rejected``, ``skipped``, ..."""
        return decode_flags(self.flags)


def _channel(name: str, values, n_sensors: int, n: int, single: bool) -> np.ndarray:
    array = np.asarray(values, dtype=np.float64)
    if single:
        array = array[None]
    if array.shape != (n_sensors, n, 3):
        expected = (n, 3) if single else (n_sensors, n, 3)
        raise ValueError(f"{name}: expected shape {expected}, got {np.asarray(values).shape}")
    return _kernel_array(array)


def _time_grid(t_s, n_sensors: int, n: int) -> np.ndarray:
    """Sample times (s) as ``(n_sensors, n)``: one shared ``(n,)`` row or one row per sensor."""
    t = np.asarray(t_s, dtype=np.float64)
    if t.shape == (n,):
        if n_sensors == 1:
            return t.reshape(1, n)  # a view: no copy for the kernel when ``t_s`` is contiguous
        return np.broadcast_to(t, (n_sensors, n))
    if t.shape != (n_sensors, n):
        raise ValueError(f"t_s: expected shape ({n},) or ({n_sensors}, {n}), got {t.shape}")
    return t


def shaped_inputs(t_s, gyr_rad_s, acc_m_s2, mag_uT, n_sensors: int | None = None):
    """The inputs as the kernels take them: ``(single, t (S, N), gyr (S, N, 3), acc, mag)``
    with ``acc``/``mag`` ``(S, N, 3)`` or None. ``single`` says the caller passed one sensor's
    ``(N, 3)`` arrays; ``n_sensors`` (default: from ``gyr``) is the count the arrays must have.
    Bad shapes raise ``ValueError`` naming the input."""
    gyr = np.asarray(gyr_rad_s, dtype=np.float64)
    if gyr.ndim not in (2, 3):
        raise ValueError(f"gyr: expected shape (N, 3) or (S, N, 3), got {gyr.shape}")
    single = gyr.ndim == 2
    if n_sensors is None:
        n_sensors = 1 if single else gyr.shape[0]
    elif single and n_sensors != 1:
        raise ValueError(f"this filter has {n_sensors} sensors: gyr must be (S, N, 3)")
    n = gyr.shape[-2]
    return (single, _time_grid(t_s, n_sensors, n), _channel("gyr", gyr, n_sensors, n, single),
            None if acc_m_s2 is None else _channel("acc", acc_m_s2, n_sensors, n, single),
            None if mag_uT is None else _channel("mag", mag_uT, n_sensors, n, single))


def _kernel_array(array: np.ndarray) -> np.ndarray:
    """C-contiguous, writeable float64 (one compiled kernel type, whatever the caller passed:
    read-only, broadcast or strided arrays would each need their own compilation)."""
    flags = array.flags
    if array.dtype == np.float64 and flags.c_contiguous and flags.writeable and flags.aligned:
        return array  # what np.require returns for such an array, without its overhead
    return np.require(array, dtype=np.float64, requirements=("C", "W", "A"))


@functools.lru_cache(maxsize=64)
def _unused_outputs(n_sensors: int) -> tuple[np.ndarray, ...]:
    """Zero-size arrays for the kernel's absent channels and storage when not storing
    (``(S, 0, 3)`` absent channel, then ``st_q``, ``st_b``, ``st_pp``, ``st_pu``, ``st_a``).
    Shared between calls: having no element, they are never written."""
    absent = np.zeros((n_sensors, 0, 3))
    pp = np.zeros((n_sensors, 0, 6, 6))
    return (absent, np.zeros((n_sensors, 0, 4)), np.zeros((n_sensors, 0, 3)), pp, pp,
            np.zeros((n_sensors, 0, 3, 3)))


def _run_filter(packed: np.ndarray, state: FusionState, t, gyr, acc, mag,
                store: tuple | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the kernel over shaped inputs (:func:`shaped_inputs`) from ``state`` (updated in
    place) with settings ``packed``; returns ``out_q`` (S, N, 4), ``out_b`` (S, N, 3) and
    ``out_flags`` (S, N). ``store``: the ``st_*`` arrays the smoother fills, or None."""
    s_count, n = gyr.shape[0], gyr.shape[1]
    out_q = np.empty((s_count, n, 4))
    out_b = np.empty((s_count, n, 3))
    out_f = np.zeros((s_count, n), dtype=np.uint8)
    absent, st_q, st_b, st_pp, st_pu, st_a = _unused_outputs(s_count)
    if store is not None:
        st_q, st_b, st_pp, st_pu, st_a = store
    fusion_kernels().ekf_sensors(
        packed, _kernel_array(t), gyr, absent if acc is None else acc, absent if mag is None else mag,
        state.q_world_from_sensor, state.bias_rad_s, state.cov, state.aux, out_q, out_b, out_f,
        store is not None, st_q, st_b, st_pp, st_pu, st_a)
    return out_q, out_b, out_f


class OrientationEKF:
    """Online error-state EKF of ``n_sensors`` sensors.

    ``params`` holds the noise model and disturbance settings; ``algorithm`` is one of
    :data:`ALGORITHMS` (it overrides ``params.propagation``; the gyro-only algorithms align
    from the first samples and then integrate); ``use_mag=False`` ignores the magnetometer
    (heading then only from the gyroscope, starting at an arbitrary value).
    """

    def __init__(self, params: FusionParams = DEFAULT_FUSION_PARAMS, *, n_sensors: int = 1,
                 algorithm: str = "ekf-taylor3", use_mag: bool = True,
                 state: FusionState | None = None) -> None:
        if algorithm not in ALGORITHMS:
            raise ValueError(f"unknown algorithm {algorithm!r}; choose one of {sorted(ALGORITHMS)}")
        if not isinstance(params, FusionParams):
            raise ValueError("params must be a FusionParams")
        propagation, correct = ALGORITHMS[algorithm]
        self.params = params
        self.algorithm = algorithm
        self.use_mag = use_mag
        self._packed = pack_params(
            FusionParams(**{**params.__dict__, "propagation": propagation}),
            use_mag=use_mag, correct=correct)
        self.state = state.copy() if state is not None else FusionState.new(n_sensors)
        #: filters with equal keys run the same equations (see :func:`update_together`)
        self.grouping_key = (algorithm, use_mag, params)

    @property
    def n_sensors(self) -> int:
        return self.state.n_sensors

    def counters(self, sensor: int = 0) -> dict[str, int]:
        return self.state.counters(sensor)

    def smoother_pass(self) -> "OrientationEKF":
        """This filter with the settings of a smoother's forward pass
        (:meth:`~mimucap.core.fusion.params.FusionParams.smoother_pass`) on the *same* state:
        samples fed to the returned filter advance this one, which goes on from where they
        leave it."""
        other = OrientationEKF(self.params.smoother_pass(), algorithm=self.algorithm, use_mag=self.use_mag)
        other.state = self.state
        return other

    def magnetometer_changed(self) -> None:
        """The magnetometer samples fed from now on are corrected differently (a new hard- and
        soft-iron calibration): the heading estimated so far carries no information about the
        heading the corrected field will give, and the gyro bias and tilt may carry the
        imprint of the old field's orientation-dependent heading errors (fed to the bias
        through the heading updates, and from the bias into the tilt).

        Keeps the orientation and bias estimates as they are and gives the error state its
        initial uncertainty again (tilt ``init_tilt_std_rad``, bias ``init_bias_std_rad_s``,
        no correlations), the heading that of an unknown angle
        (:data:`UNKNOWN_HEADING_STD_RAD`: the first corrected samples set it), and forgets the
        learned field reference (norm and dip; the first new sample seeds it) and any hard-iron
        offset learned on top of the old calibration (:mod:`.hard_iron`). Unlike a new
        filter, this neither re-aligns the tilt on one accelerometer sample (wherever the
        sensor is moving at that instant: a calibration is typically applied while the sensor
        is being strapped back on) nor forgets the gyro bias, so the estimate settles within
        seconds instead of tens of seconds. A filter without an orientation yet is left as it
        is (its first samples align it).
        """
        p = self.params
        cov = np.diag([p.init_tilt_std_rad ** 2, p.init_tilt_std_rad ** 2, UNKNOWN_HEADING_STD_RAD ** 2]
                      + [p.init_bias_std_rad_s ** 2] * 3)
        for s in range(self.n_sensors):
            if self.state.aux[s, AX_INIT] <= 0.0:
                continue
            self.state.cov[s] = cov
            self.state.aux[s, AX_MAG_REF_OK] = 0.0
            self.state.aux[s, AX_MAG_CAND_T] = 0.0
            self.state.aux[s, AX_HI_ON:AUX_COUNT] = 0.0  # the offset and its fit come last

    def update_batch(self, t_s, gyr_rad_s, acc_m_s2=None, mag_uT=None, *,
                     _store: tuple | None = None) -> FusionResult:
        """Feed a block of samples (shapes in the module docstring); returns its outputs."""
        s_count = self.n_sensors
        single, t, gyr, acc, mag = shaped_inputs(t_s, gyr_rad_s, acc_m_s2, mag_uT, s_count)
        out_q, out_b, out_f = _run_filter(self._packed, self.state, t, gyr, acc, mag, _store)
        counters = self.state.all_counters()
        if single:
            return FusionResult(out_q[0], out_b[0], out_f[0], counters)
        return FusionResult(out_q, out_b, out_f, counters)

    def update(self, t_s: float, gyr_rad_s, acc_m_s2=None, mag_uT=None) -> np.ndarray:
        """Feed one sample (``gyr (3,)`` or ``(S, 3)``); returns ``q_world_from_sensor``."""
        gyr = np.asarray(gyr_rad_s, dtype=np.float64)
        expand = (lambda v: None if v is None else np.asarray(v, dtype=np.float64)[..., None, :])
        result = self.update_batch(np.array([t_s], dtype=np.float64), gyr[..., None, :],
                                   expand(acc_m_s2), expand(mag_uT))
        return result.q_world_from_sensor[..., 0, :]


def update_together(filters, t_s, gyr_rad_s, acc_m_s2=None, mag_uT=None) -> FusionResult:
    """Feed ``S`` one-sensor filters a block each in one kernel call: exactly what
    ``filters[s].update_batch(t_s[s], gyr_rad_s[s], ...)`` would do for each ``s``, without the
    per-call overhead that dominates at a few samples per block (a live session fuses 17
    sensors 60 times a second).

    ``filters``: :class:`OrientationEKF` s of one sensor each, all with the same
    :attr:`~OrientationEKF.grouping_key` (algorithm, ``use_mag``, parameters); ``t_s`` ``(S, N)``, ``gyr_rad_s``
    ``(S, N, 3)``, ``acc``/``mag`` ``(S, N, 3)`` or ``None``. Returns the outputs with the
    sensor axis first; each filter's state is updated as by its own call."""
    filters = list(filters)
    if not filters:
        raise ValueError("update_together needs at least one filter")
    first = filters[0]
    for ekf in filters:
        if ekf.n_sensors != 1:
            raise ValueError("update_together takes filters of one sensor each")
        if ekf.grouping_key != first.grouping_key:
            raise ValueError("update_together needs filters with the same algorithm, parameters and use_mag")
    _, t, gyr, acc, mag = shaped_inputs(t_s, gyr_rad_s, acc_m_s2, mag_uT, len(filters))
    states = [ekf.state for ekf in filters]
    together = FusionState(*(np.concatenate([getattr(st, name) for st in states])
                             for name in ("q_world_from_sensor", "bias_rad_s", "cov", "aux")))
    out_q, out_b, out_f = _run_filter(first._packed, together, t, gyr, acc, mag)
    for row, st in enumerate(states):
        st.q_world_from_sensor[0] = together.q_world_from_sensor[row]
        st.bias_rad_s[0] = together.bias_rad_s[row]
        st.cov[0] = together.cov[row]
        st.aux[0] = together.aux[row]
    return FusionResult(out_q, out_b, out_f, together.all_counters())


def fuse(t_s, gyr_rad_s, acc_m_s2=None, mag_uT=None, *,
         params: FusionParams = DEFAULT_FUSION_PARAMS, algorithm: str = "ekf-taylor3",
         use_mag: bool = True) -> FusionResult:
    """Batch orientation estimate of a recording with a fresh :class:`OrientationEKF`."""
    gyr = np.asarray(gyr_rad_s)
    n_sensors = 1 if gyr.ndim == 2 else gyr.shape[0]
    ekf = OrientationEKF(params, n_sensors=n_sensors, algorithm=algorithm, use_mag=use_mag)
    return ekf.update_batch(t_s, gyr, acc_m_s2, mag_uT)
