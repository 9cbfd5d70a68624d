"""``mimucap stream --lsl`` as a user runs it (a real subprocess), an inlet of another program
beside it; and what the commands say without pylsl or pyxdf."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np
import pytest

MIMUCAP = [sys.executable, "-m", "mimucap"]


def test_stream_publishes_a_mocap_stream_that_an_inlet_beside_it_receives():
    pylsl = pytest.importorskip("pylsl", reason="pylsl is not installed (pip install 'mimucap[lsl]'; make test installs it)")
    process = subprocess.Popen(MIMUCAP + ["stream", "--source", "simulated", "--lsl", "--duration", "6"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        found = pylsl.resolve_bypred("type='MoCap' and contains(name, 'MimuCap')", 1, 20.0)
        assert found, "no MoCap stream named MimuCap appeared"
        inlet = pylsl.StreamInlet(found[0], max_buflen=30)
        inlet.open_stream(5.0)
        info = inlet.info(5.0)
        stamps: list[float] = []
        end = time.monotonic() + 4.0
        while time.monotonic() < end:
            _values, new = inlet.pull_chunk(timeout=0.1)
            stamps.extend(new)
        out, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, err
    assert len(stamps) >= 380
    assert np.all(np.diff(stamps) > 0)
    labels = []
    channel = info.desc().child("channels").child("channel")
    while not channel.empty():
        labels.append(channel.child_value("label"))
        channel = channel.next_sibling()
    assert len(labels) == info.channel_count() == 40 and len(set(labels)) == 40 and labels[0] == "pelvis_qw"
    assert "MimuCap segments:" in out and "at 100 Hz nominal" in out


def _without(tmp_path, module: str) -> dict[str, str]:
    """An environment whose Python cannot import ``module`` (a stand-in that raises ImportError)."""
    (tmp_path / f"{module}.py").write_text(f'raise ImportError("no module named {module} (test stand-in)")\n')
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), env.get("PYTHONPATH", "")])
    return env


def test_without_pylsl_stream_says_how_to_install_it(tmp_path):
    completed = subprocess.run(MIMUCAP + ["stream", "--source", "simulated", "--lsl", "--duration", "1"],
                               capture_output=True, text=True, timeout=60, env=_without(tmp_path, "pylsl"))
    assert completed.returncode == 1
    assert "pip install 'mimucap[lsl]'" in completed.stderr


def test_without_pyxdf_import_says_how_to_install_it(tmp_path):
    (tmp_path / "lab.xdf").write_bytes(b"XDF:")
    completed = subprocess.run(MIMUCAP + ["import", str(tmp_path / "lab.xdf"), "--out", str(tmp_path / "s.h5")],
                               capture_output=True, text=True, timeout=60, env=_without(tmp_path, "pyxdf"))
    assert completed.returncode == 1
    assert "pip install 'mimucap[lsl]'" in completed.stderr


def test_stream_asks_for_its_output():
    from mimucap.cli import main

    with pytest.raises(SystemExit):
        main(["stream", "--lsl"])   # --source is required
    assert main(["stream", "--source", "simulated"]) == 1   # no --lsl: said, not streamed


def test_an_xdf_without_mimucap_streams_is_refused_naming_its_streams(tmp_path):
    pytest.importorskip("pyxdf", reason="pyxdf is not installed (pip install 'mimucap[lsl]')")
    from tests.xdf_recorder import RecordedStream, write_xdf

    from mimucap.cli import main

    header = ('<?xml version="1.0"?><info><name>EEG amp</name><type>EEG</type><channel_count>1</channel_count>'
              '<nominal_srate>250</nominal_srate><channel_format>float32</channel_format></info>')
    write_xdf(tmp_path / "eeg.xdf", [RecordedStream(header, "float32", [1.0, 1.004], [[0.5], [0.6]])])
    assert main(["import", str(tmp_path / "eeg.xdf"), "--out", str(tmp_path / "s.h5")]) == 1
    assert not (tmp_path / "s.h5").exists()


def test_stream_applies_the_body_calibration_file_with_its_magnetometers(tmp_path, monkeypatch, capsys):
    pytest.importorskip("pylsl", reason="pylsl is not installed (pip install 'mimucap[lsl]'; make test installs it)")
    from mimucap.cli import main
    from mimucap.cli.stream import apply_calibration_file
    from mimucap.io.calibration_store import CalibrationStore
    from mimucap.session.live.live_session import open_live_session

    monkeypatch.setenv("MIMUCAP_DATA_DIR", str(tmp_path / "data"))
    recording = tmp_path / "poses.h5"
    assert main(["simulate", "--scenario", "demo", "--duration", "40", "--out", str(recording)]) == 0
    assert main(["magcal", "fit", str(recording), "--save"]) == 0
    calibration = tmp_path / "cal.json"
    assert main(["bodycal", str(recording), "--out", str(calibration)]) == 0
    session = open_live_session("simulated", calibration_store=CalibrationStore(tmp_path / "empty store"))
    apply_calibration_file(session, calibration)
    assert session.body_calibration is not None
    assert sorted(session.mag_calibrations) == sorted(session.body_calibration.sensors.values())
    capsys.readouterr()
    assert main(["stream", "--source", "simulated", "--lsl", "--duration", "1.5",
                 "--calibration", str(calibration)]) == 0
    assert "MimuCap joint angles:" in capsys.readouterr().out
    assert main(["stream", "--source", "simulated", "--lsl", "--duration", "1",
                 "--calibration", str(tmp_path / "missing.json")]) == 1


def test_markers_pushed_by_another_program_land_in_the_recording_at_their_times(tmp_path):
    pylsl = pytest.importorskip("pylsl", reason="pylsl is not installed (pip install 'mimucap[lsl]'; make test installs it)")
    from mimucap.io.session import read_session

    name = f"Stimuli {os.getpid()} {time.monotonic_ns()}"
    stimuli = pylsl.StreamOutlet(pylsl.StreamInfo(name, "Markers", 1, 0, "string", f"stimuli-{name}"))
    out = tmp_path / "with-stimuli.h5"
    process = subprocess.Popen(MIMUCAP + ["stream", "--source", "simulated", "--lsl", "--duration", "4",
                                          "--lsl-markers", name, "--out", str(out)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    pushed = []
    try:
        assert "markers from" in process.stdout.readline()   # streaming, the marker inlet open
        for label in ("tone 1", "tone 2", "plate trigger"):
            time.sleep(0.4)
            stamp = pylsl.local_clock() - 0.02
            stimuli.push_sample([label], stamp)
            pushed.append((label, stamp))
        rest, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, err
    assert f"3 markers taken from {name!r}" in rest
    session = read_session(out)
    start = session.metadata["lsl_clock"]["session_start_lsl_s"]
    at = {m.label: m.t_s + start for m in session.markers}
    for label, stamp in pushed:
        assert abs(at[label] - stamp) < 0.010, (label, at[label] - stamp)
