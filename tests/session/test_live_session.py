"""The live session: stale sensors, calibrations, markers and recording, the worker path."""

from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np
import pytest

from mimucap.core import rotation
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import simulate_session
from mimucap.io.session import read_session, session_from_simulation, write_session
from mimucap.session.recorded.export import ExportRequest, marker_range, recording_start_s, run_export, summary_table
from mimucap.session.sources.feeds import SimulatorFeed
from mimucap.core.pipeline.recording import POSE_SENSOR_AXES
from mimucap.session.live.evaluation import TRUTH_NOTE
from mimucap.session.live.live_session import LiveSession, open_live_session
from mimucap.session.live.processing import POSE_UNASSIGNED
from mimucap.session.live.sensor_rows import STALE_AFTER_S
from mimucap.session.live.recorder import open_session
from mimucap.session.recorded.review import ReviewPlayer, load_review
from tests.known_mounting import known_mounting_calibration


def _session(scenario: str = "walk", **config) -> tuple[LiveSession, list[float]]:
    now = [50.0]
    clock = lambda: now[0]  # noqa: E731
    session = LiveSession(SimulatorFeed(SimulationConfig(scenario=scenario, **config), clock=clock), clock=clock)
    session.start()
    return session, now


def _run(session: LiveSession, now: list[float], seconds: float, step_s: float = 0.02) -> None:
    for _ in range(int(round(seconds / step_s))):
        now[0] += step_s
        session.step()


def test_a_silent_sensor_is_flagged_stale_within_a_second():
    session, now = _session()
    _run(session, now, 1.0)
    assert not any(row.stale for row in session.sensor_rows())
    now[0] += 0.9 * STALE_AFTER_S  # no new data, not yet a second
    assert not any(row.stale for row in session.sensor_rows())
    now[0] += 0.2 * STALE_AFTER_S
    rows = session.sensor_rows()
    assert all(row.stale and row.state == "stale" for row in rows)
    assert set(session.segment_states().values()) == {"stale"}


def test_rows_report_rate_and_drops_of_the_suit():
    session, now = _session(drop_probability=0.05, seed=3)
    _run(session, now, 3.0)
    rows = {row.sensor_id: row for row in session.sensor_rows()}
    assert set(rows) == set(session.feed.sensor_ids)
    total_drops = sum(r.drops for r in rows.values())
    assert total_drops > 0  # 5 % of 3000 samples are lost
    for row in rows.values():
        assert 90.0 * 0.9 < row.rate_hz < 101.0 * 1.05
        assert row.mag_cal == "not calibrated"


def test_magnetometer_calibration_is_applied_to_its_sensor_only():
    session, now = _session()
    _run(session, now, 0.5)
    raw = session.series("S02", 0.1)[3][-1]
    calibration = MagCalibration("S02", offset_uT=raw, soft_iron=np.eye(3), field_uT=49.3,
                                 created_utc="2026-01-01T00:00:00+00:00")
    session.apply_mag_calibration(calibration)
    _run(session, now, 0.2)
    t, _acc, _gyr, mag = session.series("S02", 0.05)
    assert np.all(np.abs(mag) < 10.0)  # raw offset removed (the field barely changes in 0.2 s)
    row = {r.sensor_id: r for r in session.sensor_rows()}["S02"]
    assert row.mag_cal == "calibrated" and row.mag_cal_age_s > 3600
    with pytest.raises(ValueError, match="S03"):
        calibration.apply(raw, "S03")


def test_sensor_assignment_is_validated():
    session, _now = _session()
    with pytest.raises(ValueError, match="unknown segment"):
        session.assign_sensor("S01", "tail")
    session.assign_sensor("S09", "pelvis")  # a segment carries one sensor
    assert session.sensor_segments["S09"] == "pelvis" and "S01" not in session.sensor_segments


def test_recording_markers_review_and_export(tmp_path):
    session, now = _session("walk")
    _run(session, now, 0.5)
    session.start_recording(tmp_path / "walk.h5", {"id": "P1", "height_m": 1.75, "dominance": "left", "notes": ""})
    with pytest.raises(ValueError, match="already recording"):
        session.start_recording(tmp_path / "other.h5")
    _run(session, now, 2.0)
    session.add_marker("one")
    _run(session, now, 3.0)
    session.add_marker("two")
    _run(session, now, 1.0)
    info = session.recording_info()
    assert info.markers == 2 and info.size_bytes > 1000 and info.elapsed_s == pytest.approx(6.0, abs=0.03)
    result = session.stop_recording()
    assert result.complete and not session.recording
    stored = read_session(result.session_path)
    assert [m.label for m in stored.markers] == ["one", "two"]
    assert stored.markers[0].t_s == pytest.approx(2.0, abs=0.03)
    assert stored.metadata["subject"]["dominance"] == "left"
    for stream in stored.sensors.values():
        assert len(stream.t_s) == pytest.approx(600, abs=3)  # 6 s at 100 Hz
    # The simulator's truth rides along: its knee angle is that of the suit at the same instants.
    truth = stored.truth
    assert truth.t_s[0] >= 0 and truth.t_s[-1] == pytest.approx(6.0, abs=0.03)

    data = load_review(result.session_path)
    player = ReviewPlayer(data)
    # recorded before a body calibration: the review, like the live view, shows the outline with
    # each sensor on its segment (turned as its orientation was), and no truth beside it
    assert data.body_calibration is None
    _, geometry = player.frame()
    assert geometry.outline and dict(zip(geometry.sensor_glyphs.sensor_ids, geometry.sensor_glyphs.segments)) == {
        sensor: stream.segment for sensor, stream in stored.sensors.items() if stream.segment is not None}
    assert player.truth_frame() is None
    assert player.seek_marker(1) == pytest.approx(stored.markers[1].t_s)
    moved = player.frame()[1].sensor_glyphs.matrices
    assert not np.allclose(moved, geometry.sensor_glyphs.matrices)
    player.set_speed(2.0)
    player.play()
    player.advance(0.5)
    assert player.cursor_s == pytest.approx(stored.markers[1].t_s + 1.0)
    player.advance(10.0)
    assert not player.playing and player.cursor_s == pytest.approx(data.end_s)
    with pytest.raises(ValueError, match="marker 5"):
        player.seek_marker(5)

    a, b = marker_range(data.markers, 1, 0)
    assert (a, b) == (pytest.approx(2.0, abs=0.03), pytest.approx(5.0, abs=0.03))
    exported = run_export(data, ExportRequest(tmp_path / "out", a, b, sensors_csv=True))
    names = sorted(p.name for p in exported.files)
    assert {"out_joint_angles.csv", "out_joint_angles.mot", "out_joint_angle_summary.csv", "out_sensor_S01_raw.csv"} <= set(names)
    # the whole recording's range starts at its start, never at the negative time of a pose made
    # from the samples of the poll running when Record was pressed
    assert recording_start_s(data) == max(0.0, data.start_s)
    assert recording_start_s(SimpleNamespace(start_s=-0.14, end_s=6.0)) == 0.0
    assert recording_start_s(SimpleNamespace(start_s=0.3, end_s=6.0)) == 0.3
    assert recording_start_s(SimpleNamespace(start_s=-5.0, end_s=-1.0)) == -5.0
    whole = run_export(data, ExportRequest(tmp_path / "whole", recording_start_s(data), data.end_s))
    first_time = next(line for line in (tmp_path / "whole_joint_angles.csv").read_text().splitlines()
                      if line[:1].isdigit() or line[:1] == "-").split(",")[0]
    assert float(first_time) >= 0.0 and whole.files
    rows = summary_table({"x_deg": np.array([-5.0, 10.0, 2.0])})
    assert rows[0].minimum_deg == -5.0 and rows[0].maximum_deg == 10.0 and rows[0].rom_deg == 15.0
    with pytest.raises(ValueError, match="end after its start"):
        ExportRequest(tmp_path / "bad", 3.0, 2.0)


def test_a_crashed_recording_of_the_simulated_suit_keeps_its_truth(tmp_path):
    session, now = _session("walk")
    _run(session, now, 0.5)
    path = tmp_path / "crash.h5"
    session.start_recording(path)
    _run(session, now, 2.0)
    shown = session.feed.last_truth  # journaled now, on disk after the next flush
    time.sleep(0.6)  # the journal's flush interval (0.5 s) has passed: the next step flushes
    _run(session, now, 0.02)
    # The application dies here: no stop. Opening the recording recovers it from its journal.
    stored = open_session(path)
    truth = stored.truth
    assert truth is not None and truth.attributes["origin"] == TRUTH_NOTE
    assert truth.t_s[0] >= 0.0 and truth.t_s[-1] == pytest.approx(2.02, abs=0.03)
    samples = next(iter(stored.sensors.values()))
    assert abs(truth.t_s[-1] - samples.t_s[-1]) < 0.03 and np.all(np.diff(truth.t_s) > 0)
    shown_t_s = shown.t_s[-1] + session.feed.host_time_of(0.0) - session.t0_host_s - session.recording_started_s
    (row,) = np.flatnonzero(np.isclose(truth.t_s, shown_t_s, rtol=0.0, atol=1e-9))  # the instant `shown` ends at
    assert shown_t_s == pytest.approx(2.0, abs=0.011)
    np.testing.assert_allclose(truth.q_world_from_segment["thigh_r"][row], shown.q_world_from_segment["thigh_r"][-1])
    np.testing.assert_allclose(truth.joint_angles_deg["knee_r_flexion_deg"][row],
                               shown.joint_angles_deg["knee_r_flexion_deg"][-1])


def test_replay_through_acquisition_workers_is_fused_and_shown(tmp_path):
    """A raw-only replay (no on-board orientation) goes through the supervisor's worker, is fused
    per sensor, and the figure follows the assigned sensors' axes, labelled as such."""
    result = simulate_session(SimulationConfig(scenario="walk", duration_s=3.0, n_sensors=10, seed=1))
    path = tmp_path / "sim.h5"
    write_session(path, session_from_simulation(result, include_truth=False))
    session = open_live_session(f"replay:{path}@4")
    # the replay keeps the placement stored in the recording; taken off here to see unassigned sensors first
    assert session.sensor_segments == {sid: m.segment for sid, m in result.mounting.items()}
    for sensor_id in list(session.sensor_segments):
        session.assign_sensor(sensor_id, None)
    session.start()
    try:
        deadline = time.monotonic() + 30.0
        while session.samples_received < 500 and time.monotonic() < deadline:
            session.step()
            time.sleep(0.01)
        assert session.samples_received >= 500
        assert session.pose_source == POSE_UNASSIGNED
        assert np.isnan(session.time_s)  # no pose yet, but the plots follow the newest samples
        newest = max(session.series(sensor_id, 5.0)[0][-1] for sensor_id in session.sensor_ids)
        assert session.cursor_s == newest
        for sensor_id, mounting in result.mounting.items():
            session.assign_sensor(sensor_id, mounting.segment)
        while session.samples_received < 1500 and time.monotonic() < deadline:
            session.step()
            time.sleep(0.01)
        assert session.pose_source == POSE_SENSOR_AXES
        orientations = session.latest_orientations()
        assert set(orientations) == set(result.samples)
        for q in orientations.values():
            assert np.isclose(np.linalg.norm(q), 1.0)
        assert session.frame() is not None
    finally:
        session.stop()


def test_an_applied_body_calibration_drives_the_figure_from_the_sensors():
    """With error-free sensors and the true mounting as calibration, the pipeline's segment
    orientations (fusion → calibration) match the simulator's truth."""
    from mimucap.core import rotation, skeleton
    from mimucap.core.bodycal import BodyCalibration, CalibrationQuality

    session, now = _session("walk", errors="ideal")
    mounting = session.feed.simulator.mounting
    calibration = BodyCalibration(
        q_world_from_body=skeleton.q_world_from_body_facing(0.0), up_world=np.array([0.0, 0.0, 1.0]),
        sensors={m.segment: sid for sid, m in mounting.items()},
        q_segment_from_sensor={m.segment: m.q_segment_from_sensor for m in mounting.values()},
        quality=CalibrationQuality("known mounting", ()))
    session.apply_body_calibration(calibration)
    _run(session, now, 4.0)
    assert session.pose_source == "body calibration"
    truth = session.feed.last_truth
    for segment, q in session.q_world_from_segment.items():
        error_deg = np.degrees(rotation.angle_between(q, truth.q_world_from_segment[segment][-1]))
        assert error_deg < 5.0, segment
    session.clear_body_calibration()
    _run(session, now, 0.1)
    assert session.pose_source == POSE_SENSOR_AXES


@pytest.mark.parametrize("n_sensors", [10, 17])
def test_joint_series_and_frames_follow_every_pose(n_sensors):
    """Joint angles computed in batches (as the plots ask) and the figure of the newest pose
    equal the skeleton functions applied to each pose the pipeline produced (through a body
    calibration: before one the figure is the outline and no joint angles are kept)."""
    from mimucap.core import skeleton

    session, now = _session("walk", n_sensors=n_sensors)
    session.apply_body_calibration(known_mounting_calibration(session))
    times, poses = [], []
    for tick in range(60):
        now[0] += 0.01
        session.step()
        times.append(session.time_s)
        poses.append(dict(session.q_world_from_segment))
        if tick % 3 == 0:
            session.joint_series(session.joint_names[0], 1.0)
        if tick % 7 == 0:
            _, geometry = session.frame()
            expected = session.builder.build(
                skeleton.forward_kinematics(session.model, poses[-1], session.height_m, session.pose.root_m),  # root: where it stands
                heading_ref_rad=session.calibrations.heading_ref_rad)
            np.testing.assert_allclose(geometry.segment_matrices, expected.segment_matrices, rtol=0, atol=1e-12)
            np.testing.assert_allclose(geometry.joint_matrices, expected.joint_matrices, rtol=0, atol=1e-12)
    model = session.model
    expected = skeleton.joint_angles_deg(model, {s: np.array([p[s] for p in poses]) for s in model.segment_names})
    for joint in session.joint_names:
        t, angles = session.joint_series(joint, 10.0)
        np.testing.assert_array_equal(t, times)
        columns = session.joint_columns(joint)
        np.testing.assert_allclose(angles, np.stack([expected[c] for c in columns], axis=-1), rtol=0, atol=1e-9)


def test_small_blocks_give_the_same_session_as_whole_ones():
    """Wireless nodes deliver a sample or two at a time; the pipeline joins each sensor's
    blocks of one poll, and the buffers and orientations are those of whole blocks."""
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.session.sources.feeds import SimulatorFeed
    from mimucap.session.live.live_session import LiveSession

    def one_sample_blocks(blocks):
        return [block.rows(slice(i, i + 1)) for block in blocks for i in range(len(block))]

    sessions = []
    for split in (False, True):
        now = [50.0]
        feed = SimulatorFeed(SimulationConfig(scenario="walk", seed=4), clock=lambda now=now: now[0])
        if split:
            poll = feed.poll
            feed.poll = lambda poll=poll: one_sample_blocks(poll())
        session = LiveSession(feed, clock=lambda now=now: now[0])
        calls = []
        feed_pipeline = session.pipeline.feed
        session.pipeline.feed = lambda blocks, f=feed_pipeline, calls=calls: calls.extend(len(b.t_s) for b in blocks) or f(blocks)
        session.start()
        for _ in range(40):
            now[0] += 0.037
            session.step()
        sessions.append(session)
        if split:  # one filter call per sensor and poll, not one per sample
            assert len(calls) <= 40 * len(session.sensor_ids) and max(calls) > 1
    whole, small = sessions
    assert small.samples_received == whole.samples_received > 1000
    for sensor_id in whole.sensor_ids:
        for a, b in zip(whole.series(sensor_id, 30.0), small.series(sensor_id, 30.0)):
            np.testing.assert_array_equal(a, b)
    q_whole, q_small = whole.latest_orientations(), small.latest_orientations()
    assert q_whole.keys() == q_small.keys()
    for sensor_id in q_whole:
        np.testing.assert_allclose(q_small[sensor_id], q_whole[sensor_id], atol=1e-12)


def test_a_source_that_cannot_be_opened_says_why():
    session = open_live_session("serial:/dev/mimucap_no_such_port@115200")
    assert session.source_problem == ""  # nothing known before it starts
    session.start()
    try:
        deadline = time.monotonic() + 15.0
        while not session.source_problem and time.monotonic() < deadline:
            session.step()
            time.sleep(0.05)
        assert "cannot open /dev/mimucap_no_such_port" in session.source_problem
        assert session.samples_received == 0
    finally:
        session.stop()


def test_the_simulated_suit_shows_what_its_sensors_give_before_a_body_calibration():
    """Like any source, until a body calibration each assigned sensor's orientation (from its
    filter, never the simulator's truth) stands for its segment's: with sensors mounted along
    their segments the figure follows the subject; a sensor assigned to the wrong segment moves
    that segment as the other one."""
    session, now = _session(errors="ideal", random_mounting=False)
    _run(session, now, 2.0)
    truth = session.feed.last_truth
    q = session.q_world_from_segment
    assert session.pose_source == POSE_SENSOR_AXES
    assert np.degrees(rotation.angle_between(q["thigh_r"], truth.q_world_from_segment["thigh_r"][-1])) < 5.0
    assert not np.allclose(q["thigh_r"], truth.q_world_from_segment["thigh_r"][-1])  # estimated, not copied
    session.assign_sensor("S07", "thigh_r")   # S07 is worn on the left thigh
    _run(session, now, 0.5)
    truth = session.feed.last_truth
    q = session.q_world_from_segment
    assert np.degrees(rotation.angle_between(q["thigh_r"], truth.q_world_from_segment["thigh_l"][-1])) < 5.0
    # thigh_l lost its sensor: it turns with its parent, the pelvis
    np.testing.assert_allclose(q["thigh_l"], q["pelvis"])

    for sensor_id in list(session.sensor_segments):
        session.assign_sensor(sensor_id, None)
    frame_id = session.frame()[0]
    _run(session, now, 0.5)
    assert session.pose_source == POSE_UNASSIGNED
    assert session.frame()[0] == frame_id  # no new pose: the view says why (no sensor assigned)


def test_a_calibration_that_no_longer_matches_the_local_field_is_flagged():
    """The sensor panel warns when the calibrated field's magnitude no longer matches the
    calibration's (the sensor is in another room, or near metal)."""
    session, now = _session(errors="ideal", scenario="npose")
    _run(session, now, 0.5)
    field = float(np.median(np.linalg.norm(session.series("S02", 0.4)[3], axis=1)))
    for field_uT, flagged in ((field, False), (2.0 * field, True)):
        session.apply_mag_calibration(MagCalibration("S02", offset_uT=np.zeros(3), soft_iron=np.eye(3),
                                                     field_uT=field_uT, quality={"verdict": "good"}))
        _run(session, now, 0.5)
        row = {r.sensor_id: r for r in session.sensor_rows()}["S02"]
        assert row.mag_cal_verdict == "good"
        assert bool(row.mag_field_warning) == flagged, row.mag_field_warning
        if flagged:
            assert "calibrate again" in row.mag_field_warning


def test_after_a_restart_the_magnetometer_calibrations_are_back_with_their_age(tmp_path):
    """A calibration made before (kept in the calibration store) is applied at the next start
    and at every source change, for the sensors the source brings; the panel shows its age."""
    from mimucap.io.calibration_store import CalibrationStore

    store = CalibrationStore(tmp_path / "store")
    s02 = SimulationConfig(scenario="npose").device_ids()["S02"]   # made on this suit's S02 before
    store.save(MagCalibration("S02", offset_uT=np.array([5.0, -3.0, 1.0]), soft_iron=np.eye(3), field_uT=49.0,
                              created_utc="2026-01-01T00:00:00+00:00", quality={"verdict": "good"}, device_id=s02))
    store.save(MagCalibration("S99", offset_uT=np.zeros(3), soft_iron=np.eye(3), field_uT=49.0))  # not worn today
    now = [50.0]
    clock = lambda: now[0]  # noqa: E731
    for _restart in range(2):
        session = LiveSession(SimulatorFeed(SimulationConfig(scenario="npose"), clock=clock), clock=clock,
                              calibration_store=store)
        assert set(session.mag_calibrations) == {"S02"}
        session.start()
        _run(session, now, 0.3)
        row = {r.sensor_id: r for r in session.sensor_rows()}["S02"]
        assert row.mag_cal == "calibrated" and row.mag_cal_verdict == "good" and row.mag_cal_age_s > 86400
        session.stop()


def test_the_simulated_subjects_activity_changes_are_not_markers():
    """The walk scenario starts with a second of N-pose: its change to walking is the
    simulator's business, not a marker the user placed."""
    session, now = _session("walk")
    markers = []
    session.events.marker.connect(lambda *args: markers.append(args))
    _run(session, now, 2.0)
    assert session.simulator.current_activity() != "npose" and markers == []
    session.add_marker("mine")
    assert [label for _t, label, _recorded in markers] == ["mine"]


def test_packets_a_replay_refuses_reach_the_sensor_rows_by_sensor_and_reason(tmp_path):
    """Rows with a NaN are refused, not replayed; the sensor panel's rows count them for their
    sensor, by reason (values beyond the physical limits cannot even be written to a file)."""
    from mimucap.core.sensor_samples import SensorSamples
    from mimucap.io.session import Session

    t = np.arange(200) / 100.0
    gyr = np.zeros((200, 3))
    bad = gyr.copy()
    bad[[10, 20, 30], 0] = np.nan
    sensors = {"A": SensorSamples(sensor_id="A", t_s=t, seq=np.arange(200), gyr=gyr, acc=np.tile([0, 0, 9.81], (200, 1))),
               "B": SensorSamples(sensor_id="B", t_s=t, seq=np.arange(200), gyr=bad, acc=np.tile([0, 0, 9.81], (200, 1)))}
    path = write_session(tmp_path / "bad.h5", Session(metadata={"source": "test"}, sensors=sensors))
    session = open_live_session(f"replay:{path}@10")
    session.start()
    try:
        deadline = time.monotonic() + 30.0
        rows = {}
        while time.monotonic() < deadline:
            session.step()
            rows = {row.sensor_id: row for row in session.sensor_rows()}
            if "B" in rows and sum(rows["B"].rejections.values()) >= 3:
                break
            time.sleep(0.02)
        assert rows["B"].rejections == {"non_finite": 3}
        assert rows["A"].rejections == {}
    finally:
        session.stop()
