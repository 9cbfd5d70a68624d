"""The recorder: journal → session file, crash recovery, and a full disk."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np
import pytest

from mimucap.core.sensor_samples import SensorSamples
from mimucap.io.journal.file import read_journal
from mimucap.io.journal.records import journal_path_for
from mimucap.io.session import read_session
from mimucap.session.live.recorder import Recorder, RecorderSettings, open_session, recover

T0 = 1000.0


def block(sensor: str, first: int, n: int, rate: float = 100.0, full: bool = True) -> SensorSamples:
    seq = np.arange(first, first + n, dtype=np.int64)
    host = T0 + seq / rate
    channels = {"gyr": np.column_stack([seq * 0.001, -seq * 0.001, np.ones(n)])}
    if full:
        channels.update(acc=np.tile([0.0, 0.0, 9.81], (n, 1)), mag_uT=np.tile([20.0, 0.0, -40.0], (n, 1)),
                        q_world_from_sensor=np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
                        calibration=np.tile(np.array([3, 3, 2, 1], dtype=np.int8), (n, 1)),
                        battery_pct=np.full(n, 80.0))
    return SensorSamples(sensor, host, seq, device_time_s=host + 5.0, receive_time_s=host + 0.002, source="test",
                         **channels)


def test_blocks_become_a_session_and_the_journal_goes_away(tmp_path):
    out = tmp_path / "s.h5"
    recorder = Recorder(out, {"source": "udp:127.0.0.1:5555", "sensor_segments": {"1": "pelvis"}})
    recorder.start(start_host_s=T0)
    recorder.add_blocks([block("1", 0, 50), block("2", 0, 30, full=False)])
    recorder.add_blocks([block("1", 50, 50), block("2", 31, 20, full=False)])   # seq 30 lost
    recorder.add_marker("jump", host_s=T0 + 0.25)
    result = recorder.stop({"sensors": {"1": {"drops": 0, "latency_p95_ms": float("nan")}}}, "duration")
    assert result.complete and result.session_path == out
    assert not journal_path_for(out).exists()
    session = read_session(out)
    assert session.metadata["source"] == "udp:127.0.0.1:5555"
    assert session.metadata["acquisition"] == {"sensors": {"1": {"drops": 0, "latency_p95_ms": None}}}
    assert session.metadata["recording"]["ended"] == "duration"
    one, two = session.sensors["1"], session.sensors["2"]
    assert one.segment == "pelvis" and two.segment is None
    np.testing.assert_array_equal(one.seq, np.arange(100))
    np.testing.assert_allclose(one.t_s, np.arange(100) / 100.0, atol=1e-12)
    np.testing.assert_allclose(one.device_time_s, T0 + 5.0 + np.arange(100) / 100.0)
    np.testing.assert_allclose(one.battery_pct, 80.0)
    np.testing.assert_array_equal(one.calibration[0], [3, 3, 2, 1])
    assert two.acc is None and two.mag_uT is None and two.battery_pct is None  # absent, not zero-filled
    np.testing.assert_array_equal(two.seq, np.r_[np.arange(30), np.arange(31, 51)])
    assert session.markers[0].label == "jump" and session.markers[0].t_s == pytest.approx(0.25)


def test_writing_the_session_reports_its_progress_up_to_the_whole(tmp_path):
    """Reading the journal and writing the file report fractions that only grow and end at 1,
    through the journal's records (several reports) and the sensors written."""
    from mimucap.io.journal.to_session import PROGRESS_EVERY_RECORDS
    from mimucap.session.live.recorder import READING_SHARE

    out = tmp_path / "s.h5"
    recorder = Recorder(out, {}, RecorderSettings(fsync=False))
    recorder.start(start_host_s=T0)
    blocks = 3 * PROGRESS_EVERY_RECORDS // 2
    for k in range(blocks):
        recorder.add_blocks([block("1", 2 * k, 2), block("2", 2 * k, 2, full=False)])
    recorder.close()
    fractions: list[float] = []
    result = recorder.write_session(fractions.append)
    assert result.complete and len(read_session(out).sensors["1"]) == 2 * blocks
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    reading = [f for f in fractions if f < READING_SHARE]
    assert len(reading) >= 3 and reading[0] < 0.01  # a report every PROGRESS_EVERY_RECORDS records
    assert len([f for f in fractions if f > READING_SHARE]) == 2  # one per sensor written


def test_a_crash_is_recovered_up_to_the_last_flush(tmp_path):
    out = tmp_path / "crash.h5"
    recorder = Recorder(out, {"source": "simulated:demo"}, RecorderSettings(flush_interval_s=0.1))
    recorder.start(start_host_s=T0)
    for k in range(5):
        recorder.add_blocks([block("7", 20 * k, 20)])
    time.sleep(0.12)
    recorder.tick()                                # flushed: 100 samples are safe
    journal = journal_path_for(out)
    with open(journal, "ab") as handle:             # the crash tore the next record
        handle.write(b"\x40\x00\x00\x00garbage")
    whole = journal.read_bytes()
    result = recover(out)
    assert not result.complete and "damaged" in result.message
    session = read_session(out)
    np.testing.assert_array_equal(session.sensors["7"].seq, np.arange(100))
    assert session.metadata["recording"]["ended"].startswith("crash")
    assert not journal.exists()
    kept = journal.with_name(journal.name + ".damaged")  # nothing after the damage is thrown away
    assert kept.read_bytes() == whole and str(kept) in result.message
    with pytest.raises(ValueError, match="no journal"):
        recover(out)


def truth_rows(first: int, n: int, rate: float = 100.0):
    """Simulator truth rows ``first`` … ``first + n - 1``: host times, a knee turning about x
    by ``row`` degrees, its angle, and the root walking north at 1 m/s."""
    rows = np.arange(first, first + n)
    half = np.radians(rows) / 2.0
    q = np.column_stack([np.cos(half), np.sin(half), np.zeros(n), np.zeros(n)])
    root = np.column_stack([np.zeros(n), rows / rate, np.full(n, 0.9)])
    return T0 + rows / rate, {"shank_r": q, "pelvis": np.tile([1.0, 0, 0, 0], (n, 1))}, \
        {"knee_r_flexion_deg": rows.astype(float)}, root


def test_the_simulator_truth_is_journaled_and_survives_a_crash(tmp_path):
    out = tmp_path / "truth.h5"
    recorder = Recorder(out, {"source": "simulated:walk"}, RecorderSettings(flush_interval_s=0.1))
    recorder.start(start_host_s=T0 + 0.05)  # truth rows before the start are not kept
    for k in range(4):
        recorder.add_blocks([block("1", 25 * k, 25)])
        recorder.add_truth(*truth_rows(25 * k, 25), note="simulated suit")
    recorder.add_truth(*truth_rows(99, 1))  # a repeated instant is kept once
    time.sleep(0.12)
    recorder.tick()
    # No stop: the process died here. Recovery rebuilds samples and truth from the journal.
    recover(out)
    truth = read_session(out).truth
    np.testing.assert_allclose(truth.t_s, np.arange(5, 100) / 100.0 - 0.05, atol=1e-9)
    np.testing.assert_allclose(truth.joint_angles_deg["knee_r_flexion_deg"], np.arange(5, 100))
    np.testing.assert_allclose(truth.q_world_from_segment["shank_r"][0], truth_rows(5, 1)[1]["shank_r"][0])
    np.testing.assert_allclose(truth.extra["root_position_m"][-1], [0.0, 0.99, 0.9])
    assert truth.attributes["origin"] == "simulated suit"


def test_a_damaged_truth_record_names_the_record(tmp_path):
    from mimucap.io.journal.records import KIND_TRUTH, decode_truth, encode_truth

    payload = encode_truth(*truth_rows(0, 3))
    part = decode_truth(payload)
    np.testing.assert_allclose(part.joint_angles_deg["knee_r_flexion_deg"], [0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match="wrong number of values for 3 rows"):
        decode_truth(payload[:-8])
    out = tmp_path / "bad.h5"
    recorder = Recorder(out, {"source": "simulated:walk"})
    recorder.start(start_host_s=T0)
    recorder.add_blocks([block("1", 0, 10)])
    recorder._append(KIND_TRUTH, payload[:-8])  # written whole (CRC matches) but does not add up
    recorder.close()
    with pytest.raises(ValueError, match="record 3 is damaged: truth record holds the wrong number"):
        recorder.write_session()


def closed_journal(out, blocks_per_sensor: int = 30):
    """A recorder journal of two sensors left behind without its session file (as after a
    crash), and the byte offset where each of its records starts."""
    recorder = Recorder(out, {"source": "simulated:demo", "sensor_segments": {"1": "pelvis"}},
                        RecorderSettings(flush_interval_s=0.1))
    recorder.start(start_host_s=T0)
    for k in range(blocks_per_sensor):
        recorder.add_blocks([block("1", 20 * k, 20), block("2", 20 * k, 20, full=False)])
    recorder.close(None, "duration")
    journal = journal_path_for(out)
    starts, offset = [], 12
    for _kind, payload in read_journal(journal).records:
        starts.append(offset)
        offset += 8 + 1 + len(payload)
    return journal, starts


def test_damage_in_the_middle_of_a_journal_costs_only_the_records_it_hits(tmp_path):
    reference, _ = closed_journal(tmp_path / "ref.h5")
    assert recover(tmp_path / "ref.h5").complete
    whole = read_session(tmp_path / "ref.h5")
    out = tmp_path / "hit.h5"
    journal, starts = closed_journal(out)
    raw = bytearray(journal.read_bytes())
    first = starts[21] + 40                           # 200 bytes inside record 21: one block of sensor "1"
    raw[first:first + 200] = bytes(b ^ 0xA5 for b in raw[first:first + 200])
    journal.write_bytes(bytes(raw))
    result = recover(out)
    damaged_bytes = starts[22] - starts[21]
    assert f"skipped {damaged_bytes} damaged bytes at offset {starts[21]}" in result.message
    assert f"{len(starts) - 22} records after it recovered" in result.message
    assert "torn" not in result.message and not result.complete
    session = read_session(out)
    one, two = session.sensors["1"], session.sensors["2"]
    assert len(one) == len(whole.sensors["1"]) - 20 and len(two) == len(whole.sensors["2"])
    np.testing.assert_array_equal(one.seq, np.r_[np.arange(200), np.arange(220, 600)])   # block 10 lost
    np.testing.assert_array_equal(two.seq, whole.sensors["2"].seq)
    assert one.segment == "pelvis" and session.metadata["recording"]["ended"] == "duration"
    assert session.metadata["recording"]["journal_skipped_bytes"] == [[starts[21], damaged_bytes]]
    kept = journal.with_name(journal.name + ".damaged")
    assert not journal.exists() and kept.read_bytes() == bytes(raw) and str(kept) in result.message


def test_a_damaged_start_record_keeps_the_samples_after_it(tmp_path):
    out = tmp_path / "start.h5"
    journal, starts = closed_journal(out, blocks_per_sensor=5)
    raw = bytearray(journal.read_bytes())
    raw[starts[0] + 20] ^= 0xFF
    journal.write_bytes(bytes(raw))
    result = recover(out)
    assert "start record was damaged" in result.message
    assert f"skipped {starts[1] - starts[0]} damaged bytes at offset {starts[0]}" in result.message
    session = read_session(out)
    assert len(session.sensors["1"]) == 100 and len(session.sensors["2"]) == 100
    assert session.sensors["1"].t_s[0] == 0.0 and session.metadata["recording"]["start_record_lost"]


def test_open_session_recovers_first_and_a_stale_journal_blocks_a_new_recording(tmp_path):
    out = tmp_path / "o.h5"
    recorder = Recorder(out, {}, RecorderSettings(flush_interval_s=0.1))
    recorder.start(start_host_s=T0)
    recorder.add_blocks([block("1", 0, 10)])
    recorder._journal.flush()   # what a crash leaves: a flushed journal, no session file
    with pytest.raises(ValueError, match="mimucap recover"):
        Recorder(out).start()
    session = open_session(out)
    assert len(session.sensors["1"]) == 10


DISK_FULL_SCRIPT = r"""
import json, resource, signal, sys, time
import numpy as np
sys.path.insert(0, {test_dir!r})
from test_recording import block
from mimucap.session.live.recorder import Recorder, RecorderSettings
out = {out!r}
recorder = Recorder(out, {{}}, RecorderSettings(flush_interval_s=0.05))
recorder.start(start_host_s=1000.0)
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)         # writes beyond the limit fail with EFBIG
resource.setrlimit(resource.RLIMIT_FSIZE, (300_000, 300_000))
sent = 0
while recorder.add_blocks([block("1", sent, 100)]):
    sent += 100
    time.sleep(0.001)
result = recorder.stop(None, "duration")
print(json.dumps({{"sent": sent, "failure": recorder.failure, "message": result.message,
                  "session": None if result.session_path is None else str(result.session_path)}}))
"""


def test_a_full_disk_ends_with_a_clear_message_and_a_readable_file(tmp_path):
    out = tmp_path / "full.h5"
    script = DISK_FULL_SCRIPT.format(test_dir=str(__import__("pathlib").Path(__file__).parent), out=str(out))
    completed = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert completed.returncode == 0, completed.stderr
    report = json.loads(completed.stdout.strip().splitlines()[-1])
    assert "disk is full" in report["failure"] and "mimucap recover" in report["failure"]
    if report["session"] is None:                   # the session did not fit either: recover later
        assert "disk is full" in report["message"]
        assert read_journal(journal_path_for(out)).records
        recover(out)
    session = read_session(out)
    seq = session.sensors["1"].seq
    assert 0 < len(seq) <= report["sent"] + 100
    np.testing.assert_array_equal(seq, np.arange(len(seq)))   # a clean prefix, nothing invented


def test_the_gui_loop_records_a_simulated_suit(tmp_path):
    """The loop of docs/protocols.md: poll without blocking, record, stop."""
    from mimucap.acquisition.supervisor import Supervisor
    from mimucap.session.sources.source_configs import sensor_segments, source_configs

    configs = source_configs("simulated:walk")
    sensors = [f"S{i:02d}" for i in range(1, 11)]
    recorder = Recorder(tmp_path / "gui.h5", {"source": "simulated:walk", "sensor_segments": sensor_segments(configs)})
    with Supervisor(configs) as supervisor:
        recorder.start()
        # Until every sensor has given a good second (the workers' start is slow on a busy machine).
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline and not (
                len(recorder.samples) == len(sensors) and min(recorder.samples.values()) > 150):
            blocks = supervisor.poll(0.0)                 # never blocks
            assert recorder.add_blocks(blocks)
            time.sleep(0.02)
        recorder.add_blocks(supervisor.stop())
    result = recorder.stop({"sensors": {k: v.received for k, v in supervisor.stats().items()}})
    session = read_session(result.session_path)
    assert sorted(session.sensors) == sensors and session.sensors["S03"].segment == "upper_arm_l"
    assert all(len(s) > 100 for s in session.sensors.values())
