"""The simulated suit: physics of its measurements, consistency of its truth, streaming == batch."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.core import skeleton
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.magnetic_field import MagneticDisturbance
from mimucap.core.simulate.sensor_errors import ACC_DIFF_STEP_S, IDEAL_SENSOR, SensorErrorModel
from mimucap.core.simulate.suit import SuitSimulator, simulate_session
from mimucap.core.simulate.truth import SuitBlock
from mimucap.core.simulate.gait_design import LegGeometry
from mimucap.core.simulate.walking import Walk

NO_GYRO_ERRORS = dataclasses.replace(
    SensorErrorModel(), gyr_bias_dps=(0.0, 0.0), gyr_bias_walk_dps_per_sqrt_s=0.0, gyr_noise_dps=0.0, gyr_scale_error=0.0
)


@pytest.fixture(scope="module")
def demo17():
    return simulate_session(SimulationConfig(scenario="demo", duration_s=50.0, n_sensors=17, seed=3, errors=NO_GYRO_ERRORS))


def test_gyroscope_integrates_to_the_true_orientation(demo17) -> None:
    dt = 1.0 / demo17.config.rate_hz
    for sensor_id in ("S01", "S06", "S10", "S14"):
        truth = demo17.truth.q_world_from_sensor[sensor_id]
        gyr = demo17.samples[sensor_id].gyr
        increments = rot.from_rotvec(gyr[1:] * dt)
        q = truth[0]
        worst = 0.0
        for k in range(1, len(gyr)):
            q = rot.multiply(q, increments[k - 1])
            if k % 50 == 0 or k == len(gyr) - 1:
                worst = max(worst, float(rot.angle_between(q, truth[k])))
        assert np.degrees(worst) < 1e-6, sensor_id


def test_joint_angle_truth_is_what_the_skeleton_measures(demo17) -> None:
    model = skeleton.load_model(demo17.model_name)
    measured = skeleton.joint_angles_deg(model, demo17.truth.q_world_from_segment)
    assert set(measured) == set(demo17.truth.joint_angles_deg) == set(skeleton.joint_angle_columns(model))
    for column, values in measured.items():
        np.testing.assert_allclose(values, demo17.truth.joint_angles_deg[column], atol=1e-8, err_msg=column)


def test_sensor_truth_follows_segment_and_mounting(demo17) -> None:
    for sensor_id, mounting in demo17.mounting.items():
        q_segment = demo17.truth.q_world_from_segment[mounting.segment]
        expected = rot.multiply(q_segment, mounting.q_segment_from_sensor)
        assert np.degrees(rot.angle_between(expected, demo17.truth.q_world_from_sensor[sensor_id]).max()) < 1e-9
    assert [demo17.mounting[s].segment for s in ("S11", "S12", "S13", "S14", "S15", "S16", "S17")] == [
        "head", "hand_l", "hand_r", "foot_l", "foot_r", "thorax", "pelvis"]


def test_demo_runs_through_its_activities(demo17) -> None:
    labels = [label for _, label in demo17.markers]
    assert labels[:9] == ["N-pose", "T-pose", "N-pose", "walk", "turn", "walk", "turn", "squat", "arm raise"]
    assert labels[9] == "N-pose"  # the demo loops
    t = demo17.truth.t_s
    angles = demo17.truth.joint_angles_deg
    in_tpose = (t > 4.8) & (t < 6.0)
    np.testing.assert_allclose(angles["shoulder_r_adduction_deg"][in_tpose], -88.0, atol=1e-6)
    np.testing.assert_allclose(angles["shoulder_l_adduction_deg"][in_tpose], -88.0, atol=1e-6)


def test_walking_has_realistic_curves_and_pace(demo17) -> None:
    t = demo17.truth.t_s
    walking = (t > 10.0) & (t < 15.25)  # five strides of steady walking
    angles = demo17.truth.joint_angles_deg
    hip = angles["hip_r_flexion_deg"][walking]
    knee = angles["knee_r_flexion_deg"][walking]
    shoulder = angles["shoulder_r_flexion_deg"][walking]
    assert 27 < hip.max() < 33 and -13 < hip.min() < -7
    assert 55 < knee.max() < 65 and 0 <= knee.min() < 8
    assert 15 < shoulder.max() - 3 < 25 and -25 < shoulder.min() - 3 < -15
    assert np.corrcoef(hip, shoulder)[0, 1] < -0.9  # the arm swings against its own leg
    # Two knee-flexion peaks per stride: the loading response (~17°) and swing (~60°).
    peaks = knee[1:-1][(knee[1:-1] > knee[:-2]) & (knee[1:-1] >= knee[2:])]
    assert np.sum((peaks > 14) & (peaks < 22)) >= 4 and np.sum(peaks > 55) >= 4
    root = demo17.truth.root_position_m[walking]
    speed = np.linalg.norm(root[-1, :2] - root[0, :2]) / (t[walking][-1] - t[walking][0])
    assert speed == pytest.approx(1.2, abs=0.02)
    assert 0.02 < np.ptp(root[:, 2]) < 0.06


def _run_lengths(mask: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For every sample: time (s) since the current run of True in ``mask`` began, and until it
    ends (inf outside a run)."""
    since, until = np.full(t.shape, np.inf), np.full(t.shape, np.inf)
    start = end = None
    for i in range(t.shape[0]):
        start = (t[i] if start is None or not mask[i - 1] else start) if mask[i] else None
        since[i] = t[i] - start if start is not None else np.inf
    for i in range(t.shape[0] - 1, -1, -1):
        end = (t[i] if end is None or not mask[i + 1] else end) if mask[i] else None
        until[i] = end - t[i] if end is not None else np.inf
    return since, until


def test_a_foot_on_the_floor_does_not_slide() -> None:
    """A point of the sole pressed into the floor does not slide (but for the few milliseconds in
    which the floor stops it and in which its pad lets go); the foot is on the floor (contact
    truth) exactly while one of them is, and in the air the sole is above the floor; the pelvis
    moves on at a fluctuating speed averaging 1.2 m/s."""
    result = simulate_session(SimulationConfig(scenario="walk", duration_s=9.0, n_sensors=15, seed=1, errors=IDEAL_SENSOR,
                                               rate_hz=1000.0))
    model = skeleton.load_model(result.model_name)
    geometry = LegGeometry.of(model, result.height_m)
    poses = skeleton.forward_kinematics(model, result.truth.q_world_from_segment, result.height_m,
                                        result.truth.root_position_m)
    t = result.truth.t_s
    dt = t[1] - t[0]
    steady = t > 3.0
    for column, side in ((0, "l"), (1, "r")):
        on = result.truth.foot_contact[:, column] > 0.5
        ankle, q_foot = poses[f"shank_{side}"].distal_m, poses[f"foot_{side}"].q_world_from_segment
        lowest = np.full(t.shape, np.inf)
        for point in (geometry.heel_m, geometry.toe_m):
            sole = ankle + rot.rotate(q_foot, point)
            lowest = np.minimum(lowest, sole[:, 2])
            sliding = np.linalg.norm(np.gradient(sole[:, :2], dt, axis=0), axis=1)
            pressed = sole[:, 2] <= 0.0
            since, until = _run_lengths(pressed, t)
            planted = steady & pressed & (since > 0.03) & (until > 0.015)
            assert planted.sum() > 500
            assert sliding[planted].max() < 0.002
        grounded = lowest <= 0.0
        edges = [t[1:][steady[1:] & (mask[1:] != mask[:-1])] for mask in (on, grounded)]
        np.testing.assert_allclose(edges[0], edges[1], atol=1.5 * dt)
    root_speed = np.linalg.norm(np.gradient(result.truth.root_position_m[:, :2], dt, axis=0), axis=1)[steady]
    assert 0.6 < root_speed.min() < 1.1 < 1.3 < root_speed.max() < 1.8


def _specific_force_world(result, sensor_id: str) -> np.ndarray:
    """The measured specific force (n-1, 3) in the world frame, samples 1..n-1: each sample is the
    interval's mean seen from the sensor at mid-interval (ideal sensor, no sample dropped)."""
    q = result.truth.q_world_from_sensor[sensor_id]
    return rot.rotate(rot.slerp(q[:-1], q[1:], 0.5), result.samples[sensor_id].acc[1:])


def test_accelerometer_averages_to_gravity_over_whole_strides() -> None:
    result = simulate_session(SimulationConfig(scenario="walk", duration_s=13.0, n_sensors=10, seed=1, errors=IDEAL_SENSOR))
    t = result.truth.t_s[1:]
    stride = Walk().fit_body("ten_segment", 1.75).stride_s
    window = (t >= 4.0) & (t < 4.0 + 8 * stride)  # velocity is periodic: mean acceleration zero
    for sensor_id in ("S01", "S08", "S10", "S06"):
        acc_world = _specific_force_world(result, sensor_id)[window]
        np.testing.assert_allclose(acc_world.mean(axis=0), [0.0, 0.0, 9.81], atol=0.02, err_msg=sensor_id)
        assert np.abs(acc_world[:, 2] - 9.81).max() > 1.0  # but the segment does accelerate


def test_accelerometer_integrates_to_the_velocity_of_the_true_positions() -> None:
    """Δv from adding up the measured specific force (minus gravity) over 0.5 s windows equals
    the change of the velocity of the true sensor position between the windows' ends (each
    sample is its interval's mean: impacts included, nothing is missed between samples)."""
    config = SimulationConfig(scenario="demo", duration_s=40.0, n_sensors=15, seed=6, errors=IDEAL_SENSOR)
    result = simulate_session(config)
    dt = 1.0 / config.rate_hz
    simulator = SuitSimulator(config, lookahead_s=0.0)
    h = ACC_DIFF_STEP_S  # the simulator's velocity: mean over the last h
    ends = np.arange(0, len(result.truth.t_s) - 1, 50)
    times = result.truth.t_s[ends]
    state = simulator.kinematics(np.concatenate((times, times - h)))
    velocity = (state["p_sensor"][:len(times)] - state["p_sensor"][len(times):]) / h  # (windows, sensors, 3)
    for sensor_id in ("S01", "S06", "S10", "S14"):
        index = simulator.sensor_ids.index(sensor_id)
        acc = _specific_force_world(result, sensor_id) - np.array([0.0, 0.0, 9.81])  # samples 1..n-1
        delta_v = np.add.reduceat(acc[ends[0]:ends[-1]], ends[:-1] - ends[0], axis=0) * dt
        expected = np.diff(velocity[:, index], axis=0)
        np.testing.assert_allclose(delta_v, expected, atol=1e-3, err_msg=sensor_id)


def test_a_sensor_at_rest_reads_gravity_and_the_configured_field() -> None:
    errors = dataclasses.replace(IDEAL_SENSOR, mag_hard_iron_uT=40.0, mag_soft_iron_scale=0.1, mag_soft_iron_cross=0.05)
    config = SimulationConfig(scenario="npose", duration_s=2.0, n_sensors=10, seed=2, errors=errors,
                              scenario_params={"sway_deg": 0.0})
    result = simulate_session(config)
    for sensor_id, samples in result.samples.items():
        q = result.truth.q_world_from_sensor[sensor_id]
        np.testing.assert_allclose(rot.rotate(q, samples.acc), np.tile([0, 0, 9.81], (len(q), 1)), atol=1e-6)
        params = result.parameters[sensor_id]
        mag = np.linalg.solve(params.mag_A, (samples.mag_uT - params.mag_b_uT).T).T
        world = rot.rotate(q, mag)
        np.testing.assert_allclose(np.linalg.norm(world, axis=1), 49.3, atol=1e-9)
        dip = np.degrees(np.arctan2(-world[:, 2], np.hypot(world[:, 0], world[:, 1])))
        np.testing.assert_allclose(dip, 60.0, atol=1e-9)
        assert np.abs(samples.gyr).max() < 1e-9


def test_blocks_concatenate_to_exactly_the_batch() -> None:
    config = SimulationConfig(scenario="demo", duration_s=14.0, n_sensors=17, seed=5, drop_probability=0.05,
                              errors=dataclasses.replace(SensorErrorModel(), onboard_orientation=True, mag_lsb_uT=0.15),
                              disturbances=(MagneticDisturbance((30.0, 0.0, -10.0), 5.0, 7.0, center_m=(0.0, 0.4, 1.0)),))
    batch = simulate_session(config)
    simulator = SuitSimulator(config, lookahead_s=0.3)
    rng = np.random.default_rng(0)
    blocks = []
    while simulator.time_s < config.duration_s - 1e-9:
        blocks.append(simulator.advance(min(float(rng.uniform(0.0, 0.9)), config.duration_s - simulator.time_s)))
    joined = SuitBlock.concatenate(blocks)
    assert joined.markers == batch.markers
    assert len(simulator.schedule.entries) < len(batch.markers)  # finished activities are forgotten
    for sensor_id, expected in batch.samples.items():
        got = joined.samples[sensor_id]
        for name in ("t_s", "seq", "acc", "gyr", "mag_uT", "q_world_from_sensor", "device_time_s"):
            np.testing.assert_array_equal(getattr(got, name), getattr(expected, name), err_msg=f"{sensor_id} {name}")
        assert len(expected.t_s) < len(batch.truth.t_s)  # packets were dropped
        assert np.all(np.diff(expected.seq) >= 1)
    for name in ("q_world_from_segment", "joint_angles_deg", "q_world_from_sensor", "position_m", "gyr_bias_rad_s",
                 "field_world_uT"):
        for key, value in getattr(batch.truth, name).items():
            np.testing.assert_array_equal(getattr(joined.truth, name)[key], value, err_msg=f"{name} {key}")
    np.testing.assert_array_equal(joined.truth.root_position_m, batch.truth.root_position_m)
    disturbed = batch.truth.field_world_uT["S02"] - batch.field_world_uT
    t = batch.truth.t_s
    assert np.abs(disturbed[(t > 8.0)]).max() < 1e-12 and np.abs(disturbed[(t > 5.6) & (t < 6.4)]).max() > 1.0


def test_same_seed_same_data_other_seed_differs() -> None:
    config = SimulationConfig(scenario="walk", duration_s=2.0, seed=11)
    a, b = simulate_session(config), simulate_session(config)
    c = simulate_session(dataclasses.replace(config, seed=12))
    np.testing.assert_array_equal(a.samples["S03"].mag_uT, b.samples["S03"].mag_uT)
    assert not np.array_equal(a.samples["S03"].mag_uT, c.samples["S03"].mag_uT)
    params = a.parameters["S03"]
    samples = a.samples["S03"]
    np.testing.assert_allclose(samples.device_time_s, (1 + params.clock_drift) * samples.t_s + params.clock_offset_s)


def test_switching_activities_gives_the_same_data_for_any_block_partition() -> None:
    """With the same switches at the same times, how the time is cut into blocks does not
    matter, even with overlapping blends, hand-held bundles and forgotten activities."""
    plan = [(1.0, "walk", {}), (2.5, "mag_tumble", {"sensor_ids": ["S02", "S05"]}), (2.9, "turn", {}),
            (3.2, "mag_single_axis", {}), (5.0, "squat", {}), (5.3, "tpose", {"arms": "left"}), (8.0, "demo", {})]
    end_s = 11.0
    runs = []
    for seed in (0, 1):
        simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=9, drop_probability=0.1),
                                  lookahead_s=0.7 * seed)
        rng = np.random.default_rng(seed)
        blocks = []
        for until, name, params in plan + [(end_s, None, None)]:
            while simulator.time_s < until - 1e-9:
                blocks.append(simulator.advance(min(float(rng.uniform(0.01, 0.4)), until - simulator.time_s)))
            if name is not None:
                simulator.set_activity(name, **params)
        runs.append(SuitBlock.concatenate(blocks))
    first, second = runs
    assert first.markers == second.markers and len(first.markers) >= len(plan)
    for sensor_id, samples in first.samples.items():
        for name in ("t_s", "seq", "acc", "gyr", "mag_uT"):
            np.testing.assert_array_equal(getattr(second.samples[sensor_id], name), getattr(samples, name))
        np.testing.assert_array_equal(second.truth.q_world_from_sensor[sensor_id], first.truth.q_world_from_sensor[sensor_id])
    for column, values in first.truth.joint_angles_deg.items():
        np.testing.assert_array_equal(second.truth.joint_angles_deg[column], values)


def test_set_activity_blends_smoothly_into_a_right_t_pose() -> None:
    simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=1, errors=IDEAL_SENSOR))
    before = simulator.advance(1.0)
    simulator.set_activity("tpose", arms="right")
    assert simulator.current_activity() == "tpose(right)"
    after = simulator.advance(3.0)
    joined = SuitBlock.concatenate([before, after])
    angles = joined.truth.joint_angles_deg
    t = joined.truth.t_s
    np.testing.assert_allclose(angles["shoulder_r_adduction_deg"][t > 3.0], -88.0, atol=1e-6)
    np.testing.assert_allclose(angles["shoulder_l_adduction_deg"], 0.0, atol=1e-12)
    step = rot.angle_between(joined.truth.q_world_from_sensor["S06"][1:], joined.truth.q_world_from_sensor["S06"][:-1])
    assert np.degrees(step).max() < 2.0  # no jump: at most 200 °/s at 100 Hz
    assert after.markers == [(1.0, "T-pose (right arm)")]
    with pytest.raises(ValueError, match="arms must be right, left or both"):
        simulator.set_activity("tpose", arms="up")
    with pytest.raises(ValueError, match="unknown activity 'dance'"):
        simulator.set_activity("dance")
    assert simulator.current_activity() == "tpose(right)"  # a refused request changes nothing


def test_held_sensors_turn_together_about_the_reported_axis() -> None:
    simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=4, errors=IDEAL_SENSOR))
    simulator.advance(0.5)
    simulator.set_activity("mag_single_axis", sensor_ids=["S03", "S09", "S10"])
    block = simulator.advance(26.0)
    truth = block.truth
    settled = truth.t_s > 1.5
    assert np.all(truth.held["S03"][settled] == 1.0) and np.all(truth.held["S01"] == 0.0)
    relative = rot.angle_between(truth.q_world_from_sensor["S03"][settled], truth.q_world_from_sensor["S10"][settled])
    assert 0.2 < np.degrees(relative).max() < 8.0  # held together, with a small misalignment
    axes = [int(a) for a in truth.mag_axis_turned if a >= 0]
    assert [a for i, a in enumerate(axes) if i == 0 or axes[i - 1] != a] == [0, 1, 2]
    gyr = block.samples["S09"].gyr
    for axis in range(3):
        turning = truth.mag_axis_turned == axis
        about = np.abs(gyr[turning, axis]).mean()
        assert about > 3.0 * np.abs(np.delete(gyr[turning], axis, axis=1)).mean()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_picking_sensors_up_and_putting_them_back_is_smooth(seed: int) -> None:
    """Worn → hand-held → worn never jumps, even when the two orientations are nearly opposite."""
    simulator = SuitSimulator(SimulationConfig(scenario="walk", n_sensors=17, seed=seed, errors=IDEAL_SENSOR))
    blocks = [simulator.advance(2.0)]
    simulator.set_activity("mag_figure8")
    blocks.append(simulator.advance(4.3))
    simulator.set_activity("walk")
    blocks.append(simulator.advance(2.5))
    joined = SuitBlock.concatenate(blocks)
    for sensor_id, samples in joined.samples.items():
        q = joined.truth.q_world_from_sensor[sensor_id]
        # At most ~12 rad/s (a swinging foot); a flip between nearly opposite orientations
        # would show as a step of well over 90°.
        assert np.degrees(rot.angle_between(q[1:], q[:-1])).max() < 8.0, sensor_id
        assert np.abs(samples.gyr).max() < 14.0, sensor_id
        assert np.linalg.norm(np.diff(joined.truth.position_m[sensor_id], axis=0), axis=1).max() < 0.08  # < 8 m/s


def test_configuration_errors_are_clear() -> None:
    with pytest.raises(ValueError, match="unknown scenario 'jog'"):
        SimulationConfig(scenario="jog")
    with pytest.raises(ValueError, match="number of sensors must be 1..17"):
        SimulationConfig(n_sensors=18)
    with pytest.raises(ValueError, match="sample rate"):
        SimulationConfig(rate_hz=5.0)
    with pytest.raises(ValueError, match="walking speed"):
        SimulationConfig(scenario="walk", scenario_params={"speed_mps": 9.0})
    with pytest.raises(ValueError, match="activity 'walk'.*sped"):
        SimulationConfig(scenario="walk", scenario_params={"sped": 1.0})
    with pytest.raises(ValueError, match="unknown sensor id.*S12"):
        SimulationConfig(scenario="mag_figure8", scenario_params={"sensor_ids": ["S01", "S12"]})
    with pytest.raises(ValueError, match="unknown sensor id"):
        SuitSimulator(SimulationConfig(n_sensors=2)).set_activity("mag_tumble", sensor_ids=["S09"])


def test_the_heel_lands_as_winter_measured_and_the_toe_clears_the_floor() -> None:
    """The heel arrives moving forward, slowly downward (Winter 1992: 0.87 m/s and negligible),
    and the swinging toe clears the floor by at least his 1.29 cm."""
    design = Walk().design
    for side, velocity in design.landing_velocity_m_s.items():
        assert 0.3 < velocity[1] < 1.0, side  # walking frame: y forward
        assert -0.1 < velocity[2] < 0.0, side
    assert design.min_toe_clearance_m >= 0.0129 - 1e-6


def test_the_heel_strike_is_a_transient_of_a_few_g_at_foot_and_shank() -> None:
    """At heel strike the floor stops the foot within milliseconds: sampled at 1 kHz by ideal
    sensors, the foot and the shank feel a few g more than gravity, the pelvis well under 1 g
    (Light, McLellan & Klenerman 1980: about 5 g at the tibia, 0.5 g at the head with hard
    heels); the transient is over within 40 ms."""
    result = simulate_session(SimulationConfig(scenario="walk", duration_s=6.0, n_sensors=15, seed=2, errors=IDEAL_SENSOR,
                                               rate_hz=1000.0))
    t = result.truth.t_s
    on = result.truth.foot_contact[:, 1] > 0.5
    strikes = t[np.flatnonzero(~on[:-1] & on[1:]) + 1]
    strikes = strikes[strikes > 3.0]
    assert strikes.size >= 2
    for sensor_id, low_g, high_g in (("S15", 2.0, 8.0), ("S10", 2.0, 8.0), ("S01", 0.0, 1.0)):
        magnitude = np.linalg.norm(result.samples[sensor_id].acc, axis=1) / 9.81
        for strike in strikes:
            before = magnitude[(t >= strike - 0.05) & (t < strike)]
            during = magnitude[(t >= strike) & (t < strike + 0.04)]
            peak = np.abs(during - 1.0).max()
            assert low_g < peak < high_g, (sensor_id, strike, peak)
            assert np.abs(before - 1.0).max() < peak  # the strike, not the swing, is the largest
