"""Simulated sensor suit with ground truth: a skeleton moved through scripted activities,
measured by sensors with a realistic error model.

* :func:`simulate_session` runs a whole scenario at once and returns a
  :class:`SimulationResult` (measurements, truth, true parameters).
* :class:`SuitSimulator` streams the same simulation block by block (``advance``); blocks
  concatenate to exactly the batch result, and ``set_activity`` makes the subject do what a
  wizard asks (blended in over 0.5 s).

:class:`~mimucap.core.simulate.config.SimulationConfig` holds the settings; the samples and
truth come as :class:`~mimucap.core.simulate.truth.SuitBlock`. A hand-held sensor's
magnetometer-calibration motion alone is :func:`mimucap.core.simulate.hand_held.calibration_motion`.
The suit comes assigned one sensor per segment
(:func:`~mimucap.core.simulate.config.default_assignment`): the second units are worn but drive
no segment. Each unit is a device of its own (:mod:`mimucap.core.device_identity`): its error
parameters are drawn from the random seed and the error model, so
:func:`~mimucap.core.simulate.config.suit_fingerprint` of those two names the suit, and
``sim:<fingerprint>/<sensor id>`` the unit. Another seed is another suit with units numbered
alike; the same session file read twice is the same suit.

Frames: world ENU (z up), segment frames ISB (x anterior, y superior, z right), sensor
frames the device axes; quaternions scalar-first Hamilton, ``q_A_from_B``. Units: s, m,
m/s² (specific force), rad/s, µT; joint angles in degrees (Z-X'-Y'', clinical signs of
``skeleton.JOINT_ANGLE_SIGNS_DOC``). Host time ``t_s`` is the true time ``k / rate_hz``;
the device clock runs as ``(1 + drift)·t + offset``. Gyroscope sample ``k`` is the mean rate
over the preceding interval: without errors ``q_k = q_{k-1} ⊗ exp(gyr_k · dt)`` exactly.
Accelerometer sample ``k`` is the mean specific force over the same interval (the change of the
sensor point's velocity over it, plus gravity 9.81 m/s² up), seen from the sensor at
mid-interval (:func:`~mimucap.core.simulate.sensor_errors.mean_acceleration`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mimucap.core import rotation as rot
from mimucap.core import skeleton
from mimucap.core.sensor_samples import SensorSamples
from mimucap.core.simulate.clinical_tests import CLINICAL_TESTS, protocol_truth
from mimucap.core.simulate.config import SENSOR_PLACEMENTS, SensorMounting, SimulationConfig, default_assignment
from mimucap.core.simulate.magnetic_field import disturbed_field
from mimucap.core.simulate.names import SCENARIOS
from mimucap.core.simulate.rooms import room
from mimucap.core.simulate.scenarios import scenario_activities
from mimucap.core.simulate.schedule import Schedule
from mimucap.core.simulate.sensor_errors import (
    ACC_DIFF_STEP_S,
    SensorNoise,
    SensorParameters,
    draw_sensor_parameters,
    mean_acceleration,
    measure,
    stack_noise,
    stack_parameters,
)
from mimucap.core.simulate.truth import SuitBlock, SuitTruth, slice_block
from mimucap.core.simulate.walking import Walk

#: Scale (m) of the smooth minimum that keeps the lower ankle on the ground.
GROUND_SOFTNESS_M = 0.02
_STREAM_MOUNTING = 505
#: Seconds simulated per internal step of :func:`simulate_session` (bounds its memory use).
BATCH_CHUNK_S = 10.0


@dataclass
class SimulationResult:
    """A whole simulation: ``config``, ``samples``/``truth``/``markers`` as in :class:`SuitBlock`,
    true unit ``parameters`` (gyro bias, scale, magnetometer ``mag_A``/``mag_b_uT``, clock) and
    ``mounting`` per sensor id, the undisturbed ``field_world_uT`` (3,), the skeleton
    ``model_name`` and ``height_m``, and for a clinical test scenario its true results
    ``protocol`` (:func:`mimucap.core.simulate.clinical_tests.protocol_truth`; None otherwise)."""

    config: SimulationConfig
    samples: dict[str, SensorSamples]
    truth: SuitTruth
    markers: list[tuple[float, str]]
    parameters: dict[str, SensorParameters]
    mounting: dict[str, SensorMounting]
    field_world_uT: np.ndarray
    model_name: str
    height_m: float
    protocol: dict[str, Any] | None = None


def _softmin(a: np.ndarray, b: np.ndarray, scale: float) -> np.ndarray:
    """Smooth minimum, equal to ``a`` when ``a == b`` and within ``scale·ln 2`` of min(a, b)."""
    low = np.minimum(a, b)
    return low - scale * np.log(0.5 * (np.exp(-(a - low) / scale) + np.exp(-(b - low) / scale)))


class SuitSimulator:
    """Streaming simulation of the suit: :meth:`advance` returns the next block of samples.

    State: the next sample index, the activity schedule, and each unit's noise generator. The
    sample at index ``k`` is at ``t = k / rate_hz``; any sequence of blocks gives the same
    samples as one long block, as long as the activity is not changed in between.
    """

    def __init__(self, config: SimulationConfig = SimulationConfig(), lookahead_s: float = 1.0) -> None:
        if not 0.0 <= lookahead_s <= 10.0:
            raise ValueError(f"lookahead must be 0..10 s, got {lookahead_s}")
        self.config = config
        self.rate_hz = float(config.rate_hz)
        self.dt = 1.0 / self.rate_hz
        self.model = skeleton.load_model(config.model_name)
        self.errors = config.error_settings()
        self.sensor_ids = config.sensor_ids
        placements = SENSOR_PLACEMENTS[: config.n_sensors]
        missing = [p[1] for p in placements if p[1] not in self.model.segment_names]
        if missing:
            raise ValueError(f"model {self.model.name!r} has no segment(s) {', '.join(missing)} for {config.n_sensors} sensors")
        self.field_world_uT = config.earth_field.field_world_uT()
        self.room = room(config.room)
        seed = int(config.seed) & 0xFFFFFFFF
        self.parameters = {
            sid: draw_sensor_parameters(seed, index, sid, self.errors) for index, sid in enumerate(self.sensor_ids)
        }
        self._stack = stack_parameters([self.parameters[s] for s in self.sensor_ids])
        self._noise = [SensorNoise(seed, self.parameters[s], self.errors, self.rate_hz) for s in self.sensor_ids]
        self.mounting: dict[str, SensorMounting] = {}
        misalign, offsets = [], []
        for index, (sid, segment_name, along, normal) in enumerate(placements):
            rng = np.random.default_rng([seed, index, _STREAM_MOUNTING])
            q = rot.normalize(rng.normal(size=4)) if config.random_mounting else rot.identity()
            segment = self.model.segment(segment_name)
            position = (np.array(segment.direction) * along * segment.length_ratio * config.height_m
                        + np.array(normal) * segment.radius_ratio * config.height_m)
            self.mounting[sid] = SensorMounting(sid, segment_name, rot.canonical(q), position)
            misalign.append(rot.from_rotvec(rng.normal(size=3) * math.radians(1.5)))
            offsets.append(np.array([0.0, 0.0, 0.015 * index]))
        self._segments_of_sensors = [self.mounting[s].segment for s in self.sensor_ids]
        #: sensor → the segment it drives as the suit comes (:func:`default_assignment`)
        self.assignment = default_assignment(self.sensor_ids)
        #: sensor → its device id (:meth:`SimulationConfig.device_ids`)
        self.device_ids = config.device_ids()
        self._q_segment_from_sensor = np.stack([self.mounting[s].q_segment_from_sensor for s in self.sensor_ids])
        self._position_in_segment = np.stack([self.mounting[s].position_in_segment_m for s in self.sensor_ids])
        self._q_bundle_from_sensor = np.stack(misalign)
        self._bundle_offset = np.stack(offsets)
        self._seed = seed
        self._switches = 0
        self.schedule = Schedule(self._activities(config.scenario, dict(config.scenario_params),
                                                  with_magcal_turns=config.magcal_turns))
        # The walk's gait design takes a moment: made now, a streaming suit never waits for it
        # (for the default speed; other speeds are designed when first walked).
        Walk().fit_body(self.model.name, config.height_m).design  # noqa: B018
        #: The true results of a clinical test scenario (:func:`~.clinical_tests.protocol_truth`), else None.
        self.protocol: dict[str, Any] | None = None
        if config.scenario in CLINICAL_TESTS:
            planned = list(self._activities(config.scenario, dict(config.scenario_params),
                                            with_magcal_turns=config.magcal_turns))
            self.protocol = protocol_truth(config.scenario, planned, dict(config.scenario_params))
        neutral = skeleton.forward_kinematics(
            self.model, {name: skeleton.q_world_from_body_facing(0.0) for name in self.model.segment_names},
            config.height_m,
        )
        self._ankle_height_m = float(0.5 * (neutral["shank_l"].distal_m[2] + neutral["shank_r"].distal_m[2]))
        self._root_height_m = float(self.model.root_height_ratio * config.height_m)
        self._next_sample = 0
        self._target_time_s = 0.0
        self.lookahead_s = float(lookahead_s)
        self._cache: SuitBlock | None = None
        self._cache_start = self._cache_end = 0

    # ---------------------------------------------------------------------------------------
    def _activities(self, name: str, params: dict, with_magcal_turns: bool = False):
        activities = scenario_activities(name, params, sensor_ids=self.sensor_ids,
                                         seed=self._seed + 7919 * self._switches, with_magcal_turns=with_magcal_turns)
        belt = self.room.treadmill
        return (a.fit_body(self.model.name, self.config.height_m).on_treadmill(belt) if isinstance(a, Walk) else a
                for a in activities)

    @property
    def time_s(self) -> float:
        """Time (s) of the next sample to be simulated."""
        return self._next_sample * self.dt

    def set_activity(self, name: str, **params: Any) -> None:
        """From the next sample on, do activity (or scenario) ``name`` with keyword ``params``.

        Names: ``npose``, ``tpose`` (``arms="right|left|both"``), ``walk``, ``turn``,
        ``arm_raise``, ``squat``, ``rom`` (``joint=, axis=, angle_deg=``: one joint moved and back), ``demo``,
        ``bodycal``, and ``mag_single_axis``/``mag_figure8``/
        ``mag_tumble`` (``sensor_ids=[...]`` held together and turned; default all). The new
        activity is blended in over 0.5 s (1 s when walking starts or stops and when sensors
        are picked up or put back). Switching again while units are being picked up or put
        back can make them turn abruptly.
        """
        if name not in SCENARIOS:
            raise ValueError(f"unknown activity {name!r}; use one of {', '.join(SCENARIOS)}")
        if "sensor_ids" in params:
            unknown = [s for s in params["sensor_ids"] if s not in self.sensor_ids]
            if unknown:
                raise ValueError(f"unknown sensor id(s) {', '.join(unknown)}; the suit has {', '.join(self.sensor_ids)}")
        self._switches += 1
        activities = self._activities(name, params)
        if name not in ("demo", "bodycal"):
            # Skip the scenario's lead-in N-pose: switching is blended already.
            activities = (a for a in activities if not (a.name == "npose" and a.duration_s is not None and name != "npose"))
        self.schedule.switch(self.time_s, activities)
        self._cache = None

    def resume_scenario(self) -> None:
        """Start the configured scenario again from its beginning, its lead-in included (after
        doing what a calibration asked: the subject stands a moment, then moves)."""
        self._switches += 1
        self.schedule.switch(self.time_s, self._activities(self.config.scenario, dict(self.config.scenario_params)))
        self._cache = None

    def current_activity(self) -> str:
        """Label of the activity at the next sample's time."""
        return self.schedule.label_at(self.time_s)

    # ---------------------------------------------------------------------------------------
    def _orientations(self, t: np.ndarray):
        """Pose, segment orientations, and each sensor's worn and hand-held orientation (m,S,4)."""
        pose = self.schedule.pose(t)
        q_world_from_pelvis = rot.multiply(skeleton.q_world_from_body_facing(pose.heading_rad), pose.q_body_from_pelvis)
        angles = {j: pose.joint_angles_deg[j] for j in self.model.joint_names if j in pose.joint_angles_deg}
        segments = skeleton.segment_orientations_from_joint_angles(self.model, q_world_from_pelvis, angles)
        q_seg = np.stack([segments[s] for s in self._segments_of_sensors], axis=1)
        q_worn = rot.multiply(q_seg, self._q_segment_from_sensor)
        q_hand = rot.multiply(pose.bundle_q[:, None, :], self._q_bundle_from_sensor)
        return pose, angles, segments, q_seg, q_worn, q_hand

    def _pick_up(self, t: np.ndarray, held: np.ndarray, q_worn: np.ndarray, q_hand: np.ndarray) -> np.ndarray:
        """Orientations (m,S,4) of sensors between body and hand (``held`` (m,S) in [0, 1]).

        The turn from worn to hand-held follows the rotation between the two at the start of
        the current activity (a fixed path, so it cannot flip when the two orientations are
        nearly opposite), plus the small change of that rotation since then.
        """
        q = np.where(held[..., None] >= 1.0, q_hand, q_worn)
        moving = (held > 0.0) & (held < 1.0)
        rows = np.any(moving, axis=1)
        if not np.any(rows):
            return q
        t_ref = self.schedule.entry_start(t[rows])
        unique, inverse = np.unique(t_ref, return_inverse=True)
        _, _, _, _, worn_ref, hand_ref = self._orientations(unique)
        r0 = rot.to_rotvec(rot.multiply(rot.conjugate(worn_ref), hand_ref))[inverse.ravel()]
        h = held[rows][..., None]
        worn, hand = q_worn[rows], q_hand[rows]
        residual = rot.to_rotvec(rot.multiply(rot.conjugate(rot.multiply(worn, rot.from_rotvec(r0))), hand))
        blended = rot.multiply(rot.multiply(worn, rot.from_rotvec(h * r0)), rot.from_rotvec(h * residual))
        q[rows] = np.where(moving[rows][..., None], blended, q[rows])
        return q

    def kinematics(self, t_s: np.ndarray) -> dict[str, Any]:
        """True state at times ``t_s`` (m,): segment orientations and joint angles, sensor
        orientations (m,S,4) and positions (m,S,3), root position, bundle axis and held weights."""
        t = np.asarray(t_s, dtype=np.float64)
        pose, angles, segments, q_seg, q_sensor, q_hand = self._orientations(t)
        m = t.shape[0]
        root = np.zeros((m, 3))
        root[:, :2] = pose.root_xy_m
        fk = skeleton.forward_kinematics(self.model, segments, self.config.height_m, root)
        ankle_l, ankle_r = fk["shank_l"].distal_m, fk["shank_r"].distal_m
        shift = np.zeros((m, 3))
        contact_z = self._ankle_height_m - _softmin(ankle_l[:, 2], ankle_r[:, 2], GROUND_SOFTNESS_M)
        shift[:, 2] = pose.ground * contact_z + (1.0 - pose.ground) * (self._root_height_m + pose.root_dz_m)
        shift[:, :2] = pose.plant[:, None] * (pose.root_xy_m - 0.5 * (ankle_l[:, :2] + ankle_r[:, :2]))
        proximal = np.stack([fk[s].proximal_m for s in self._segments_of_sensors], axis=1)
        p_sensor = proximal + shift[:, None, :] + rot.rotate(q_seg, self._position_in_segment)
        held = np.zeros((m, len(self.sensor_ids)))
        for index, sid in enumerate(self.sensor_ids):
            if sid in pose.held:
                held[:, index] = pose.held[sid]
        if np.any(held > 0.0):
            q_sensor = self._pick_up(t, held, q_sensor, q_hand)
            p_hand = pose.bundle_p_m[:, None, :] + rot.rotate(pose.bundle_q[:, None, :], self._bundle_offset)
            p_sensor = p_sensor + held[..., None] * (p_hand - p_sensor)
        return {
            "segments": segments, "angles": angles, "q_sensor": q_sensor, "p_sensor": p_sensor,
            "root": root + shift, "axis_turned": pose.axis_turned.astype(np.int64), "held": held,
            "contact": pose.contact,
        }

    def advance(self, duration_s: float) -> SuitBlock:
        """Simulate the next ``duration_s`` seconds (the samples whose times fall into it)."""
        if not math.isfinite(duration_s) or duration_s < 0:
            raise ValueError(f"advance needs a duration >= 0 s, got {duration_s}")
        self._target_time_s += float(duration_s)
        end = int(math.floor(self._target_time_s * self.rate_hz + 1e-9))
        return self.advance_samples(max(end - self._next_sample, 0))

    def skip_samples(self, n: int) -> None:
        """Let ``n`` samples pass unmeasured (a radio dropout: the subject moves on, the
        sensors send nothing; their sequence numbers jump)."""
        if n < 0:
            raise ValueError(f"cannot skip {n} samples")
        self._next_sample += int(n)
        self._target_time_s = max(self._target_time_s, self._next_sample * self.dt)
        self.schedule.forget_before(self._next_sample * self.dt - 1.0)

    def advance_samples(self, n: int) -> SuitBlock:
        """Simulate the next ``n`` samples.

        Samples are computed ahead in chunks of at least ``lookahead_s`` and served from that
        cache (every sample is a pure function of its index and the activity schedule, so the
        values do not depend on the chunking); :meth:`set_activity` drops the cache.
        """
        n = int(n)
        if n < 0:
            raise ValueError(f"cannot advance by {n} samples")
        k0 = self._next_sample
        needed_end = k0 + n
        if self._cache is None or self._cache_start > k0 or self._cache_end < needed_end:
            chunk = max(n, int(math.ceil(self.lookahead_s * self.rate_hz)))
            if self._cache is not None and self._cache_start <= k0 < self._cache_end:
                # Keep the part not yet delivered and compute the rest.
                head = slice_block(self._cache, self._cache_start, k0, self._cache_end, self.dt)
                tail = self._simulate(self._cache_end, k0 + chunk - self._cache_end)
                self._cache = SuitBlock.concatenate([head, tail])
            else:
                self._cache = self._simulate(k0, chunk)
            self._cache_start, self._cache_end = k0, k0 + chunk
        block = slice_block(self._cache, self._cache_start, k0, needed_end, self.dt)
        self.schedule.forget_before(k0 * self.dt - 1.0)
        self._next_sample = needed_end
        self._target_time_s = max(self._target_time_s, self._next_sample * self.dt)
        return block

    def _simulate(self, k0: int, n: int) -> SuitBlock:
        """Compute samples ``k0 .. k0+n-1`` (no caching, no state change besides noise caches)."""
        t = (k0 + np.arange(n)) * self.dt
        h = ACC_DIFF_STEP_S
        state = self.kinematics(np.concatenate((t, t - self.dt, t - h, t - self.dt - h)))
        q_all, p_all = state["q_sensor"], state["p_sensor"]
        q_now, q_prev = q_all[:n], q_all[n:2 * n]
        p_now = p_all[:n]
        acc_world = mean_acceleration(p_now, p_all[2 * n:3 * n], p_all[n:2 * n], p_all[3 * n:], self.dt)
        fields = np.stack([
            disturbed_field(self.field_world_uT, self.config.disturbances, sid, t, p_now[:, i])
            for i, sid in enumerate(self.sensor_ids)
        ], axis=1)
        if not self.room.is_clean:
            fields = fields + self.room.field_uT(p_now)
        noise = stack_noise([source.block(k0, n) for source in self._noise])
        meas = measure(self._stack, self.errors, noise, t, q_now, q_prev, acc_world, fields, self.dt)
        samples = {}
        seq = k0 + np.arange(n, dtype=np.int64)
        for i, sid in enumerate(self.sensor_ids):
            keep = meas.keep[:, i]
            samples[sid] = SensorSamples(
                sid, t[keep], seq[keep], meas.acc[keep, i], meas.gyr[keep, i], meas.mag_uT[keep, i],
                q_world_from_sensor=None if meas.q_world_from_sensor is None else meas.q_world_from_sensor[keep, i],
                device_time_s=meas.device_time_s[keep, i], segment=self.assignment.get(sid),
            )
        angles = {}
        for joint in self.model.joint_names:
            values = state["angles"].get(joint)
            for axis_index, axis in enumerate(("flexion", "adduction", "rotation")):
                angles[f"{joint}_{axis}_deg"] = np.zeros(n) if values is None else values[:n, axis_index].copy()
        truth = SuitTruth(
            t_s=t,
            q_world_from_segment={name: q[:n].copy() for name, q in state["segments"].items()},
            joint_angles_deg=angles,
            root_position_m=state["root"][:n],
            q_world_from_sensor={sid: q_now[:, i] for i, sid in enumerate(self.sensor_ids)},
            position_m={sid: p_now[:, i] for i, sid in enumerate(self.sensor_ids)},
            gyr_bias_rad_s={sid: meas.gyr_bias[:, i] for i, sid in enumerate(self.sensor_ids)},
            field_world_uT={sid: fields[:, i] for i, sid in enumerate(self.sensor_ids)},
            mag_axis_turned=state["axis_turned"][:n],
            held={sid: state["held"][:n, i] for i, sid in enumerate(self.sensor_ids)},
            foot_contact=state["contact"][:n].copy(),
        )
        t_start, t_end = k0 * self.dt, (k0 + n) * self.dt
        markers = [(start, label) for start, label in self.schedule.markers if t_start <= start < t_end]
        return SuitBlock(samples=samples, truth=truth, markers=markers)


def simulate_session(config: SimulationConfig = SimulationConfig()) -> SimulationResult:
    """Run ``config.scenario`` for ``config.duration_s`` seconds and return everything."""
    simulator = SuitSimulator(config, lookahead_s=0.0)
    blocks = []
    remaining = int(math.floor(config.duration_s * config.rate_hz + 1e-9))
    step = int(BATCH_CHUNK_S * config.rate_hz)
    while True:  # in chunks, to bound memory; identical to one block
        blocks.append(simulator.advance_samples(min(step, remaining)))
        remaining -= len(blocks[-1].truth.t_s)
        if remaining <= 0:
            break
    block = SuitBlock.concatenate(blocks)
    return SimulationResult(
        config=config, samples=block.samples, truth=block.truth, markers=block.markers,
        parameters=dict(simulator.parameters), mounting=dict(simulator.mounting),
        field_world_uT=simulator.field_world_uT, model_name=simulator.model.name, height_m=config.height_m,
        protocol=simulator.protocol,
    )
