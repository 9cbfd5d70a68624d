"""The one processing path: online blocks equal one batch, grouped filter calls equal each
sensor's own, poses are formed at one instant, and a recording processed as seen live gives
the live numbers."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from mimucap.core import rotation, skeleton
from mimucap.core.fusion import OrientationEKF
from mimucap.core.fusion.state import AX_N_MAG_OFFSET
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.pipeline.chain import SensorChain, update_chains
from mimucap.core.pipeline.instants import orientation_at
from mimucap.core.pipeline.live import LivePipeline
from mimucap.core.pipeline.recording import process_recording
from mimucap.core.pipeline.settings import RESULT_LIVE, RESULT_REPROCESSED, state_from_dict, state_to_dict
from mimucap.core.sensor_samples import SensorSamples


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
            inputs.append((chains[name], SensorSamples(name, t, np.arange(n), acc, gyr, mag)))
            expected.append(own[name].update_batch(t, gyr, acc, mag))
        for out, want in zip(update_chains(*zip(*inputs)), expected):
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
    chain.update(SensorSamples("S01", t, np.arange(len(t)), acc, gyr, mag))
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
        SensorChain("S04").process(SensorSamples("S04", np.arange(3.0), np.arange(3), acc=np.zeros((3, 3))))
    out = process_recording({"S04": _samples("S04", np.arange(3.0), np.zeros((3, 3)), None, None)},
                            skeleton.load_model("ten_segment"), sensor_segments={"S04": "pelvis"})
    assert out.problems and "S04" in out.problems[0] and len(out.t_s) == 0


APP = Path(__file__).resolve().parents[2] / "app" / "mimucap"
#: What makes an orientation filter: the filter object, and the filter's own batch functions.
FILTER_MAKERS = {"OrientationEKF", "fuse", "fuse_offline"}


def filter_makers_called(path: Path) -> list[str]:
    """``name (line)`` of every call in ``path`` that makes an orientation filter."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Call):
            func = node.func
            name = func.id if isinstance(func, ast.Name) else func.attr if isinstance(func, ast.Attribute) else ""
            if name in FILTER_MAKERS:
                found.append(f"{name} (line {node.lineno})")
    return found


def test_the_chain_is_the_only_place_of_the_application_that_makes_a_filter():
    """Live view, wizards, review, export and every command go through
    :class:`~mimucap.core.pipeline.chain.SensorChain`; only the filter's own package (its batch
    functions and the kernels' warm-up) makes filters besides."""
    makers = {str(path.relative_to(APP)): filter_makers_called(path) for path in sorted(APP.rglob("*.py"))
              if "fusion" not in path.relative_to(APP).parts}
    assert {name for name, calls in makers.items() if calls} == {"core/pipeline/chain.py"}


def test_the_filter_maker_scan_sees_a_filter_made_in_a_function(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text("from mimucap.core.fusion import offline\n\ndef f(t, g):\n    return offline.fuse_offline(t, g)\n")
    assert filter_makers_called(probe) == ["fuse_offline (line 4)"]


def test_a_recording_through_the_chain_gives_the_filter_s_own_forward_and_smoothed_results():
    """Fed in blocks for its doubt, with the smoother's storage kept block by block, the chain
    gives bitwise what the filter's batch functions give over the whole recording at once."""
    from mimucap.core.fusion.ekf import fuse
    from mimucap.core.fusion.offline import fuse_offline

    rng = np.random.default_rng(11)
    t, gyr, acc, mag = _block(rng, 1000, 0.0)
    samples = SensorSamples("S01", t, np.arange(len(t)), acc, gyr, mag)
    forward = SensorChain("S01").process(samples, RESULT_LIVE)
    smoothed = SensorChain("S01").process(samples, RESULT_REPROCESSED)
    assert np.array_equal(forward.q_world_from_sensor, fuse(t, gyr, acc, mag).q_world_from_sensor)
    assert np.array_equal(smoothed.q_world_from_sensor, fuse_offline(t, gyr, acc, mag).q_world_from_sensor)
    assert not np.array_equal(forward.q_world_from_sensor, smoothed.q_world_from_sensor)
    quiet = SensorChain("S01", doubt=False).process(samples, RESULT_REPROCESSED)
    assert quiet.doubt is None and np.array_equal(quiet.q_world_from_sensor, smoothed.q_world_from_sensor)


def test_the_chain_reports_the_heading_uncertainty_and_a_magnetometer_free_orientation_alike_live_and_batch():
    """What a stage that looks at several sensors needs, per sample: the heading's standard
    deviation, and the orientation of a filter that never uses the magnetometer. At 60 s the
    field turns 40° about the vertical (magnitude and dip kept, so the filter follows it): the
    magnetometer-free heading keeps to the gyroscope, the other turns with the field."""
    rng = np.random.default_rng(4)
    n = 9000
    t = 0.01 * np.arange(1, n + 1)
    turn = np.where(t >= 60.0, np.radians(40.0), 0.0)
    field = np.stack([20.0 * np.sin(turn), 20.0 * np.cos(turn), np.full(n, -40.0)], axis=1)
    acc = np.array([0.0, 0.0, 9.81]) + 0.02 * rng.standard_normal((n, 3))
    gyr = 0.002 * rng.standard_normal((n, 3))
    samples = SensorSamples("S01", t, np.arange(n), acc, gyr, field + 0.2 * rng.standard_normal((n, 3)))
    batch = SensorChain("S01", magnetometer_free=True).process(samples, RESULT_LIVE)
    live_chain = SensorChain("S01", magnetometer_free=True)
    parts = [live_chain.update(samples.rows(slice(start, start + 5))) for start in range(0, n, 5)]
    live_free = np.concatenate([part.q_world_from_sensor_no_mag for part in parts])
    assert np.array_equal(live_free, batch.q_world_from_sensor_no_mag)
    assert np.all(np.isfinite(batch.heading_std_rad))
    assert np.degrees(batch.heading_std_rad[-1]) < 5.0 < np.degrees(batch.heading_std_rad[0])

    def yaw(q):  # heading of the sensor's x axis, degrees
        x = rotation.rotate(q, np.array([1.0, 0.0, 0.0]))
        return np.degrees(np.arctan2(x[..., 1], x[..., 0]))

    with_mag, without = yaw(batch.q_world_from_sensor), yaw(batch.q_world_from_sensor_no_mag)
    end = t > 85.0
    assert abs(np.mean(with_mag[end]) - np.mean(with_mag[(t > 40.0) & (t < 59.0)])) > 20.0
    assert abs(np.mean(without[end]) - np.mean(without[(t > 40.0) & (t < 59.0)])) < 2.0
    assert live_chain.ekf_no_mag is not None and not live_chain.ekf_no_mag.use_mag


class _TurnSensor:
    """A joint coupling for the tests: turns one sensor by a fixed heading, and counts the
    instants it was given."""

    def __init__(self, sensor_id: str, degrees: float) -> None:
        self.sensor_id = sensor_id
        self.q = rotation.from_rotvec(np.array([0.0, 0.0, np.radians(degrees)]))
        self.instants = 0

    def couple(self, instants, stage):
        from dataclasses import replace

        assert stage.segment_of_sensor[self.sensor_id] == "thigh_r"
        self.instants += np.size(instants.t_s)
        q = dict(instants.q_world_from_sensor)
        q[self.sensor_id] = rotation.multiply(self.q, q[self.sensor_id])
        return replace(instants, q_world_from_sensor=q)


def test_a_joint_coupling_acts_between_the_sensors_and_the_segments_live_and_in_a_recording_alike():
    """The segment stage takes every sensor at the same instants, with the chains' flags and
    heading uncertainty; a coupling put there changes the segments (and so the joint angles) of
    the live pose and of the recording's batch processing in the same way."""
    from mimucap.core.simulate.config import SENSOR_PLACEMENTS

    result = _suit_recording(seconds=3.0)
    model = skeleton.load_model("ten_segment")
    segments = {sid: seg for sid, seg, _a, _b in SENSOR_PLACEMENTS if sid in result.samples}
    thigh = next(sid for sid, seg in segments.items() if seg == "thigh_r")
    plain = process_recording(result.samples, model, result=RESULT_LIVE, sensor_segments=segments)
    batch_coupling = _TurnSensor(thigh, 30.0)
    coupled = process_recording(result.samples, model, result=RESULT_LIVE, sensor_segments=segments,
                                coupling=batch_coupling)
    assert batch_coupling.instants == len(coupled.t_s) > 100
    turned = np.degrees(rotation.angle_between(coupled.q_world_from_segment["thigh_r"], plain.q_world_from_segment["thigh_r"]))
    assert np.allclose(turned, 30.0, atol=1e-6)
    assert np.array_equal(coupled.q_world_from_segment["shank_r"], plain.q_world_from_segment["shank_r"])
    live_coupling = _TurnSensor(thigh, 30.0)
    live = LivePipeline(model, coupling=live_coupling)
    n = len(result.samples["S01"].t_s)
    poses = []
    for start in range(0, n, 7):
        live.feed([samples.rows(slice(start, start + 7)) for samples in result.samples.values()])
        pose = live.pose(None, segments)
        if pose is not None:
            poses.append(pose)
    # live, the coupling is given every instant once, whether a pose is shown there or not
    assert len(poses) > 20
    assert live_coupling.instants == int(np.count_nonzero(coupled.t_s <= poses[-1][0]))
    for t_pose, q_segments in poses:
        index = int(np.searchsorted(coupled.t_s, t_pose))
        assert coupled.t_s[index] == t_pose
        assert np.degrees(rotation.angle_between(q_segments["thigh_r"], coupled.q_world_from_segment["thigh_r"][index])) < 1e-6


def test_every_sensor_at_one_instant_carries_what_the_chains_report():
    from mimucap.core.pipeline.instants import LiveTrack, SensorTrack, live_sensors_at, sensors_at_instants

    t = np.array([1.0, 2.0, 3.0])
    q = rotation.from_rotvec(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 2.0]]))
    flags = np.array([0, 4, 0], dtype=np.uint8)
    heading = np.array([0.3, 0.2, 0.1])
    track = SensorTrack.finite(t, q, flags, heading, q)
    at = sensors_at_instants(np.array([0.5, 2.0, 2.5, 9.0]), {"S1": track})
    assert list(at.flags["S1"]) == [0, 4, 4, 0]
    np.testing.assert_array_equal(at.heading_std_rad["S1"], [np.nan, 0.2, 0.2, 0.1])
    np.testing.assert_array_equal(at.q_world_from_sensor_no_mag["S1"], at.q_world_from_sensor["S1"])
    live = LiveTrack()
    live.add(t, q, flags, heading, q)
    one = live_sensors_at(2.5, {"S1": live})
    assert one.flags["S1"] == 4 and one.heading_std_rad["S1"] == 0.2
    assert np.degrees(rotation.angle_between(one.q_world_from_sensor["S1"], at.q_world_from_sensor["S1"][2])) < 1e-9
