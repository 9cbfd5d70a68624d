"""Where each sensor's heading comes from: its own filter, the field the body shares, or its joint.

The orientation filters give every sensor's ``q_world_from_sensor`` on its own; this step, the
joint coupling of the segment stage (:class:`~mimucap.core.pipeline.segments.JointCoupling`,
between the sensors' orientations at the same instants and their segments), corrects each
sensor's heading relative to the body's, choosing per sensor and instant from the field checks:

1. **The field the body shares** (:mod:`mimucap.core.fusion.uniform_field`): while a sensor's
   field agrees with the body's in magnitude and dip, its azimuth says how the sensor is turned
   relative to the others, even when the field is not the one the magnetometers were
   calibrated in and every filter rejects it. The sensor is turned back by its averaged relative
   error.
2. **The joint** (:mod:`mimucap.core.joint_coupling`): the distal segment of a hinge (the
   shank under the knee) takes its orientation about the vertical and about its own long axis
   relative to the proximal one from the joint axis, whatever its own field (the floor's
   gradient reaches the shanks first, in the N-pose too). Only the instants that hold the hinge
   count, and the correction fades in with their share (:data:`HINGE_EVIDENCE_SHARE`): where
   the sensors were off the body it is the filter's heading, with no jump where they come on.
3. **Its own filter** alone: a sensor whose field disagrees with the body's keeps the last
   relative correction its field gave, on its gyroscope.

The body's heading as a whole stays that of the filters (the mean over the agreeing sensors).
Heading errors of the filters change slowly (gyro bias, a field followed over seconds), so
each source's relative error is averaged over :data:`DEFAULT_TIME_CONSTANT_S`: as seen live
with a first-order low-pass over the past (:class:`ExponentialAverage`), reprocessed forwards and
backwards (no lag).

Modes (:data:`~mimucap.core.heading_modes.MODES`, the pipeline settings' ``heading``):
``coupled`` (the above), ``magnetometer`` (each filter's heading as it is), ``no-magnetometer``
(the filters ignore every magnetometer; the knees' distal segments from their joints, the
others from the gyroscopes: rooms where no magnetometer can be trusted; the body calibration is
then made from the same magnetometer-free tracks, ``mimucap bodycal --heading no-magnetometer``).

Per sensor and instant the source used is one of :data:`SOURCE_NAMES` (uint8 codes).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from mimucap.core import bodycal, rotation, skeleton
from mimucap.core.fusion.uniform_field import shared_field_terms
from mimucap.core.heading_modes import MODE_COUPLED, MODE_MAGNETOMETER, check_mode
from mimucap.core.joint_coupling import HINGE_JOINTS, hinge_errors, hinge_statistics
from mimucap.core.pipeline import doubt_reasons
from mimucap.core.pipeline.instants import SensorsAtInstants
from mimucap.core.pipeline.segments import SegmentStage
from mimucap.core.pipeline.settings import RESULT_REPROCESSED, PipelineSettings

SOURCE_FILTER = 0
SOURCE_SHARED_FIELD = 1
SOURCE_JOINT = 2
SOURCE_HELD = 3
#: Source code → (short name for files, words for people).
SOURCE_NAMES = {
    SOURCE_FILTER: ("filter", "its own filter"),
    SOURCE_SHARED_FIELD: ("shared_field", "the magnetic field the body shares"),
    SOURCE_JOINT: ("joint", "its joint's axis (knee)"),
    SOURCE_HELD: ("held", "its gyroscope, its field disagreeing with the body's"),
}

#: Time constant (s) over which relative heading errors are averaged: several gait cycles,
#: so that a knee's axial rotation within a cycle and the magnetometers' noise average out,
#: yet short beside the gyroscope's drift.
DEFAULT_TIME_CONSTANT_S = 2.0
#: The hinge's errors are solved to first order (:func:`~mimucap.core.joint_coupling.hinge_errors`);
#: a second pass on the corrected orientations (Gauss-Newton) removes what the first left of a
#: large one (a drift of tens of degrees without a magnetometer).
HINGE_ITERATIONS = 2
#: How much a sensor's field's deviation from the body's varies (µT, its spread over the past
#: :data:`DEFAULT_TIME_CONSTANT_S`, in the horizontal and vertical components of
#: :func:`~mimucap.core.fusion.uniform_field.shared_field_terms`) in a field the body shares,
#: while walking: the magnetometers' noise and the attitude's error of a degree or so in the
#: accelerations of gait, which moves a 50 µT field between its horizontal and vertical
#: components by about 1 µT (a constant deviation is the sensor's calibration in a field other
#: than the calibrated one, and says nothing of the room). Beyond it the field varies over the
#: sensor's path: a real room's field is not uniform (de Vries, Veeger, Baten, van der Helm 2009,
#: "Magnetic distortion in motion labs, implications for validating inertial magnetic sensors",
#: found its heading scattered by 29° at the floor, 3° at 1 m), and it turns about the vertical
#: by about as much as it varies in the components a check can see. The sensor's relative
#: heading error then counts with the inverse of that variance: averaged over a time longer by
#: the spread's ratio to this one, squared, over which a moving sensor's local turns average out
#: while a filter's drift is still followed.
SHARED_DEVIATION_UT = 1.0


def own_field_weight(spread_uT: float) -> float:
    """The weight (0-1) of a sensor's own field at one place beside what the body's field gives
    it over the recording, from how much its field's deviation from the body's varied while it
    moved (µT, :func:`~mimucap.core.fusion.uniform_field.deviation_spread_uT`): the inverse of
    its variance beyond a shared field's, ``(SHARED_DEVIATION_UT / spread)²``, as the relative
    errors above count; 1 within a shared field's spread, or unknown."""
    if not np.isfinite(spread_uT) or spread_uT <= SHARED_DEVIATION_UT:
        return 1.0
    return float((SHARED_DEVIATION_UT / spread_uT) ** 2)


#: A sensor whose share of agreeing field samples over the time constant falls below this
#: counts as held on its gyroscope.
AGREEING_SHARE = 0.5
#: The share of the averaged instants that held a hinge
#: (:data:`~mimucap.core.joint_coupling.HINGE_RESIDUAL_LIMIT_DEG`) from which its distal
#: segment is corrected in full; below it the correction fades out in proportion.
HINGE_EVIDENCE_SHARE = 0.5


#: Reasons for doubt (:mod:`~mimucap.core.pipeline.doubt_reasons`) about a sensor's own magnetometer, which say
#: nothing about its heading relative to the body when that came from the shared field or its
#: joint.
RELIEVED_REASONS = (doubt_reasons.MAG_REJECTED | doubt_reasons.MAG_MISSING | doubt_reasons.FIELD_MISMATCH
                    | doubt_reasons.NO_MAGNETOMETER)


def relieved(reasons: np.ndarray, sources: np.ndarray) -> np.ndarray:
    """``reasons`` (T,) without :data:`RELIEVED_REASONS` where ``sources`` (T,) is the shared
    field or the joint."""
    coupled = (sources == SOURCE_SHARED_FIELD) | (sources == SOURCE_JOINT)
    return np.where(coupled, reasons & ~np.asarray(RELIEVED_REASONS, dtype=reasons.dtype), reasons)


class ExponentialAverage:
    """First-order low-pass over time of an array of values (any shape, real or complex), fed
    instant by instant (:meth:`step`) or a series at a time (:meth:`series`) with the time
    constant ``time_constant_s`` (s); the very first instant is taken as it is."""

    def __init__(self, time_constant_s: float) -> None:
        self.time_constant_s = time_constant_s
        self.value: np.ndarray | None = None
        self.t_s: float | None = None

    def step(self, t_s: float, value: np.ndarray) -> np.ndarray:
        return self.series(np.array([t_s], dtype=np.float64), np.asarray(value)[None])[0]

    def series(self, t_s: np.ndarray, values: np.ndarray, time_constant_s: np.ndarray | None = None) -> np.ndarray:
        """The averages (T, ...) of ``values`` (T, ...) at ``t_s`` (T,) s, continuing from where
        the average stands (it then stands at the last); ``time_constant_s`` per instant and
        element in place of the average's own (see :func:`exponential_average`)."""
        start = None if self.value is None or self.t_s is None else (self.t_s, self.value)
        tau = self.time_constant_s if time_constant_s is None else time_constant_s
        out = exponential_average(t_s, values, tau, both_ways=False, start=start)
        if len(t_s):
            newest = float(t_s[-1]) if self.t_s is None else max(float(t_s[-1]), self.t_s)
            self.settle(newest, out[-1])
        return out

    def settle(self, t_s: float, value: np.ndarray) -> None:
        """Continue from ``value`` at ``t_s``."""
        self.t_s, self.value = float(t_s), np.array(value, copy=True)


def exponential_average(t_s: np.ndarray, values: np.ndarray, time_constant_s: float | np.ndarray, both_ways: bool,
                        start: tuple[float, np.ndarray] | None = None) -> np.ndarray:
    """:class:`ExponentialAverage` over a series ``values`` (T, ...) at ``t_s`` (T,) s, from the
    average ``start`` (``(t_s, value)``; None: the first instant as it is); ``time_constant_s``
    (s) one for all, or one per instant and element ((T, ...), leading dimensions of ``values``);
    ``both_ways`` runs it again backwards over the forward result (no lag: for the reprocessed
    result). An instant not after the one before leaves the average as it is."""
    out = np.empty_like(values)
    if not len(t_s):
        return out
    before = t_s[:1] if start is None else np.array([start[0]], dtype=np.float64)
    dt = np.diff(t_s, prepend=before).clip(0.0)
    tau = np.asarray(time_constant_s, dtype=np.float64)
    gains = -np.expm1(-dt.reshape((-1,) + (1,) * max(tau.ndim - 1, 0)) / tau)
    gains = gains.reshape(gains.shape + (1,) * (np.ndim(values) - gains.ndim))
    if start is None:
        gains[0] = 1.0
        value = values[0]
    else:
        value = np.asarray(start[1])
    for k in range(len(t_s)):
        value = value + gains[k] * (values[k] - value)
        out[k] = value
    if both_ways:
        for k in range(len(t_s) - 2, -1, -1):
            out[k] = out[k + 1] + gains[k + 1] * (out[k] - out[k + 1])
    return out


def weighted_angles(angle_rad: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Angles as weighted unit vectors (complex; averaging them has no wrap-around, and an
    instant of weight 0 leaves the average's angle as it was), with the share of instants of
    weight > 0 as a second, real channel: (..., 2) complex."""
    return np.stack([weight * np.exp(1j * angle_rad), (weight > 0).astype(np.complex128)], axis=-1)


def angles_and_shares(averaged: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`weighted_angles` after averaging: the angles (rad) and the shares."""
    return np.angle(averaged[..., 0]), averaged[..., 1].real


def turned_about_vertical(q_world_from_sensor: np.ndarray, angle_rad: np.ndarray) -> np.ndarray:
    """``Rz(angle) ⊗ q``: orientations (..., 4) turned about the world's vertical by ``angle_rad`` (...)."""
    half = 0.5 * np.asarray(angle_rad)
    turn = np.zeros(np.shape(half) + (4,))
    turn[..., 0], turn[..., 3] = np.cos(half), np.sin(half)
    return rotation.multiply(turn, q_world_from_sensor)


@dataclass(frozen=True)
class Hinge:
    """A hinge joint between two sensors' segments: the sensors and their ``q_sensor_from_segment``."""

    joint: str
    proximal_sensor: str
    distal_sensor: str
    q_sensor_from_proximal: np.ndarray
    q_sensor_from_distal: np.ndarray


def hinges(model: skeleton.SkeletonModel, body_calibration: bodycal.BodyCalibration | None,
           sensors: Sequence[str]) -> list[Hinge]:
    """The model's hinge joints (:data:`~mimucap.core.joint_coupling.HINGE_JOINTS`) whose two
    segments carry a body-calibrated sensor among ``sensors`` (none without a body calibration:
    the joint axis in the sensors' frames is not known then)."""
    if body_calibration is None:
        return []
    found = []
    for joint in model.joints:
        if joint.kind not in HINGE_JOINTS:
            continue
        proximal = body_calibration.sensors.get(joint.proximal)
        distal = body_calibration.sensors.get(joint.distal)
        if proximal in sensors and distal in sensors:
            found.append(Hinge(joint.name, proximal, distal,
                               rotation.conjugate(body_calibration.q_segment_from_sensor[joint.proximal]),
                               rotation.conjugate(body_calibration.q_segment_from_sensor[joint.distal])))
    return found


class HeadingCoupling:
    """The heading correction of a set of sensors (see the module docstring): the joint
    coupling of the segment stage (:meth:`couple`).

    ``sensors`` the sensor ids in a fixed order (rows of the arrays); ``hinge_list`` from
    :func:`hinges`; ``mode`` one of :data:`~mimucap.core.heading_modes.MODES`; ``both_ways``
    averages a whole series forwards and backwards (the reprocessed result). :meth:`step`
    corrects one instant (the live view), :meth:`run` a whole series (causal, as :meth:`step`
    gives it, or both ways). As the segment stage's coupling, the sensors and hinges are those
    of the stage's assignment and body calibration, and the averages start anew when those
    change."""

    def __init__(self, sensors: Sequence[str], hinge_list: Sequence[Hinge], mode: str = MODE_COUPLED,
                 time_constant_s: float = DEFAULT_TIME_CONSTANT_S, both_ways: bool = False) -> None:
        self.mode = check_mode(mode)
        self.time_constant_s = time_constant_s
        self.both_ways = both_ways
        self._stage_key: tuple | None = None
        self._pending_state: dict[str, Any] | None = None
        self._configure(sensors, hinge_list)

    def _configure(self, sensors: Sequence[str], hinge_list: Sequence[Hinge]) -> None:
        """Couple ``sensors`` through ``hinge_list``, the averages started anew."""
        self.sensors = list(sensors)
        self.index = {sid: i for i, sid in enumerate(self.sensors)}
        self.hinges = [h for h in hinge_list if h.proximal_sensor in self.index and h.distal_sensor in self.index]
        self._deviation = ExponentialAverage(self.time_constant_s)
        self._field = ExponentialAverage(self.time_constant_s)
        self._joint = [ExponentialAverage(self.time_constant_s) for _ in range(HINGE_ITERATIONS)]

    @property
    def active(self) -> bool:
        return self.mode != MODE_MAGNETOMETER and bool(self.sensors)

    def _field_terms(self, q: np.ndarray, mag: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """(..., S, 2) complex, :func:`weighted_angles` of each sensor's relative heading error,
        and (..., S, 5) its field's deviation from the body's (µT: horizontal, vertical), its
        square (µT²), whether it has a field (to average: the moments over the instants with one)
        and whether it agrees."""
        if self.mode != MODE_COUPLED or mag is None:
            zeros = np.zeros(q.shape[:-1])
            return weighted_angles(zeros, zeros), np.zeros(q.shape[:-1] + (5,))
        if q.ndim == 2:
            error, weight, deviation = shared_field_terms(q, mag)
        else:
            terms = [shared_field_terms(q[k], mag[k]) for k in range(len(q))]
            error, weight, deviation = (np.array([term[i] for term in terms]) for i in range(3))
        known = np.isfinite(deviation).all(axis=-1)
        deviation = np.where(known[..., None], deviation, 0.0)
        return weighted_angles(error, weight), np.concatenate(
            [deviation, np.sum(deviation ** 2, axis=-1, keepdims=True), known[..., None],
             (weight > 0)[..., None]], axis=-1)

    def _field_correction(self, q: np.ndarray, averaged: np.ndarray,
                          share: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``q`` turned back by the averaged relative errors; the source of each heading from
        ``share``, the share of agreeing instants over :attr:`time_constant_s`."""
        if self.mode != MODE_COUPLED:
            return q.copy(), np.full(q.shape[:-1], SOURCE_FILTER, dtype=np.uint8)
        error, _share = angles_and_shares(averaged)
        source = np.where(share >= AGREEING_SHARE, SOURCE_SHARED_FIELD, SOURCE_HELD).astype(np.uint8)
        return turned_about_vertical(q, -error), source

    def _joint_terms(self, q: np.ndarray) -> np.ndarray:
        """(..., H, 5): :func:`~mimucap.core.joint_coupling.hinge_statistics` of each hinge."""
        terms = []
        for hinge in self.hinges:
            proximal = rotation.multiply(q[..., self.index[hinge.proximal_sensor], :], hinge.q_sensor_from_proximal)
            distal = rotation.multiply(q[..., self.index[hinge.distal_sensor], :], hinge.q_sensor_from_distal)
            terms.append(hinge_statistics(proximal, distal))
        return np.stack(terms, axis=-2)

    def _joint_correction(self, q: np.ndarray, averaged: np.ndarray, source: np.ndarray) -> None:
        # hinges are in model order (parents first): a distal sensor corrected here is
        # already corrected when it is the proximal sensor of a later hinge
        epsilon, delta = hinge_errors(averaged)
        # the correction fades in with the share of the averaged instants that held the hinge,
        # so that it never jumps where the evidence begins or ends (sensors strapped on after
        # their magnetometer calibration)
        evidence = np.clip(averaged[..., 0].real / HINGE_EVIDENCE_SHARE, 0.0, 1.0)
        epsilon, delta = epsilon * evidence, delta * evidence
        for j, hinge in enumerate(self.hinges):
            row = self.index[hinge.distal_sensor]
            about_long_axis = rotation.multiply(hinge.q_sensor_from_distal, rotation.multiply(
                rotation.from_axis_angle([0.0, 1.0, 0.0], epsilon[..., j]),
                rotation.conjugate(hinge.q_sensor_from_distal)))
            q[..., row, :] = turned_about_vertical(rotation.multiply(q[..., row, :], about_long_axis), delta[..., j])
            source[..., row] = np.where(evidence[..., j] >= 1.0, SOURCE_JOINT, source[..., row])

    def step(self, t_s: float, q_world_from_sensor: np.ndarray,
             mag_uT: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """One instant: ``q_world_from_sensor`` (S, 4), ``mag_uT`` (S, 3) calibrated field or None.
        Returns the corrected orientations (S, 4) and the source of each heading (S,): what
        :meth:`run` gives for it, continuing causally."""
        q, source = self.run(np.array([t_s], dtype=np.float64), np.asarray(q_world_from_sensor)[None],
                             None if mag_uT is None else np.asarray(mag_uT)[None], both_ways=False)
        return q[0], source[0]

    def run(self, t_s: np.ndarray, q_world_from_sensor: np.ndarray, mag_uT: np.ndarray | None,
            both_ways: bool) -> tuple[np.ndarray, np.ndarray]:
        """A series: ``t_s`` (T,), ``q_world_from_sensor`` (T, S, 4), ``mag_uT`` (T, S, 3) or None.
        Returns (T, S, 4) and (T, S). ``both_ways=False`` continues the averages from where the
        previous series or step left them (the live view's instants, fed in any slices, give
        what one series gives); ``both_ways=True`` averages this series alone forwards and
        backwards."""
        q = np.asarray(q_world_from_sensor, dtype=np.float64)
        if not self.active or not len(t_s):
            return q, np.zeros(q.shape[:-1], dtype=np.uint8)
        t_s = np.asarray(t_s, dtype=np.float64)

        def averaged(average: ExponentialAverage, terms: np.ndarray, tau: np.ndarray | None = None) -> np.ndarray:
            if both_ways:
                return exponential_average(t_s, terms, average.time_constant_s if tau is None else tau,
                                           both_ways=True)
            return average.series(t_s, terms, tau)

        # an instant without a sensor's orientation (before its first sample: the first instants
        # of a recording whose sensors' first blocks arrived apart) or field leaves its averages
        # as they are, as the live view, which forms an instant once every sensor delivered for it
        present = np.isfinite(q).all(axis=-1)
        measured = present if mag_uT is None else present & np.isfinite(mag_uT).all(axis=-1)
        field_kept = np.where(measured, 1.0, np.inf)
        terms, deviation_sq = self._field_terms(q, mag_uT)
        # over the past only, both ways too: an instant's variance is that of its measurement
        # and those before, not of a foreign field the sensor is yet to reach
        horizontal, vertical, square, known, agreeing = np.moveaxis(
            self._deviation.series(t_s, deviation_sq, self.time_constant_s * field_kept), -1, 0)
        known = np.maximum(known, 1e-9)
        # how much the deviation varied (a constant one is the sensor's calibration in a field
        # other than the calibrated one, not the room's field varying over its path)
        spread = np.sqrt(np.maximum(square / known - (horizontal / known) ** 2 - (vertical / known) ** 2, 0.0))
        # each instant weighted by the inverse of its variance beyond a shared field's: a
        # recursive weighted mean's gain, and so its time constant, scales so
        field_tau = self.time_constant_s * np.maximum(spread / SHARED_DEVIATION_UT, 1.0) ** 2
        q, source = self._field_correction(q, averaged(self._field, terms, field_tau * field_kept), agreeing)
        if self.hinges:
            both = np.stack([present[:, self.index[h.proximal_sensor]] & present[:, self.index[h.distal_sensor]]
                             for h in self.hinges], axis=-1)
            joint_tau = self.time_constant_s * np.where(both, 1.0, np.inf)
        for average in self._joint if self.hinges else ():
            self._joint_correction(q, averaged(average, self._joint_terms(q), joint_tau), source)
        return q, source

    def couple(self, instants: SensorsAtInstants, stage: SegmentStage) -> SensorsAtInstants:
        """The segment stage's joint coupling (:class:`~mimucap.core.pipeline.segments.JointCoupling`):
        ``instants`` with every assigned sensor's heading corrected and its source
        (``heading_source``). One instant is a :meth:`step`, a series a :meth:`run` (both ways
        when :attr:`both_ways`, else continuing causally)."""
        # in one order whatever the order the sensors came in (a stored state is by row)
        sensors = sorted(sid for sid in instants.q_world_from_sensor if sid in stage.segment_of_sensor)
        key = (tuple(sensors), id(stage.body_calibration), stage.model.name)
        if key != self._stage_key:
            self._configure(sensors, hinges(stage.model, stage.body_calibration, sensors))
            self._stage_key = key
            if self._pending_state is not None:
                self._restore(self._pending_state)
                self._pending_state = None
        if not self.active or not sensors:
            return instants
        shape = np.shape(instants.t_s)
        q = np.stack([np.asarray(instants.q_world_from_sensor[sid], dtype=np.float64) for sid in sensors], axis=-2)
        fields = [instants.mag_uT.get(sid) for sid in sensors]
        mag = None if all(f is None for f in fields) else np.stack(
            [np.full(shape + (3,), np.nan) if f is None else np.asarray(f, dtype=np.float64) for f in fields], axis=-2)
        if not shape:
            corrected, sources = self.step(float(instants.t_s), q, mag)
        else:
            corrected, sources = self.run(np.asarray(instants.t_s, dtype=np.float64), q, mag, self.both_ways)
        q_out = dict(instants.q_world_from_sensor)
        q_out.update({sid: corrected[..., i, :] for i, sid in enumerate(sensors)})
        return replace(instants, q_world_from_sensor=q_out,
                       heading_source={sid: sources[..., i] for i, sid in enumerate(sensors)})

    # -- the state a recording starts from ----------------------------------------------------
    def _layout(self) -> dict[str, list]:
        return {"sensors": list(self.sensors),
                "hinges": [[h.joint, h.proximal_sensor, h.distal_sensor] for h in self.hinges]}

    def state_to_dict(self, time_offset_s: float = 0.0) -> dict[str, Any] | None:
        """Where the causal averages stand (JSON-ready), on a clock ``time_offset_s`` behind this
        one's (a recording's, whose instants are the live view's minus that offset); None before
        any instant. :meth:`restore` continues from it: a recording's *as seen live* result
        then reproduces the live view's from its first instant."""
        if self._field.value is None or self._field.t_s is None:
            return None
        joint = [average.value for average in self._joint] if self.hinges else []
        if self._deviation.value is None or any(value is None for value in joint):
            return None
        return {**self._layout(), "t_s": self._field.t_s - float(time_offset_s),
                "field": [np.real(self._field.value).tolist(), np.imag(self._field.value).tolist()],
                "deviation": np.asarray(self._deviation.value, dtype=np.float64).tolist(),
                "joint": [np.asarray(value, dtype=np.float64).tolist() for value in joint]}

    def restore(self, state: Mapping[str, Any] | None) -> None:
        """Continue from ``state`` (:meth:`state_to_dict`) once the segment stage's sensors and
        hinges are known, if they are the ones it was taken with (else the averages start anew)."""
        self._pending_state = None if state is None else dict(state)

    def _restore(self, state: Mapping[str, Any]) -> None:
        if {key: state.get(key) for key in ("sensors", "hinges")} != self._layout():
            return
        field = np.asarray(state["field"][0], dtype=np.float64) + 1j * np.asarray(state["field"][1], dtype=np.float64)
        deviation = np.asarray(state["deviation"], dtype=np.float64)
        joint = [np.asarray(value, dtype=np.float64) for value in state["joint"]]
        if field.shape != (len(self.sensors), 2) or deviation.shape != (len(self.sensors), 5) \
                or len(joint) != (len(self._joint) if self.hinges else 0) \
                or any(value.shape != (len(self.hinges), 5) for value in joint):
            raise ValueError("the heading coupling's state does not fit its sensors and joints")
        t_s = float(state["t_s"])
        self._field.settle(t_s, field)
        self._deviation.settle(t_s, deviation)
        for average, value in zip(self._joint, joint):
            average.settle(t_s, value)


def coupling_state_from_dict(data: Any, origin: str = "heading coupling state") -> dict[str, Any] | None:
    """A stored :meth:`HeadingCoupling.state_to_dict` checked for its form (``ValueError``
    naming ``origin`` when malformed; None for none)."""
    if data is None:
        return None
    try:
        state = dict(data)
        for key in ("sensors", "hinges", "t_s", "field", "deviation", "joint"):
            if key not in state:
                raise ValueError(f"{key!r} missing")
        if not np.isfinite(float(state["t_s"])):
            raise ValueError("its time is not finite")
        field = np.asarray(state["field"], dtype=np.float64)
        joint = np.asarray(state["joint"], dtype=np.float64)
        deviation = np.asarray(state["deviation"], dtype=np.float64)
        if field.ndim != 3 or field.shape[0] != 2 or not all(np.isfinite(a).all() for a in (field, joint, deviation)):
            raise ValueError("its averages are malformed")
    except (TypeError, ValueError) as error:
        raise ValueError(f"{origin}: {error}") from None
    return state


def heading_coupling(settings: PipelineSettings, result: str,
                     live_state: Mapping[str, Any] | None = None) -> HeadingCoupling | None:
    """The segment stage's joint coupling for ``settings.heading`` and ``result`` (both ways for
    :data:`~mimucap.core.pipeline.settings.RESULT_REPROCESSED`); None where each filter's
    heading is used as it is. ``live_state`` (:meth:`HeadingCoupling.state_to_dict`, the live
    coupling's when a recording started) is where :data:`~mimucap.core.pipeline.settings.RESULT_LIVE`
    continues from."""
    if settings.heading == MODE_MAGNETOMETER:
        return None
    coupling = HeadingCoupling([], [], settings.heading, both_ways=result == RESULT_REPROCESSED)
    if result != RESULT_REPROCESSED:
        coupling.restore(live_state)
    return coupling


def source_summary(sources: Mapping[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """Sensor → source name → share (0-1) of the instants its heading came from that source."""
    out = {}
    for sensor, codes in sources.items():
        codes = np.asarray(codes)
        if not len(codes):
            continue
        out[sensor] = {SOURCE_NAMES[code][0]: float(np.mean(codes == code)) for code in SOURCE_NAMES
                       if np.any(codes == code)}
    return out
