"""The live session tells what changed through its events: data and frames from every step that
brings samples, its status at 4 Hz (and at once after a change it shows), state changes when they
happen; the figure's geometry is built only while someone listens."""

from __future__ import annotations

import pytest

from mimucap.core.pipeline.recording import POSE_SENSOR_AXES
from mimucap.core.simulate.config import SimulationConfig
from mimucap.session.angle_accuracy import FLEXION_COLUMNS
from mimucap.session.sources.feeds import SimulatorFeed
from mimucap.session.live.live_session import LiveSession
from mimucap.session.live.processing import POSE_NONE
from mimucap.session.live.status import STATUS_RATE_HZ, StatusPublisher
from tests.known_mounting import known_mounting_calibration


def _session(**config) -> tuple[LiveSession, list[float]]:
    now = [50.0]
    clock = lambda: now[0]  # noqa: E731
    session = LiveSession(SimulatorFeed(SimulationConfig(scenario="walk", **config), clock=clock), clock=clock,
                          status_clock=clock)
    return session, now


def _record(session: LiveSession, *names: str) -> dict[str, list[tuple]]:
    seen: dict[str, list[tuple]] = {name: [] for name in names}
    for name in names:
        getattr(session.events, name).connect(lambda *args, name=name: seen[name].append(args))
    return seen


def _run(session: LiveSession, now: list[float], seconds: float, step_s: float = 0.016) -> None:
    for _ in range(int(round(seconds / step_s))):
        now[0] += step_s
        session.step()


def test_each_step_with_samples_emits_data_and_a_frame_with_its_geometry():
    session, now = _session()
    seen = _record(session, "data", "frame", "sensors", "pose_source")
    session.start()
    steps = 0
    for _ in range(31):
        now[0] += 0.016
        steps += session.step() > 0
    assert session.step() == 0  # nothing new at the same instant: nothing told
    assert steps > 25 and len(seen["data"]) == steps and len(seen["frame"]) == steps
    assert seen["data"][-1] == (session.cursor_s,)
    frame_id, geometry = seen["frame"][-1]
    assert (frame_id, geometry) == session.frame()
    assert len({args[0] for args in seen["frame"]}) == steps  # a new id for every pose
    assert seen["sensors"] == [(session.sensor_ids,)]  # once, when the sensors appeared
    assert seen["pose_source"] == [(POSE_SENSOR_AXES,)]  # once, when it changed
    session.set_display_mode("body")  # the same pose in another mode: a new frame
    assert len(seen["frame"]) == steps + 1 and seen["frame"][-1][0] != frame_id


def test_the_geometry_is_built_only_while_someone_listens(monkeypatch):
    session, now = _session()
    built = []
    real = session.builder.build_arrays
    monkeypatch.setattr(session.builder, "build_arrays", lambda *a, **k: built.append(1) or real(*a, **k))
    session.start()
    _run(session, now, 0.3)
    assert built == []  # nobody subscribed to frame: no figure made
    frames = _record(session, "frame")["frame"]
    _run(session, now, 0.3)
    assert len(built) == len(frames) > 10


def test_the_running_error_against_the_truth_is_told_once_a_body_calibration_is_applied():
    session, now = _session()
    seen = _record(session, "truth_errors")
    session.start()
    _run(session, now, 1.0)
    assert seen["truth_errors"] and all(errors == {} for (errors,) in seen["truth_errors"])
    session.apply_body_calibration(known_mounting_calibration(session))
    _run(session, now, 2.0)
    # of the joints whose flexion the status bar shows
    errors = seen["truth_errors"][-1][0]
    joints = {column.rsplit("_", 2)[0] for column in FLEXION_COLUMNS}
    assert set(FLEXION_COLUMNS) & set(errors)
    assert all(column.rsplit("_", 2)[0] in joints and value >= 0.0 for column, value in errors.items())


def test_the_status_is_published_four_times_a_second_and_at_once_after_an_assignment():
    session, now = _session()
    seen = _record(session, "status", "checklist", "recording_progress", "source_problem", "refused",
                   "truth_errors", "assignment")
    session.start()
    _run(session, now, 3.0)
    # the first step publishes; then one every 0.25 s of the session's clock
    assert 3.0 * STATUS_RATE_HZ <= len(seen["status"]) <= 3.0 * STATUS_RATE_HZ + 2
    rows = seen["status"][-1][0]
    assert [row.sensor_id for row in rows] == list(session.sensor_ids)
    assert len(seen["checklist"]) == len(seen["status"]) and seen["recording_progress"] == []
    assert {item.key for item in seen["checklist"][-1][0]} == {"streaming", "drops", "magnetometers", "body"}
    # rarely changing values are emitted when they change only
    assert seen["source_problem"] == [("",)] and seen["refused"] == [({}, {})]
    # no error against the truth before a body calibration: there is no estimated pose to judge
    assert all(errors == {} for (errors,) in seen["truth_errors"])
    # an assignment is told at once, and shows in the status of the next step
    published = len(seen["status"])
    sensor = session.sensor_ids[0]
    session.assign_sensor(sensor, None)
    assert seen["assignment"][-1] == (dict(session.sensor_segments),) and sensor not in session.sensor_segments
    now[0] += 0.016
    session.step()
    assert len(seen["status"]) == published + 1
    assert {row.sensor_id: row.segment for row in seen["status"][-1][0]}[sensor] is None


def test_a_recording_publishes_its_progress_instead_of_the_checklist(tmp_path):
    session, now = _session()
    seen = _record(session, "checklist", "recording_progress", "recording")
    session.start()
    _run(session, now, 0.5)
    checklists = len(seen["checklist"])
    session.start_recording(tmp_path / "s.h5")
    _run(session, now, 1.0)
    assert len(seen["checklist"]) == checklists
    progress = [info for (info,) in seen["recording_progress"]]
    assert len(progress) >= 4 and progress[-1].elapsed_s == pytest.approx(1.0, abs=0.3)
    session.stop_recording()
    assert seen["recording"][-1] == (None,)


def test_publish_status_tells_every_value_again():
    session, now = _session()
    seen = _record(session, "status", "source_problem", "refused", "pose_source")
    session.publish_status()  # before the start: what a widget that just subscribed needs
    assert seen["pose_source"] == [(POSE_NONE,)] and seen["source_problem"] == [("",)]
    session.publish_status()
    assert len(seen["status"]) == 2 and len(seen["source_problem"]) == 2 and len(seen["refused"]) == 2


def test_the_status_rate_must_be_positive():
    session, _now = _session()
    with pytest.raises(ValueError, match="positive"):
        StatusPublisher(session, session.events, lambda: 0.0, rate_hz=0.0)
