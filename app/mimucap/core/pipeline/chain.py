"""One sensor's chain: magnetometer calibration, the on-board-orientation rule and the orientation
filter, with the reasons its result may be wrong (no I/O, no Qt).

Steps 1 and 2 of the processing path (:mod:`mimucap.core.pipeline`), one object per sensor:

1. **Magnetometer calibration** (Choe, Zhao, Qiu, So, "Study of calibration method of low-cost
   MEMS magnetometer"): ``mag_cal_uT = soft_iron · (mag_raw_uT − offset_uT)``
   (:class:`~mimucap.core.magcal.model.MagCalibration`); a sensor without one keeps its raw field.
   The same calibration's gyroscope correction (scale factors and cross-axis terms estimated from
   its turns, :mod:`mimucap.core.magcal.gyro_scale`) turns the raw rates into ``C @ ω_raw``
   before the filter (the identity when it has none).
2. **Orientation**: a device that fuses on board (BNO055, SlimeVR trackers) sends its own
   ``q_world_from_sensor``, which is taken as it is; any other sensor with a gyroscope goes
   through the error-state Kalman filter of Zhang, Gao, Zhou ("Head attitude sensing algorithm
   based on IMU in VR device", :class:`~mimucap.core.fusion.ekf.OrientationEKF`). This module is
   the only place of the application that makes such a filter.

Like VQF's one object (Laidig, Seel, "VQF: Highly accurate IMU orientation estimation with bias
estimation and magnetic disturbance rejection"), which serves ``update``, ``updateBatch`` and its
offline function, a :class:`SensorChain` serves

* live blocks, forward, continuing its state: :meth:`SensorChain.update`, or
  :func:`update_chains` for the blocks of many sensors at once (one filter call for all the
  sensors whose blocks have the same shape);
* a whole recording, forward from a prior (the live filter's state when the recording started,
  :data:`~mimucap.core.pipeline.settings.RESULT_LIVE`) or smoothed with past and future data
  from the same prior (Rauch-Tung-Striebel, :data:`~mimucap.core.pipeline.settings.RESULT_REPROCESSED`):
  :meth:`SensorChain.process`.

Fed the same samples from the same state, the two give the same numbers (the filter gives the
same result block by block as in one call), which is how a recording's *as seen live* result
reproduces the screen.

Each result (:class:`SensorOrientations`) carries, per sample, what a stage that looks at
several sensors at once needs (:mod:`.instants`, :mod:`.segments`): the orientation, the
filter's flags (magnetometer rejected or missing, rest, ...), its heading uncertainty, the
reasons for doubt (:mod:`.sensor_doubt`), and on request the orientation of a second filter
that never uses the magnetometer (``magnetometer_free``).

Times ``t_s`` are float64 seconds on one clock per chain; fields µT, rates rad/s, specific
force m/s², quaternions ``[w, x, y, z]`` world ENU.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from mimucap.core.fusion.ekf import FusionResult, OrientationEKF, update_together
from mimucap.core.fusion.offline import SmootherStore, forward_block, smooth
from mimucap.core.fusion.state import FusionState
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.pipeline import sensor_doubt
from mimucap.core.pipeline.settings import (
    DEFAULT_PIPELINE_SETTINGS, RESULT_REPROCESSED, PipelineSettings, check_result, state_to_dict,
)
from mimucap.core.sensor_samples import SensorSamples

#: The filter's algorithm (:data:`~mimucap.core.fusion.algorithms.ALGORITHMS`) unless a chain
#: is given another (the orientation benchmark compares them).
DEFAULT_ALGORITHM = "ekf-taylor3"
#: Samples the filter is fed at a time when a recording is processed, so that its covariance is
#: read as often as the live view reads it between blocks (the numbers are those of one call).
FILTER_BLOCK_SAMPLES = 32


@dataclass(frozen=True)
class SensorOrientations:
    """What a chain made of N samples of its sensor (:class:`~mimucap.core.sensor_samples.SensorSamples`).

    ``t_s`` (N,) s; ``q_world_from_sensor`` (N, 4) (NaN rows before the filter has an
    orientation); ``mag_uT`` (N, 3) the calibrated field, or None; ``flags`` (N,) uint8 the
    filter's flags (:data:`~mimucap.core.fusion.state.FLAG_NAMES`; zeros for an on-board
    orientation); ``onboard`` whether the device fused it; ``doubt`` (N,) uint16 the reasons it
    may be wrong (:mod:`.doubt_reasons`; None for a chain that keeps none); ``heading_std_rad``
    (N,) the filter's heading standard deviation after the block the sample was fed in (NaN for
    an on-board orientation: the device does not say); ``q_world_from_sensor_no_mag`` (N, 4) the
    orientation of the chain's magnetometer-free filter, or None.
    """

    sensor_id: str
    t_s: np.ndarray
    q_world_from_sensor: np.ndarray
    mag_uT: np.ndarray | None
    flags: np.ndarray
    onboard: bool
    doubt: np.ndarray | None
    heading_std_rad: np.ndarray
    q_world_from_sensor_no_mag: np.ndarray | None = None


class SensorChain:
    """Magnetometer calibration, on-board rule and orientation filter of one sensor (see the
    module docstring).

    Args:
        sensor_id: the sensor's session-wide name.
        mag_calibration: its magnetometer calibration (None: the raw field is used).
        settings: the filter's settings.
        state: the filter's prior (a one-sensor :class:`~mimucap.core.fusion.state.FusionState`,
            e.g. the live filter's state when a recording started); None starts a fresh filter,
            which aligns on its first samples.
        algorithm: one of :data:`~mimucap.core.fusion.algorithms.ALGORITHMS`.
        magnetometer_free: also run a filter that never uses the magnetometer, and report its
            orientation (``q_world_from_sensor_no_mag``).
        doubt: keep the reasons for doubt (:mod:`.sensor_doubt`); the commands that only write
            orientations leave them out.

    The filter is created on the first block with a gyroscope (using the magnetometer if that
    block has one). A new magnetometer calibration keeps the running filter's orientation and
    gyro bias but reopens their uncertainty, with the heading unknown
    (:meth:`~mimucap.core.fusion.ekf.OrientationEKF.magnetometer_changed`): the corrected field
    then sets the heading within a second, where a new filter, aligned on one accelerometer
    sample of a sensor that is being strapped back on and with its gyro bias forgotten, took
    tens of seconds to settle (and a body calibration made meanwhile kept its heading error).
    """

    def __init__(self, sensor_id: str, mag_calibration: MagCalibration | None = None,
                 settings: PipelineSettings = DEFAULT_PIPELINE_SETTINGS, *, state: FusionState | None = None,
                 algorithm: str = DEFAULT_ALGORITHM, magnetometer_free: bool = False, doubt: bool = True) -> None:
        if mag_calibration is not None and mag_calibration.sensor_id != sensor_id:
            raise ValueError(f"the magnetometer calibration of sensor {mag_calibration.sensor_id} cannot be "
                             f"used for sensor {sensor_id}")
        self.sensor_id = sensor_id
        self.settings = settings
        self.mag_calibration = mag_calibration
        self.prior = state
        self.algorithm = algorithm
        self.magnetometer_free = magnetometer_free
        self.keeps_doubt = doubt
        #: the orientation filter, once a block with a gyroscope has come
        self.ekf: OrientationEKF | None = None
        #: the magnetometer-free filter (``magnetometer_free`` chains)
        self.ekf_no_mag: OrientationEKF | None = None
        #: the device sends its own orientation (the on-board rule, :meth:`takes_onboard`)
        self.onboard = False
        self._doubt: sensor_doubt.SensorDoubt | None = None

    # ---------------------------------------------------------------- step 1 and the rules

    def set_mag_calibration(self, calibration: MagCalibration | None) -> None:
        """Use ``calibration`` (None: the raw field) from now on; the running filter learns the
        heading anew (see the class docstring)."""
        if calibration is not None and calibration.sensor_id != self.sensor_id:
            raise ValueError(f"the magnetometer calibration of sensor {calibration.sensor_id} cannot be "
                             f"used for sensor {self.sensor_id}")
        self.mag_calibration = calibration
        if self.ekf is not None and self.ekf.use_mag:
            self.ekf.magnetometer_changed()
        if self._doubt is not None:
            self._doubt.set_mag_calibration(calibration)

    def calibrated_mag(self, mag_raw_uT: np.ndarray | None) -> np.ndarray | None:
        """``mag_raw_uT`` (N, 3) corrected by this sensor's calibration (raw when it has none)."""
        if mag_raw_uT is None or self.mag_calibration is None:
            return mag_raw_uT
        return self.mag_calibration.apply(mag_raw_uT, self.sensor_id)

    def corrected_gyr(self, samples: SensorSamples) -> SensorSamples:
        """``samples`` with their rates corrected by this sensor's gyroscope correction (the
        same record when there is none to apply)."""
        if samples.gyr is None or self.mag_calibration is None or not self.mag_calibration.corrects_gyr:
            return samples
        return replace(samples, gyr=self.mag_calibration.correct_gyr(samples.gyr))

    def fused_mag(self, calibrated_uT: np.ndarray | None) -> np.ndarray | None:
        """The field the filter fuses: ``calibrated_uT`` (:meth:`calibrated_mag`), or None when
        the settings' heading mode runs the filters without magnetometers."""
        return calibrated_uT if self.settings.uses_magnetometers else None

    def takes_onboard(self, samples: SensorSamples) -> bool:
        """The on-board-orientation rule: samples that carry ``q_world_from_sensor`` come from a
        device that fuses on board, and that orientation is used as it is (the chain is marked
        :attr:`onboard`); other samples go through the filter when they have a gyroscope."""
        if samples.q_world_from_sensor is not None:
            self.onboard = True
            return True
        return False

    def _filters_for(self, has_mag: bool) -> OrientationEKF:
        """The chain's filter, made at its first block from the prior (the one place in the
        application that makes an orientation filter); with it the magnetometer-free one."""
        if self.ekf is None:
            params = self.settings.fusion
            self.ekf = OrientationEKF(params, algorithm=self.algorithm, use_mag=has_mag, state=self.prior)
            if self.magnetometer_free:
                self.ekf_no_mag = OrientationEKF(params, algorithm=self.algorithm, use_mag=False, state=self.prior)
        return self.ekf

    # ---------------------------------------------------------------- the filter's state

    def state_snapshot(self) -> dict[str, list] | None:
        """The filter state now (JSON-ready), ``None`` before the filter has started."""
        return None if self.ekf is None else state_to_dict(self.ekf.state)

    def counters(self) -> dict[str, int]:
        """The filter's counts so far (samples, skipped, rest, magnetometer and accelerometer
        rejected or missing); empty before the filter has started."""
        return {} if self.ekf is None else self.ekf.counters()

    def heading_std_rad(self) -> float:
        """The filter's heading standard deviation now (rad; NaN without a filter)."""
        if self.ekf is None or self.onboard:
            return math.nan
        return math.sqrt(max(float(self.ekf.state.cov[0][2, 2]), 0.0))

    # ---------------------------------------------------------------- doubt

    def doubt(self) -> sensor_doubt.SensorDoubt:
        """What keeps this sensor's reasons for doubt (:mod:`.sensor_doubt`) across blocks."""
        if self._doubt is None or self._doubt.onboard != self.onboard:
            self._doubt = sensor_doubt.SensorDoubt(self.settings.fusion, self.mag_calibration, onboard=self.onboard)
        return self._doubt

    def _doubt_block(self, samples: SensorSamples, mag_uT: np.ndarray | None, q: np.ndarray,
                     flags: np.ndarray) -> sensor_doubt.DoubtBlock:
        """A block this chain has just fused (or received fused on board) as the doubt takes it,
        with the filter's covariance after it."""
        if self.onboard:
            return sensor_doubt.DoubtBlock(samples.t_s, samples.seq, samples.gyr, None, q, flags, None,
                                           samples.calibration)
        cov = None if self.ekf is None else self.ekf.state.cov[0]
        return sensor_doubt.DoubtBlock(samples.t_s, samples.seq, samples.gyr, mag_uT, q, flags, cov)

    # ---------------------------------------------------------------- live blocks

    def update(self, samples: SensorSamples) -> SensorOrientations | None:
        """Calibrate and fuse a new block of this sensor, forward from the chain's state (see
        :func:`update_chains`); None when the block has neither an orientation nor a gyroscope."""
        return update_chains([self], [samples])[0]

    # ---------------------------------------------------------------- whole recordings

    def process(self, samples: SensorSamples, result: str = RESULT_REPROCESSED) -> SensorOrientations:
        """One sensor's whole recording through the chain, from its prior.

        ``samples``: raw samples (``mag_uT`` raw µT, calibrated here; a ``q_world_from_sensor``
        is the device's own orientation and is used as it is, its ``calibration`` status giving
        the reasons for doubt). ``result``: :data:`~mimucap.core.pipeline.settings.RESULT_LIVE`
        runs the forward filter, :data:`~mimucap.core.pipeline.settings.RESULT_REPROCESSED`
        smooths it with past and future data (one forward pass, then the backward pass); the
        reasons for doubt of the smoothed result also reach back from later samples
        (:meth:`~mimucap.core.pipeline.sensor_doubt.DoubtTerms.smoothed`). The chain's filter
        continues from where the recording leaves it. ``ValueError`` naming the sensor when it
        has neither an orientation nor a gyroscope.
        """
        smoothed = check_result(result) == RESULT_REPROCESSED
        t = np.asarray(samples.t_s, dtype=np.float64)
        n = len(t)
        if self.takes_onboard(samples):
            q = np.asarray(samples.q_world_from_sensor, dtype=np.float64)
            flags = np.zeros(n, dtype=np.uint8)
            reasons = None
            if self.keeps_doubt:
                reasons = self.doubt().update(t, samples.seq, samples.gyr, None, q, flags, None,
                                              samples.calibration).reasons()
            return SensorOrientations(self.sensor_id, t, q, None, flags, True, reasons, np.full(n, math.nan))
        if samples.gyr is None:
            raise ValueError(f"sensor {self.sensor_id}: neither an on-board orientation nor a gyroscope to fuse")
        samples = self.corrected_gyr(samples)
        field = self.calibrated_mag(samples.mag_uT)
        mag = self.fused_mag(field)
        ekf = self._filters_for(mag is not None)
        # the smoother's forward pass weighs the magnetometer its own way, on the chain's state
        feeding = ekf.smoother_pass() if smoothed else ekf
        store = SmootherStore(n) if smoothed else None
        store_free = SmootherStore(n) if smoothed and self.ekf_no_mag is not None else None
        step = FILTER_BLOCK_SAMPLES if self.keeps_doubt else max(n, 1)
        forward: list[FusionResult] = []
        free: list[FusionResult] = []
        terms: list[sensor_doubt.DoubtTerms] = []
        heading = np.empty(n)
        gyr, acc, seq = samples.gyr, samples.acc, samples.seq
        for start in range(0, n, step):
            rows = slice(start, start + step)
            block = [None if channel is None else channel[rows] for channel in (t, gyr, acc, mag, seq)]
            forward.append(_feed(feeding, store, start, *block[:4]))
            if self.ekf_no_mag is not None:
                free.append(_feed(self.ekf_no_mag, store_free, start, *block[:3], None))
            heading[rows] = self.heading_std_rad()
            if self.keeps_doubt:
                out = forward[-1]
                terms.append(self.doubt().update(block[0], block[4], block[1], block[3], out.q_world_from_sensor,
                                                 out.flags, ekf.state.cov[0]))
        q, flags = _joined(forward, n)
        q_free = _joined(free, n)[0] if self.ekf_no_mag is not None else None
        doubt_terms = sensor_doubt.DoubtTerms.joined(terms) if self.keeps_doubt else None
        if smoothed and n:
            q = smooth(q, _joined_bias(forward, n), store)[0]
            if q_free is not None:
                q_free = smooth(q_free, _joined_bias(free, n), store_free)[0]
            if doubt_terms is not None:
                intervals = np.diff(t)
                intervals = intervals[intervals > 0]
                step_s = float(np.median(intervals)) if len(intervals) else 0.01
                doubt_terms = doubt_terms.smoothed(sensor_doubt.smoother_memory_s(self.settings.fusion, step_s))
        reasons = None if doubt_terms is None else doubt_terms.reasons()
        return SensorOrientations(self.sensor_id, t, q, field, flags, False, reasons, heading, q_free)


def _feed(ekf: OrientationEKF, store: SmootherStore | None, start: int, t_s: np.ndarray, gyr_rad_s: np.ndarray,
          acc_m_s2: np.ndarray | None, mag_uT: np.ndarray | None) -> FusionResult:
    """Samples ``start:start + N`` of a recording through ``ekf``, keeping what the smoother
    needs in ``store`` (None: the forward result only)."""
    if store is None:
        return ekf.update_batch(t_s, gyr_rad_s, acc_m_s2, mag_uT)
    return forward_block(ekf, store, start, t_s, gyr_rad_s, acc_m_s2, mag_uT)


def _joined(parts: Sequence[FusionResult], n: int) -> tuple[np.ndarray, np.ndarray]:
    """``q_world_from_sensor`` (N, 4) and ``flags`` (N,) of consecutive blocks."""
    if not parts:
        return np.zeros((n, 4)) * np.nan, np.zeros(n, dtype=np.uint8)
    return (np.concatenate([part.q_world_from_sensor for part in parts]),
            np.concatenate([part.flags for part in parts]))


def _joined_bias(parts: Sequence[FusionResult], n: int) -> np.ndarray:
    return np.concatenate([part.bias_rad_s for part in parts]) if parts else np.zeros((n, 3))


def update_chains(chains: Sequence[SensorChain], blocks: Sequence[SensorSamples]) -> list[SensorOrientations | None]:
    """Each block through its sensor's chain (``chains[i]`` takes ``blocks[i]``), forward,
    continuing each chain's state: the live form. Returns the results in the blocks' order
    (None for a block with neither an orientation nor a gyroscope).

    ``blocks`` hold raw samples (``t_s`` on the chains' clock, raw ``mag_uT``; a
    ``q_world_from_sensor`` is the device's own orientation). A sensor may have several blocks
    in a call, in time order. Chains whose blocks have the same length and channels and whose
    filters the same settings go through the filter in one call
    (:func:`~mimucap.core.fusion.ekf.update_together`): for a 17-sensor suit one kernel call per
    poll instead of 17, with the same numbers; a sensor with several blocks in a call has them
    fused one after the other. The reasons for doubt of every block are worked out together too
    (:func:`~mimucap.core.pipeline.sensor_doubt.update_together`).
    """
    count = len(blocks)
    blocks = [chain.corrected_gyr(block) for chain, block in zip(chains, blocks)]
    calibrated: list[np.ndarray | None] = [None] * count
    fused_field: list[np.ndarray | None] = [None] * count
    fused: list[int] = []
    onboard: list[int] = []
    for index, (chain, block) in enumerate(zip(chains, blocks)):
        calibrated[index] = chain.calibrated_mag(block.mag_uT)
        fused_field[index] = chain.fused_mag(calibrated[index])
        if chain.takes_onboard(block):
            onboard.append(index)
        elif block.gyr is not None:
            chain._filters_for(fused_field[index] is not None)
            fused.append(index)
    orientation: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    heading: dict[int, np.ndarray] = {}
    for index in onboard:
        n = len(blocks[index].t_s)
        orientation[index] = (np.asarray(blocks[index].q_world_from_sensor, dtype=np.float64),
                              np.zeros(n, dtype=np.uint8))
        heading[index] = np.full(n, math.nan)
    outputs = _grouped([(chains[i].ekf, blocks[i], fused_field[i]) for i in fused])
    for index, out in zip(fused, outputs):
        orientation[index] = out
        heading[index] = np.full(len(blocks[index].t_s), chains[index].heading_std_rad())
    free_at = [i for i in fused if chains[i].ekf_no_mag is not None]
    free = dict(zip(free_at, (q for q, _flags in _grouped([(chains[i].ekf_no_mag, blocks[i], None)
                                                           for i in free_at]))))
    done = sorted(onboard + fused)
    with_doubt = [i for i in done if chains[i].keeps_doubt]
    reasons: dict[int, np.ndarray] = {}
    if with_doubt:
        doubt_blocks = [chains[i]._doubt_block(blocks[i], fused_field[i], *orientation[i]) for i in with_doubt]
        joined = sensor_doubt.update_together([chains[i].doubt() for i in with_doubt], doubt_blocks).reasons()
        start = 0
        for index in with_doubt:
            n = len(blocks[index].t_s)
            reasons[index] = joined[start:start + n]
            start += n
    results: list[SensorOrientations | None] = [None] * count
    for index in done:
        chain, block = chains[index], blocks[index]
        q, flags = orientation[index]
        results[index] = SensorOrientations(block.sensor_id, block.t_s, q, None if chain.onboard else calibrated[index],
                                            flags, chain.onboard, reasons.get(index), heading[index], free.get(index))
    return results


def _grouped(inputs: Sequence[tuple[OrientationEKF, SensorSamples, np.ndarray | None]]
             ) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(q_world_from_sensor, flags)`` of each ``(filter, block, calibrated field)``, in order:
    the filters whose blocks have the same length and channels and that run the same equations
    share one kernel call; a filter with more than one block has them fed one after the other."""
    blocks_of = Counter(id(ekf) for ekf, _block, _mag in inputs)
    groups: dict[object, list[int]] = {}
    for index, (ekf, block, mag) in enumerate(inputs):
        shares = blocks_of[id(ekf)] == 1  # a filter appears once in a call
        key = ((len(block.t_s), block.acc is None, mag is None, ekf.grouping_key) if shares else ("alone", index))
        groups.setdefault(key, []).append(index)
    outputs: list[tuple[np.ndarray, np.ndarray] | None] = [None] * len(inputs)
    for indices in sorted(groups.values()):
        members = [inputs[i] for i in indices]

        def stacked(pick):
            first = pick(members[0])
            return None if first is None else np.stack([pick(member) for member in members])

        result = update_together([ekf for ekf, _block, _mag in members], stacked(lambda m: m[1].t_s),
                                 stacked(lambda m: m[1].gyr), stacked(lambda m: m[1].acc), stacked(lambda m: m[2]))
        for row, index in enumerate(indices):
            outputs[index] = (result.q_world_from_sensor[row], result.flags[row])
    return outputs  # type: ignore[return-value]

