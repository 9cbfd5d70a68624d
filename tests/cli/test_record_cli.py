"""``mimucap record`` / ``recover`` / ``emulate`` as a user runs them (real subprocesses)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mimucap.cli import main
from mimucap.io.session import read_session
from mimucap.session.recording import journal_path_for

MIMUCAP = [sys.executable, "-m", "mimucap"]


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def wait_until_bound(port: int, timeout_s: float = 60.0) -> None:
    """Until a socket is bound to UDP ``port`` (read from ``/proc/net/udp``, so that the test never
    holds the port itself while the worker binds it)."""
    suffix = f":{port:04X}"
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        lines = Path("/proc/net/udp").read_text().splitlines()[1:]
        if any(line.split()[1].endswith(suffix) for line in lines if len(line.split()) > 1):
            return
        time.sleep(0.05)
    raise AssertionError(f"nothing bound UDP port {port} within {timeout_s:.0f} s")


def children_of(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                found.append(int(entry.name))
    return found


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def test_kill_9_during_record_loses_at_most_the_last_second(tmp_path):
    out = tmp_path / "crash.h5"
    journal = journal_path_for(out)
    process = subprocess.Popen(MIMUCAP + ["record", "--source", "simulated:walk", "--duration", "60",
                                          "--out", str(out), "--quiet"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and (not journal.exists() or journal.stat().st_size < 100_000):
            time.sleep(0.05)
        assert journal.exists(), process.stderr.read1().decode() if process.poll() is not None else ""
        time.sleep(1.0)
        workers = children_of(process.pid)
        killed_at = time.monotonic()
        os.kill(process.pid, signal.SIGKILL)
    finally:
        process.wait(10)
    assert workers, "the recorder should have a worker process"
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline and any(alive(w) for w in workers):
        time.sleep(0.05)
    assert not any(alive(w) for w in workers), "orphaned workers must stop when the recorder dies"
    assert not out.exists()

    recovered = subprocess.run(MIMUCAP + ["recover", str(out)], capture_output=True, text=True, timeout=60)
    assert recovered.returncode == 0, recovered.stderr
    session = read_session(out)
    t0 = session.metadata["recording"]["start_host_monotonic_s"]
    assert len(session.sensors) == 10
    assert session.sensors["S01"].segment == "pelvis" and session.metadata["source"] == "simulated:walk"
    assert "walk" in [m.label for m in session.markers]     # the simulator's activity markers
    for sensor_id, stream in session.sensors.items():
        # every sample older than one second before the kill is there, without gaps
        assert t0 + stream.t_s[-1] >= killed_at - 1.0, sensor_id
        np.testing.assert_array_equal(stream.seq, np.arange(stream.seq[0], stream.seq[0] + len(stream)))
        np.testing.assert_allclose(np.diff(stream.t_s), 0.01, atol=1e-9)
    assert not journal.exists()


def test_emulated_udp_nodes_recorded_with_loss_reported_as_drops(tmp_path):
    port = free_udp_port()
    out = tmp_path / "udp.h5"
    record = subprocess.Popen(MIMUCAP + ["record", "--source", f"udp:127.0.0.1:{port}", "--duration", "5",
                                         "--out", str(out), "--sensors", "1-3", "--quiet"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_until_bound(port)   # the worker has bound the port: nothing the emulator sends is lost before
    emulate = subprocess.run(MIMUCAP + ["emulate", "udp", "--sensors", "4", "--rate", "100", "--target",
                                        f"127.0.0.1:{port}", "--loss", "0.1", "--duration", "2.5",
                                        "--drift", "100", "--offset-ms", "40"],
                             capture_output=True, text=True, timeout=60)
    assert emulate.returncode == 0, emulate.stderr
    stdout, stderr = record.communicate(timeout=60)
    assert record.returncode == 0, stderr
    session = read_session(out)
    assert sorted(session.sensors) == ["1", "2", "3"]            # node 4 is not part of the session
    sources = session.metadata["acquisition"]["sources"]["udp"]
    assert sources["rejections"]["unknown_sensor"] > 200
    sensors = session.metadata["acquisition"]["sensors"]
    for sensor_id, stream in session.sensors.items():
        expected = stream.seq[-1] - stream.seq[0] + 1
        assert len(stream) + sensors[sensor_id]["drops"] == expected
        assert 0.03 < sensors[sensor_id]["drops"] / expected < 0.2        # --loss 0.1
        assert 200 <= expected <= 250
        assert np.all(np.diff(stream.t_s) > 0)
        assert stream.acc is not None and np.all(np.isfinite(stream.acc))
    assert "wrote" in stdout


def test_a_malformed_source_is_one_line_naming_the_valid_forms(tmp_path):
    completed = subprocess.run(MIMUCAP + ["record", "--source", "tcp:1.2.3.4", "--duration", "1",
                                          "--out", str(tmp_path / "x.h5")], capture_output=True, text=True)
    assert completed.returncode == 1
    lines = completed.stderr.strip().splitlines()
    assert len(lines) == 1 and "serial:DEVICE[@BAUD]" in lines[0] and "replay:FILE[@SPEED]" in lines[0]


def test_record_from_the_serial_emulator_survives_its_unplug(tmp_path):
    link = tmp_path / "ttyMIMU"
    out = tmp_path / "serial.h5"
    # the recorder starts first and waits for the device to appear (plugged in late)
    record = subprocess.Popen(MIMUCAP + ["record", "--source", f"serial:{link}@115200", "--duration", "6",
                                         "--out", str(out), "--sensors", "1-2"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    emulate = None
    try:
        for _ in range(10):                    # progress lines, one a second, until the worker waits
            progress = record.stderr.readline()
            if "disconnected" in progress:
                break
        assert "cannot open" in progress, progress
        emulate = subprocess.Popen(MIMUCAP + ["emulate", "serial", "--sensors", "2", "--rate", "50", "--link",
                                              str(link), "--duration", "3", "--unplug-after", "1.2",
                                              "--unplug-for", "0.6"],
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert emulate.stdout.readline().strip() == str(link)      # the device path comes first
        _stdout, stderr = record.communicate(timeout=60)
    finally:
        if emulate is not None:
            emulate.wait(30)
        if record.poll() is None:
            record.kill()
    assert record.returncode == 0, stderr
    session = read_session(out)
    assert sorted(session.sensors) == ["1", "2"]
    assert session.metadata["acquisition"]["sources"]["serial"]["reconnects"] == 1
    for stream in session.sensors.values():
        gaps = np.diff(stream.t_s)
        assert 0.4 < gaps.max() < 1.2                      # the unplugged time is a visible gap
        assert abs(np.median(gaps) - 0.02) < 1e-3          # 50 Hz
        assert len(stream) > 60                            # data before and after the unplug


def test_a_source_that_cannot_start_ends_with_its_reason(tmp_path):
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as blocker:
        blocker.bind(("127.0.0.1", 0))
        port = blocker.getsockname()[1]
        completed = subprocess.run(MIMUCAP + ["record", "--source", f"udp:127.0.0.1:{port}", "--duration", "2",
                                              "--out", str(tmp_path / "busy.h5"), "--quiet"],
                                   capture_output=True, text=True, timeout=60)
    assert completed.returncode == 1
    assert "source udp failed" in completed.stderr and "Address already in use" in completed.stderr
    assert read_session(tmp_path / "busy.h5").sensors == {}      # still a readable (empty) session


def test_a_recording_that_received_nothing_fails_and_says_why(tmp_path):
    out = tmp_path / "missing.h5"
    completed = subprocess.run(MIMUCAP + ["record", "--source", f"serial:{tmp_path / 'ttyUSB9'}", "--duration", "2.5",
                                          "--out", str(out), "--quiet"], capture_output=True, text=True, timeout=60)
    assert completed.returncode == 1
    assert "no sample was received" in completed.stderr and "cannot open" in completed.stderr
    assert "ttyUSB9" in completed.stderr and str(out) in completed.stderr
    assert read_session(out).sensors == {}


@pytest.mark.parametrize(("options", "message"), [
    (["--source", "simulated", "--sensor-count", "0"], "--sensor-count must be at least 1, got 0"),  # was: 10 sensors
    (["--source", "simulated", "--rate", "0"], "--rate must be a positive number of Hz, got 0"),       # was: 100 Hz
    (["--source", "udp:127.0.0.1:5999", "--sensors", "10-1"], "--sensors '10-1': the range 10-1 is empty"),
    (["--source", "simulated", "--sensors", "1-3"], "--sensors applies to udp and serial sources only"),
    (["--source", "serial:/dev/ttyUSB0", "--allow", "10.0.0.2"], "--allow applies to udp sources only"),
    (["--source", "udp:127.0.0.1:5999", "--sensor-count", "4"], "--sensor-count applies to simulated sources only"),
])
def test_record_refuses_option_values_it_would_replace_or_ignore(tmp_path, capsys, options, message):
    out = tmp_path / "x.h5"
    assert main(["record", *options, "--duration", "1", "--out", str(out), "--quiet"]) == 1
    assert message in capsys.readouterr().err
    assert not out.exists() and not Path(f"{out}.journal").exists()


def test_replaying_a_text_file_named_like_a_session_says_it_is_not_hdf5(tmp_path, capsys):
    text = tmp_path / "text.h5"
    text.write_text("t_s,ax\n0,1\n")
    assert main(["record", "--source", f"replay:{text}", "--duration", "1", "--out", str(tmp_path / "x.h5")]) == 1
    err = capsys.readouterr().err           # was: "line 1: no PacketCounter column" (read as an Xsens export)
    assert f"replay file {text}: not an HDF5 session" in err


def test_replayed_invalid_samples_are_rejections_with_their_reason_not_drops(tmp_path, capsys):
    """Was: the 20 NaN accelerometer rows of a replayed session were counted as ``drops``
    (packet loss) and no rejection was reported; a live source refuses such samples as
    ``non_finite`` / ``out_of_range``."""
    from mimucap.core.samples import SensorSamples
    from mimucap.io.session import Session, write_session

    n = 400
    t = np.arange(n) / 100.0
    seq = np.arange(n) + np.where(np.arange(n) >= 300, 5, 0)      # 5 packets really lost before row 300
    rng = np.random.default_rng(3)
    streams = {}
    for sid in ("S01", "S02"):
        acc, gyr = rng.normal(0.0, 1.0, (n, 3)) + [0.0, 0.0, 9.81], rng.normal(0.0, 0.1, (n, 3))
        mag = rng.normal(0.0, 1.0, (n, 3)) + [0.0, 20.0, -40.0]
        if sid == "S02":
            acc[100:120] = np.nan          # 20 NaN rows in the middle
            gyr[200, 1] = np.inf           # one infinite value
            mag[250] = [6000.0, 0.0, 0.0]  # beyond the magnetometer limit (5000 µT)
            acc[395:] = np.nan             # 5 NaN rows at the very end (no sample follows them)
        streams[sid] = SensorSamples(sid, t, seq, acc=acc, gyr=gyr, mag_uT=mag)
    source = write_session(tmp_path / "in.h5", Session(metadata={}, sensors=streams))
    out = tmp_path / "out.h5"
    assert main(["record", "--source", f"replay:{source}@8", "--duration", "60", "--out", str(out), "--quiet"]) == 0
    table = {line.split()[0]: line.split(None, 5) for line in capsys.readouterr().out.splitlines()
             if line.split()[:1] in (["S01"], ["S02"])}
    assert table["S01"][1:3] == ["400", "5"] and table["S01"][5] == "-"            # the real loss stays a drop
    assert table["S02"][1:3] == [str(n - 27), "5"]                                  # was: drops 32, no rejection
    assert table["S02"][5] == "non_finite: 26, out_of_range: 1"
    recorded = read_session(out).sensors["S02"]
    valid = np.ones(n, dtype=bool)
    valid[[*range(100, 120), 200, 250, *range(395, n)]] = False
    np.testing.assert_array_equal(recorded.seq, seq[valid])                        # no valid sample lost
    np.testing.assert_array_equal(recorded.acc, streams["S02"].acc[valid])
    assert np.isfinite(recorded.acc).all() and np.isfinite(recorded.gyr).all()     # no NaN went on
    assert np.abs(recorded.mag_uT).max() < 5000.0


@pytest.mark.parametrize(("options", "message"), [
    (["--unplug-after", "0.2", "--unplug-for=-1"], "--unplug-for must be a number of seconds >= 0, got -1"),
    (["--unplug-after=-1"], "--unplug-after must be a number of seconds >= 0, got -1"),
    (["--unplug-after", "nan"], "--unplug-after must be a number of seconds >= 0, got nan"),
    (["--unplug-for", "2"], "--unplug-for needs --unplug-after"),
])
def test_emulate_serial_refuses_unplug_times_it_would_ignore(tmp_path, capsys, options, message):
    link = tmp_path / "tty"
    assert main(["emulate", "serial", "--sensors", "1", "--duration", "1", "--link", str(link), *options]) == 1
    assert message in capsys.readouterr().err
    assert not link.exists()


def test_emulate_udp_refuses_a_target_host_that_cannot_be_resolved(capsys):
    assert main(["emulate", "udp", "--sensors", "1", "--duration", "1",
                 "--target", "no.such.host.invalid:5005"]) == 1      # was: exit 0 with "100 send errors"
    assert "--target no.such.host.invalid:5005: cannot resolve host 'no.such.host.invalid'" in capsys.readouterr().err


def test_a_headless_recording_stores_which_device_each_sensor_was(tmp_path, capsys):
    """The devices the source told by the end of the recording (the simulated suit's units)
    land in the session's ``devices``, which a calibration's standing is judged against."""
    from mimucap.core.simulate.config import SimulationConfig

    out = tmp_path / "devices.h5"
    assert main(["record", "--source", "simulated:npose", "--sensor-count", "3", "--duration", "1.5",
                 "--out", str(out), "--quiet"]) == 0
    session = read_session(out)
    expected = SimulationConfig(n_sensors=3).device_ids()
    assert session.metadata["devices"] == {sid: {"device_id": device} for sid, device in expected.items()}
    assert {sid: device.device_id for sid, device in session.devices().items()} == expected
