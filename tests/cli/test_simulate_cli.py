"""``mimucap simulate`` end to end: the file it writes, determinism, and one-line errors."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

from mimucap.cli import main
from mimucap.core import rotation as rot
from mimucap.io.session import read_session

REPO = Path(__file__).resolve().parents[2]


def _datasets(path: Path) -> dict[str, bytes]:
    """Every dataset's stored bytes (strings by value)."""
    found: dict[str, bytes] = {}

    def visit(name: str, item) -> None:
        if isinstance(item, h5py.Dataset):
            value = item[()]
            is_text = item.dtype.kind == "O" or item.shape == ()
            found[name] = repr(np.asarray(value).tolist()).encode() if is_text else value.tobytes()

    with h5py.File(path, "r") as h5:
        h5.visititems(visit)
    return found


def test_simulate_writes_a_readable_session(tmp_path: Path, capsys) -> None:
    out = tmp_path / "demo.h5"
    code = main(["simulate", "--scenario", "demo", "--duration", "4", "--sensors", "17", "--seed", "3",
                 "--out", str(out), "--rate", "50", "--drops", "0.02", "--onboard", "--no-magcal-turns"])
    assert code == 0
    line = capsys.readouterr().out.strip()
    assert line.startswith(f"wrote {out}: scenario demo, 17 sensors on fifteen_segment, 4 s at 50 Hz")
    assert "\n" not in line
    session = read_session(out)
    assert sorted(session.sensors) == [f"S{i:02d}" for i in range(1, 18)]
    assert session.metadata["source"]["kind"] == "simulated" and session.metadata["source"]["seed"] == 3
    assert session.metadata["sensor_segments"]["S14"] == "foot_l"
    stream = session.sensors["S05"]
    assert stream.segment == "forearm_l" and stream.q_world_from_sensor is not None
    assert len(stream) < 200 and np.all(np.diff(stream.seq) >= 1)
    assert [m.label for m in session.markers][:2] == ["N-pose", "T-pose"]
    truth = session.truth
    assert truth.t_s.shape == (200,)
    sensor = truth.sensors["S05"]
    expected = rot.multiply(truth.q_world_from_segment["forearm_l"], sensor.q_segment_from_sensor)
    assert np.degrees(rot.angle_between(expected, sensor.q_world_from_sensor)).max() < 1e-9
    assert sensor.mag_A.shape == (3, 3) and np.abs(sensor.mag_b_uT).max() <= 40.0
    assert np.linalg.norm(truth.field_world_uT) == np.float64(np.linalg.norm(truth.field_world_uT))
    assert abs(np.linalg.norm(truth.field_world_uT) - 49.3) < 1e-9


def test_same_seed_gives_identical_datasets_other_seed_differs(tmp_path: Path, capsys) -> None:
    paths = []
    for name, seed in (("a.h5", "7"), ("b.h5", "7"), ("c.h5", "8")):
        paths.append(tmp_path / name)
        assert main(["simulate", "--scenario", "walk", "--duration", "2", "--sensors", "10", "--seed", seed,
                     "--out", str(paths[-1])]) == 0
    a, b, c = (_datasets(p) for p in paths)
    assert a == b
    assert a["sensors/S01/mag_uT"] != c["sensors/S01/mag_uT"]
    assert main(["simulate", "--scenario", "npose", "--duration", "1", "--seed", "7", "--no-truth",
                 "--out", str(tmp_path / "n.h5")]) == 0
    assert read_session(tmp_path / "n.h5").truth is None


def test_disturbance_reaches_the_file(tmp_path: Path, capsys) -> None:
    out = tmp_path / "d.h5"
    assert main(["simulate", "--scenario", "npose", "--duration", "4", "--sensors", "2", "--seed", "1",
                 "--disturbance", "30,0,-10,1.5,3", "--out", str(out)]) == 0
    session = read_session(out)
    t = session.truth.t_s
    extra = session.truth.sensors["S01"].field_world_uT - session.truth.field_world_uT
    inside = (t > 2.0) & (t < 2.5)
    np.testing.assert_allclose(extra[inside], np.tile([30.0, 0.0, -10.0], (int(inside.sum()), 1)), atol=1e-9)
    np.testing.assert_allclose(extra[(t < 1.0) | (t > 3.5)], 0.0, atol=1e-12)
    assert session.metadata["source"]["disturbances"][0]["field_uT"] == [30.0, 0.0, -10.0]


def test_the_room_reaches_the_file(tmp_path: Path, capsys) -> None:
    """``--room clinic``: each unit measures the room's field where it is (the shank more than the
    pelvis), and the file says which room it was."""
    out = tmp_path / "clinic.h5"
    assert main(["simulate", "--scenario", "walk", "--duration", "5", "--seed", "1", "--room", "clinic",
                 "--out", str(out)]) == 0
    assert "room clinic" in capsys.readouterr().out
    session = read_session(out)
    assert session.metadata["source"]["room"] == "clinic" and session.truth.attributes["room"] == "clinic"
    deviation = {sid: np.linalg.norm(s.field_world_uT - session.truth.field_world_uT, axis=1).mean()
                 for sid, s in session.truth.sensors.items()}
    assert deviation["S09"] > 1.5 * deviation["S01"] > 0.0
    assert main(["simulate", "--room", "kitchen", "--out", str(tmp_path / "x.h5")]) == 1
    err = capsys.readouterr().err.strip()
    assert err == "mimucap simulate: error: unknown room 'kitchen'; use one of clean, clinic, treadmill"


def test_a_clinical_test_writes_its_true_results_into_the_truth_group(tmp_path: Path, capsys) -> None:
    import h5py

    out = tmp_path / "tug.h5"
    assert main(["simulate", "--scenario", "tug", "--duration", "60", "--sensors", "2", "--seed", "4",
                 "--magcal-turns", "--out", str(out)]) == 0
    session = read_session(out)
    protocol = session.truth.protocol
    assert protocol["test"] == "tug" and set(protocol) >= {"total_s", "sit_to_stand_s", "walk_out_s", "turn_s",
                                                           "walk_back_s", "turn_to_sit_s"}
    with h5py.File(out, "r") as h5:
        assert "protocol_json" in h5["truth"].attrs
    assert [m.label for m in session.markers][:4] == ["magnetometer turns", "N-pose", "T-pose", "N-pose"]
    assert read_session(out, include_truth=False).truth is None


def test_bad_arguments_give_one_line(tmp_path: Path, capsys) -> None:
    assert main(["simulate", "--scenario", "jog", "--out", str(tmp_path / "x.h5")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("mimucap simulate: error: unknown scenario 'jog'") and "\n" not in err
    assert main(["simulate", "--sensors", "0", "--out", str(tmp_path / "x.h5")]) == 1
    assert "number of sensors must be 1..17" in capsys.readouterr().err
    assert main(["simulate", "--duration", "1", "--out", str(tmp_path / "missing" / "x.h5")]) == 1
    assert "does not exist" in capsys.readouterr().err
    assert main(["simulate", "--disturbance", "30,0,x,1,2", "--out", str(tmp_path / "x.h5")]) == 1
    assert "--disturbance '30,0,x,1,2': expected five numbers" in capsys.readouterr().err
    assert main(["simulate", "--disturbance", "30,0,0,2,1", "--out", str(tmp_path / "x.h5")]) == 1
    assert "must end after it starts" in capsys.readouterr().err
    for duration in ("0", "0.004"):
        assert main(["simulate", "--duration", duration, "--out", str(tmp_path / "x.h5")]) == 1
        assert "holds no sample at 100 Hz: give at least 0.01 s" in capsys.readouterr().err
    assert main(["simulate", "--duration", "1e6", "--sensors", "17", "--rate", "1000",
                 "--out", str(tmp_path / "x.h5")]) == 1        # refused before any memory is taken
    assert "at most 353 s at this rate and sensor count" in capsys.readouterr().err
    assert main(["simulate", "--duration", "1", "--out", str(tmp_path / "x.csv")]) == 1
    assert "name it .h5 or .hdf5" in capsys.readouterr().err
    assert not (tmp_path / "x.h5").exists() and not (tmp_path / "x.csv").exists()


def test_memory_exhaustion_and_a_closed_pipe_are_not_tracebacks(tmp_path: Path, monkeypatch, capsys) -> None:
    import mimucap.core.simulate.suit as simulate_command  # the command imports it when it runs

    def exhausted(config):
        raise MemoryError

    monkeypatch.setattr(simulate_command, "simulate_session", exhausted)
    assert main(["simulate", "--duration", "1", "--out", str(tmp_path / "x.h5")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("mimucap simulate: error: not enough memory") and "\n" not in err
    # `mimucap … | head -1`: the reader leaving early is not an error (no "Broken pipe" message)
    import mimucap.cli as cli

    def reader_gone(config):
        raise BrokenPipeError(32, "Broken pipe")

    quieted = []
    monkeypatch.setattr(simulate_command, "simulate_session", reader_gone)
    monkeypatch.setattr(cli, "_quiet_stdout", lambda: quieted.append(True))  # not this test process's stdout
    assert main(["simulate", "--duration", "1", "--out", str(tmp_path / "x.h5")]) == 0
    assert capsys.readouterr().err == "" and quieted == [True]


def test_installed_command_runs(tmp_path: Path) -> None:
    executable = Path(sys.executable).parent / "mimucap"
    out = tmp_path / "s.h5"
    done = subprocess.run([str(executable), "simulate", "--scenario", "squat", "--duration", "2", "--sensors", "10",
                           "--seed", "1", "--out", str(out)], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert done.returncode == 0, done.stderr
    assert done.stdout.count("\n") == 1 and "scenario squat" in done.stdout
    assert len(read_session(out).sensors) == 10
