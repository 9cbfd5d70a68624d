"""The live session's Lab Streaming Layer streams, received by real pylsl inlets: metadata, every
sample at its sample time, the window's numbers, markers both ways, the recording's LSL clock,
and an XDF recorded from the streams imported back as a session that reviews."""

from __future__ import annotations

import time
import uuid

import numpy as np
import pytest

pylsl = pytest.importorskip("pylsl", reason="pylsl is not installed (pip install 'mimucap[lsl]'; make test installs it)")

from mimucap.io.calibration_store import CalibrationStore  # noqa: E402
from mimucap.session.live.live_session import open_live_session  # noqa: E402
from mimucap.session.streaming.lsl_streamer import LslStreamer, marker_layout  # noqa: E402
from tests.known_mounting import known_mounting_calibration  # noqa: E402

RATE_HZ = 100.0


def _session(tmp_path):
    """A simulated 10-sensor suit at 100 Hz whose streams no other test shares (its own source)."""
    session = open_live_session("simulated", calibration_store=CalibrationStore(tmp_path / "calibrations"))
    session.sensors.label = f"simulated:test-{uuid.uuid4().hex[:8]}"
    return session


def _run(session, seconds: float, each=None) -> None:
    """Step ``session`` every 5 ms for ``seconds`` (``each()`` after every step)."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        session.step()
        if each is not None:
            each()
        time.sleep(0.005)


def _resolve(prop: str, value: str, source_id: str):
    """The stream whose ``prop`` (type, name) is ``value``, of ``source_id`` (this test's)."""
    found = [i for i in pylsl.resolve_bypred(f"{prop}='{value}' and source_id='{source_id}'", 1, 3.0)]
    assert found, f"no stream with {prop}={value!r} and source_id {source_id!r}"
    return found[0]


def _channels(info) -> list[dict[str, str]]:
    """Each channel's meta-data fields (tag → text)."""
    out, channel = [], info.desc().child("channels").child("channel")
    while not channel.empty():
        fields, child = {}, channel.first_child()
        while not child.empty():
            fields[child.name()] = child.child_value()
            child = child.next_sibling()
        out.append(fields)
        channel = channel.next_sibling()
    return out


@pytest.fixture
def streaming(tmp_path):
    session = _session(tmp_path)
    streamer = LslStreamer(session)
    session.start()
    yield session, streamer
    session.stop()
    streamer.close()


def test_streams_resolve_with_their_metadata_and_carry_every_sample_at_its_sample_time(streaming):
    session, streamer = streaming
    sample_times: list[np.ndarray] = []   # the pelvis sensor's sample times (session s): the pose instants
    reference = next(sid for sid, seg in session.sensor_segments.items() if seg == "pelvis")
    session.events.processed.connect(
        lambda items: sample_times.extend(i.t_s for i in items if i.sensor_id == reference))
    session.apply_body_calibration(known_mounting_calibration(session))  # joint angles need one
    _run(session, 0.5)  # the outlets open once 20 samples gave their rate

    mocap = _resolve("type", "MoCap", streamer.segments.layout.source_id)
    assert "MimuCap" in mocap.name() and mocap.nominal_srate() == RATE_HZ
    inlets = {"mocap": pylsl.StreamInlet(mocap, max_buflen=30)}
    joints = _resolve("name", "MimuCap joint angles", streamer.joints.layout.source_id)
    raw = _resolve("name", f"MimuCap raw {reference}", streamer.raw[reference].layout.source_id)
    inlets["joints"] = pylsl.StreamInlet(joints, max_buflen=30)
    for inlet in inlets.values():
        inlet.open_stream(3.0)

    # metadata: XDF motion-capture conventions, clinical names, BIDS-Motion units
    channels = _channels(inlets["mocap"].info(3.0))
    assert len(channels) == 4 * len(session.model.segment_names)
    assert [c["type"] for c in channels[:4]] == ["OrientationA", "OrientationB", "OrientationC", "OrientationD"]
    assert {c["object"] for c in channels} == set(session.model.segment_names)
    assert all(c["unit"] == "normalized" for c in channels)
    objects = inlets["mocap"].info().desc().child("setup").child("objects")
    assert objects.child("object").child_value("label") == "pelvis"
    assert objects.child("object").child_value("name") == "Pelvis"
    angles = {c["label"]: c for c in _channels(inlets["joints"].info(3.0))}
    knee = angles["knee_r_flexion_deg"]
    assert (knee["name"], knee["unit"], knee["type"], knee["sign"]) == (
        "Right knee flexion", "deg", "JNTANG", "+ flexion / − extension")
    raw_channels = {c["label"]: c for c in _channels(pylsl.StreamInlet(raw).info(3.0))}
    assert [(raw_channels[k]["type"], raw_channels[k]["unit"]) for k in ("acc_x", "gyr_y", "mag_z")] == [
        ("ACCEL", "m/s^2"), ("GYRO", "rad/s"), ("MAGN", "µT")]
    assert raw.nominal_srate() == RATE_HZ

    received = {name: ([], []) for name in inlets}

    def pull():
        for name, inlet in inlets.items():
            values, stamps = inlet.pull_chunk(timeout=0.0)
            received[name][0].extend(values)
            received[name][1].extend(stamps)

    _run(session, 3.0, pull)
    _run(session, 0.3, pull)
    # the LSL clock's offset measured here, apart from the streamer's
    offset = np.median([pylsl.local_clock() - time.monotonic() for _ in range(5)])
    stamps = np.array(received["mocap"][1])
    span_s = stamps[-1] - stamps[0]
    assert len(stamps) >= 0.99 * (span_s * RATE_HZ + 1), (len(stamps), span_s)
    assert len(stamps) >= 0.99 * 3.0 * RATE_HZ
    assert np.all(np.diff(stamps) > 0)
    sampled_lsl = np.concatenate(sample_times) + session.t0_host_s + offset
    nearest = np.abs(sampled_lsl[np.searchsorted(sampled_lsl, stamps).clip(0, len(sampled_lsl) - 1)] - stamps)
    below = np.abs(sampled_lsl[(np.searchsorted(sampled_lsl, stamps) - 1).clip(0)] - stamps)
    assert np.max(np.minimum(nearest, below)) < 0.005
    # the samples are not stamped when sent: the newest came at least a pump step after it was sampled
    assert stamps[-1] < pylsl.local_clock()

    # the same numbers as the window: the live plots' joint angles at their instants
    t_window, window_deg = session.joint_series("knee_r", 2.0)
    streamed = np.array(received["joints"][0])
    streamed_t = np.array(received["joints"][1]) - session.t0_host_s - streamer.offset_s
    columns = list(angles)
    at = np.searchsorted(streamed_t, t_window)
    ok = (at < len(streamed_t)) & (np.abs(streamed_t[at.clip(max=len(streamed_t) - 1)] - t_window) < 1e-6)
    assert ok.sum() > 50
    knee_columns = [columns.index(c) for c in session.joint_columns("knee_r")]
    np.testing.assert_allclose(streamed[at[ok]][:, knee_columns], window_deg[ok], atol=1e-9)
    # segment orientations are unit quaternions of the same poses
    q = np.array(received["mocap"][0]).reshape(len(stamps), -1, 4)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-9)
    # without a body calibration no joint angle goes out, as the window plots none
    session.clear_body_calibration()
    received["joints"][0].clear()
    _run(session, 0.3, pull)
    assert received["joints"][0] and np.all(np.isnan(np.array(received["joints"][0])[-5:]))


def test_the_source_id_is_the_same_after_a_restart(tmp_path):
    first = _session(tmp_path)
    second = open_live_session("simulated", calibration_store=CalibrationStore(tmp_path / "c2"))
    second.sensors.label = first.label
    ids = []
    for session in (first, second):
        streamer = LslStreamer(session)
        ids.append((streamer.segments.layout.source_id, streamer.joints.layout.source_id))
        streamer.close()
    assert ids[0] == ids[1]


def test_markers_go_out_and_another_programs_markers_come_in_at_their_times(streaming, tmp_path):
    session, streamer = streaming
    name = f"Stimulus {uuid.uuid4().hex[:8]}"
    stimulus = pylsl.StreamOutlet(pylsl.StreamInfo(name, "Markers", 1, 0, "string", f"stim-{name}"))
    ours = _resolve("type", "Markers", marker_layout(session.label).source_id)
    out_inlet = pylsl.StreamInlet(ours)
    out_inlet.open_stream(3.0)
    streamer.take_markers(name)
    assert streamer.marker_stream == name
    recording = tmp_path / "with-markers.h5"
    session.start_recording(recording)
    _run(session, 0.3)
    pushed = []
    for label in ("stimulus A", "stimulus B", "trigger 7"):
        stamp = pylsl.local_clock() - 0.05   # sent 50 ms after its instant, as a trigger program may
        stimulus.push_sample([label], stamp)
        pushed.append((label, stamp))
        _run(session, 0.25)
    t_ours = session.add_marker("walk")
    _run(session, 0.3)
    session.stop_recording()

    from mimucap.io.session import read_session

    stored = read_session(recording)
    start_lsl = stored.metadata["lsl_clock"]["session_start_lsl_s"]
    by_label = {m.label: m.t_s for m in stored.markers}
    for label, stamp in pushed:
        assert abs(by_label[label] + start_lsl - stamp) < 0.010, label
    assert streamer.markers_taken == 3
    # the session's own marker goes out on 'MimuCap markers' at its time; the ones taken in do not
    values, stamps = out_inlet.pull_chunk(timeout=1.0)
    assert [v[0] for v in values] == ["walk"]
    assert abs(stamps[0] - streamer.lsl_time(t_ours)) < 1e-6
    assert abs(by_label["walk"] + start_lsl - stamps[0]) < 0.010


def test_a_stream_that_is_not_there_or_not_of_markers_is_refused_with_the_reason(streaming):
    _session_, streamer = streaming
    with pytest.raises(ValueError, match="no Lab Streaming Layer stream named 'nothing here'"):
        streamer.take_markers("nothing here", timeout_s=0.3)
    name = f"EMG {uuid.uuid4().hex[:8]}"
    emg = pylsl.StreamOutlet(pylsl.StreamInfo(name, "EMG", 8, 1000, "float32", f"emg-{name}"))
    with pytest.raises(ValueError, match="is not a marker stream: it has 8 channels at 1000 Hz"):
        streamer.take_markers(name)
    del emg


def test_an_xdf_recorded_from_the_streams_imports_as_a_session_that_reviews(streaming, tmp_path):
    pytest.importorskip("pyxdf", reason="pyxdf is not installed (pip install 'mimucap[lsl]'; make test installs it)")
    from tests.xdf_recorder import record, write_xdf

    from mimucap.cli import main
    from mimucap.io.session import read_session
    from mimucap.session.recorded.review import load_review

    session, streamer = streaming
    sent: dict[str, list] = {}
    session.events.processed.connect(lambda items: [sent.setdefault(i.sensor_id, []).append(i.block) for i in items])
    _run(session, 0.5)
    infos = [_resolve("name", f"MimuCap raw {sid}", outlet.layout.source_id) for sid, outlet in streamer.raw.items()]
    infos.append(_resolve("type", "Markers", marker_layout(session.label).source_id))
    marks = iter([1.0, 2.0])
    due = [time.monotonic() + 1.0, time.monotonic() + 2.0]

    def step():
        session.step()
        if due and time.monotonic() >= due[0]:
            due.pop(0)
            session.add_marker(f"mark {next(marks):g}")

    recorded = record(pylsl, infos, 3.0, step)
    path = tmp_path / "lab.xdf"
    write_xdf(path, recorded)
    out = tmp_path / "from-xdf.h5"
    assert main(["import", str(path), "--out", str(out)]) == 0
    imported = read_session(out)
    assert sorted(imported.sensors) == sorted(session.sensor_ids)
    assert imported.sensor_segments() == {sid: session.sensor_segments[sid] for sid in imported.sensors}
    assert [m.label for m in imported.markers] == ["mark 1", "mark 2"]
    # the samples are the ones the sensors sent, by sequence number, raw magnetometer included
    for sid, samples in imported.sensors.items():
        blocks = sent[sid]
        seq = np.concatenate([b.seq for b in blocks])
        mag = np.concatenate([b.mag_uT for b in blocks])
        acc = np.concatenate([b.acc for b in blocks])
        rows = np.searchsorted(seq, samples.seq)
        assert len(samples) >= 0.99 * (samples.seq[-1] - samples.seq[0] + 1)
        np.testing.assert_array_equal(seq[rows], samples.seq)
        np.testing.assert_allclose(samples.mag_uT, mag[rows], rtol=0, atol=1e-12)
        np.testing.assert_allclose(samples.acc, acc[rows], rtol=0, atol=1e-12)
    # the session lines up with the LSL clock: a marker's session time + the start is its LSL time
    start = imported.metadata["lsl_clock"]["session_start_lsl_s"]
    first = min(float(s.t_s[0]) for s in imported.sensors.values())
    assert first == 0.0 and start > 0
    review = load_review(out)
    assert len(review.t_s) > 250
    assert np.all(np.isfinite(review.angles_deg["knee_r_flexion_deg"]))
