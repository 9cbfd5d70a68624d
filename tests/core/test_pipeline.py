"""The one processing path: online blocks equal one batch, grouped filter calls equal each
sensor's own, poses are formed at one instant, and a recording processed as seen live gives
the live numbers."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core import rotation, skeleton
from mimucap.core.fusion import OrientationEKF
from mimucap.core.fusion.state import AX_N_MAG_OFFSET
from mimucap.core.magcal import MagCalibration
from mimucap.core.pipeline import (
    RESULT_LIVE, RESULT_REPROCESSED, ChainInput, LivePipeline, SensorChain, orientation_at,
    process_recording, run_chains, sensor_orientation, state_from_dict, state_to_dict,
)
from mimucap.core.samples import SensorSamples


def _block(rng, n, t0, mag=True):
    t = t0 + 0.01 * np.arange(1, n + 1)
    acc = np.array([0.0, 0.0, 9.81]) + 0.05 * rng.standard_normal((n, 3))
    field = (np.array([0.0, 20.0, -40.0]) + rng.standard_normal((n, 3))) if mag else None
    return t, 0.02 * rng.standard_normal((n, 3)), acc, field


def test_grouped_filter_calls_give_each_sensor_what_its_own_filter_gives():
    """Sensors with blocks of one length and channels share a filter call; a sensor with two
    blocks in a poll, or other channels, is fused on its own, in order."""
    rng = np.random.default_rng(3)
    polls = [[("a", 4, True), ("b", 4, True), ("c", 4, True), ("d", 4, False), ("e", 3, True)],
             [("a", 2, True), ("b", 2, True), ("a", 3, True), ("c", 5, True), ("d", 2, False), ("e", 2, True)]]
    chains = {name: SensorChain(name) for name in "abcde"}
    own = {name: OrientationEKF(use_mag=name != "d") for name in "abcde"}
    clock = {name: 0.0 for name in "abcde"}
    for poll in polls:
        inputs, expected = [], []
        for name, n, with_mag in poll:
            t, gyr, acc, mag = _block(rng, n, clock[name], with_mag)
            clock[name] = t[-1]
            inputs.append(ChainInput(chains[name], t, gyr, acc, mag))
            expected.append(own[name].update_batch(t, gyr, acc, mag))
        for out, want in zip(run_chains(inputs), expected):
            assert np.array_equal(out.q_world_from_sensor, want.q_world_from_sensor)
            assert np.array_equal(out.flags, want.flags)


def test_orientation_at_is_exact_at_samples_slerps_between_holds_after_and_is_absent_before():
    t = np.array([1.0, 2.0, 3.0])
    q = rotation.from_rotvec(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 2.0]]))
    got = orientation_at(np.array([0.5, 1.0, 1.5, 3.0, 9.0]), t, q)
    assert np.all(np.isnan(got[0]))
    assert np.array_equal(got[1], q[0]) and np.array_equal(got[3], q[2]) and np.array_equal(got[4], q[2])
    assert np.isclose(np.degrees(rotation.angle_between(got[2], q[0])), np.degrees(0.5))


def test_a_filter_state_survives_its_json_form_and_a_malformed_one_is_named():
    ekf = OrientationEKF()
    rng = np.random.default_rng(1)
    t, gyr, acc, mag = _block(rng, 50, 0.0)
    ekf.update_batch(t, gyr, acc, mag)
    state = state_from_dict(state_to_dict(ekf.state), "test")
    for a, b in zip((state.q_world_from_sensor, state.cov, state.aux), (ekf.state.q_world_from_sensor, ekf.state.cov, ekf.state.aux)):
        assert np.array_equal(a, b)
    with pytest.raises(ValueError, match="S07.*filter state"):
        state_from_dict({"q_world_from_sensor": [1, 0, 0]}, "S07")


def test_a_filter_state_stored_before_the_hard_iron_tracking_still_loads():
    """Recordings made before the layout grew hold the first 34 entries of ``aux``: the rest
    (the hard-iron offset and its fit) start at zero, and the filter runs on from the state."""
    ekf = OrientationEKF()
    rng = np.random.default_rng(1)
    t, gyr, acc, mag = _block(rng, 50, 0.0)
    ekf.update_batch(t, gyr, acc, mag)
    stored = state_to_dict(ekf.state)
    stored["aux"] = stored["aux"][:AX_N_MAG_OFFSET]
    state = state_from_dict(stored, "old")
    assert np.array_equal(state.aux[0, :AX_N_MAG_OFFSET], ekf.state.aux[0, :AX_N_MAG_OFFSET])
    assert not state.aux[0, AX_N_MAG_OFFSET:].any() and state.magnetic_offset() is None
    resumed = OrientationEKF(state=state).update_batch(t + 1.0, gyr, acc, mag)
    assert np.isfinite(resumed.q_world_from_sensor).all()
    with pytest.raises(ValueError, match="old.*aux"):
        state_from_dict({**stored, "aux": stored["aux"] + [0.0] * 100}, "old")


def _samples(sid, t, acc, gyr, mag):
    """A sensor's raw samples at times ``t``."""
    return SensorSamples(sid, t, np.arange(len(t)), acc, gyr, mag)


def test_a_new_magnetometer_calibration_keeps_the_running_filter_and_learns_its_field_anew():
    """The filter goes on from its orientation and gyro bias (a new one would re-align on one
    accelerometer sample and forget the bias); only the heading and the field it learned start
    over."""
    rng = np.random.default_rng(5)
    chain = SensorChain("S01")
    t, gyr, acc, mag = _block(rng, 200, 0.0)
    chain.filter_for(True).update_batch(t, gyr, acc, chain.calibrated_mag(mag))
    ekf = chain.ekf
    q, bias = ekf.state.q_world_from_sensor.copy(), ekf.state.bias_rad_s.copy()
    assert ekf.state.magnetic_reference(0) is not None
    chain.set_mag_calibration(MagCalibration("S01", np.array([3.0, -2.0, 1.0]), np.eye(3), 45.0))
    assert chain.ekf is ekf
    assert np.array_equal(ekf.state.q_world_from_sensor, q) and np.array_equal(ekf.state.bias_rad_s, bias)
    assert ekf.state.magnetic_reference(0) is None
    assert np.degrees(ekf.state.attitude_std_rad(0)[2]) > 90.0
    with pytest.raises(ValueError, match="S02"):
        chain.set_mag_calibration(MagCalibration("S02", np.zeros(3), np.eye(3), 45.0))


def _suit_recording(seconds=6.0, seed=2):
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.core.simulate.suit import simulate_session

    result = simulate_session(SimulationConfig(scenario="walk", duration_s=seconds, seed=seed, n_sensors=10))
    return result


def test_blocks_fed_live_give_the_recording_processed_as_seen_live():
    """The live pipeline fed a recording in blocks, from a filter state taken mid-way (as a
    recording that starts after the live view), and the batch path from that state give the
    same sensor orientations and joint angles at the live poses' instants."""
    from mimucap.core.simulate.config import SENSOR_PLACEMENTS

    result = _suit_recording()
    model = skeleton.load_model("ten_segment")
    segments = {sid: seg for sid, seg, _a, _b in SENSOR_PLACEMENTS if sid in result.samples}
    calibration = MagCalibration("S01", np.array([3.0, -2.0, 1.0]), np.eye(3), 50.0)
    live = LivePipeline(model)
    live.set_mag_calibration(calibration)
    split = 150  # the recording starts at this sample
    streams, states, poses = {}, None, []
    n = len(result.samples["S01"].t_s)
    for start in range(0, n, 7):
        if start >= split and states is None:
            states = live.filter_states()
        blocks = []
        for sid, samples in result.samples.items():
            sl = slice(start, min(start + 7, n))
            blocks.append(SensorSamples(sid, samples.t_s[sl], samples.seq[sl], samples.acc[sl], samples.gyr[sl],
                                        samples.mag_uT[sl]))
        live.feed(blocks)
        pose = live.pose(None, segments)
        if pose is not None and start >= split:
            poses.append(pose)
    for sid, samples in result.samples.items():
        k = slice(split - split % 7 + (7 if split % 7 else 0), None)
        streams[sid] = _samples(sid, samples.t_s[k], samples.acc[k], samples.gyr[k], samples.mag_uT[k])
    initial = {sid: state_from_dict(state, sid) for sid, state in states.items()}
    out = process_recording(streams, model, result=RESULT_LIVE, mag_calibrations={"S01": calibration},
                            sensor_segments=segments, initial_states=initial)
    assert len(poses) > 20
    worst = 0.0
    for t_pose, q_segments in poses[1:]:
        index = int(np.searchsorted(out.t_s, t_pose))
        assert out.t_s[index] == t_pose
        for name, q in q_segments.items():
            worst = max(worst, float(np.degrees(rotation.angle_between(q, out.q_world_from_segment[name][index]))))
    assert worst < 1e-6
    smoothed = process_recording(streams, model, result=RESULT_REPROCESSED, mag_calibrations={"S01": calibration},
                                 sensor_segments=segments)
    assert smoothed.result == RESULT_REPROCESSED and smoothed.t_s.shape == out.t_s.shape
    assert not np.allclose(smoothed.q_world_from_sensor["S02"], out.q_world_from_sensor["S02"])


def test_a_sensor_without_gyroscope_or_orientation_is_named():
    with pytest.raises(ValueError, match="S04"):
        sensor_orientation(np.arange(3.0), None, np.zeros((3, 3)), None, None, sensor_id="S04")
    out = process_recording({"S04": _samples("S04", np.arange(3.0), np.zeros((3, 3)), None, None)},
                            skeleton.load_model("ten_segment"), sensor_segments={"S04": "pelvis"})
    assert out.problems and "S04" in out.problems[0] and len(out.t_s) == 0
