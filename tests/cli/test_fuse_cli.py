"""``mimucap fuse`` and ``mimucap bench orientation`` as a user runs them."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from mimucap.cli import main
from mimucap.core import rotation as rot
from mimucap.core.fusion.evaluation import orientation_errors
from mimucap.core.sensor_samples import SensorSamples
from mimucap.io.broad_trials import read_broad
from mimucap.io.session import Session, write_session
from tests.external_data import data_path

BROAD_DIR = data_path("broad")
TRIAL = BROAD_DIR / "26_disturbed_phone_vibration_A.hdf5"


@pytest.mark.data("broad")
def test_fuse_broad_trial_to_csv(tmp_path, capsys):
    out = tmp_path / "q.csv"
    assert main(["fuse", str(TRIAL), "--out", str(out)]) == 0
    trial = read_broad(TRIAL)
    lines = out.read_text().splitlines()
    assert lines[0] == "t_s,qw,qx,qy,qz"
    assert len(lines) == trial.n_samples + 1
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert np.allclose(table[:, 0], trial.t_s, atol=1e-6)
    # the written orientation is the real one: below Madgwick's published BROAD mean (4.9°)
    errors = orientation_errors(table[:, 1:], trial.q_ref_world_from_sensor, trial.movement)
    assert errors.total_deg < 4.9
    assert "samples" in capsys.readouterr().out


@pytest.mark.data("broad")
@pytest.mark.parametrize("suffix", [".npy", ".h5"])
def test_fuse_other_formats_and_options(tmp_path, suffix):
    out = tmp_path / f"q{suffix}"
    assert main(["fuse", str(TRIAL), "--offline", "--algorithm", "ekf-rk4", "--out", str(out)]) == 0
    n = read_broad(TRIAL).n_samples
    if suffix == ".npy":
        q = np.load(out)
    else:
        with h5py.File(out) as handle:
            q = handle["q_world_from_sensor"][()]
            assert handle["t_s"].shape == (n,) and handle["flags"].shape == (n,)
    assert q.shape == (n, 4)
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0)


def _session(path: Path) -> Path:
    n = 400
    t = np.arange(n) / 100.0
    q = rot.from_axis_angle([0, 0, 1], 0.5 * t)  # turning about the vertical at 0.5 rad/s
    gyr = np.tile([0.0, 0.0, 0.5], (n, 1))
    acc = rot.rotate(rot.conjugate(q), [0, 0, 9.81])
    mag = rot.rotate(rot.conjugate(q), [0, 20, -40])
    sensors = {
        "S01": SensorSamples("S01", t, np.arange(n), acc=acc, gyr=gyr, mag_uT=mag),
        "S02": SensorSamples("S02", t, np.arange(n), acc=acc, gyr=gyr, mag_uT=None),
        "S03": SensorSamples("S03", t, np.arange(n), acc=acc, gyr=None, mag_uT=mag),
    }
    return write_session(path, Session(metadata={}, sensors=sensors))


def test_fuse_session_one_output_per_sensor(tmp_path):
    session = _session(tmp_path / "rec.h5")
    out = tmp_path / "q.csv"
    assert main(["fuse", str(session), "--out", str(out)]) == 0
    assert sorted(p.name for p in tmp_path.glob("q_*.csv")) == ["q_S01.csv", "q_S02.csv"]
    table = np.loadtxt(tmp_path / "q_S01.csv", delimiter=",", skiprows=1)
    truth = rot.from_axis_angle([0, 0, 1], 0.5 * table[:, 0])
    assert np.degrees(rot.angle_between(table[:, 1:], truth)).max() < 1.0
    assert main(["fuse", str(session), "--sensor", "S02", "--no-mag", "--out", str(out)]) == 0
    assert np.loadtxt(out, delimiter=",", skiprows=1).shape == (400, 5)


def test_fuse_user_errors(tmp_path, capsys):
    session = _session(tmp_path / "rec.h5")
    assert main(["fuse", str(session), "--sensor", "S09", "--out", str(tmp_path / "q.csv")]) == 1
    assert "no sensor 'S09'" in capsys.readouterr().err
    assert main(["fuse", str(session), "--sensor", "S03", "--out", str(tmp_path / "q.csv")]) == 1
    assert "S03 has no gyroscope" in capsys.readouterr().err
    assert main(["fuse", str(TRIAL), "--out", str(tmp_path / "q.txt")]) == 1
    assert "must end in" in capsys.readouterr().err
    assert main(["fuse", str(tmp_path / "none.h5"), "--out", str(tmp_path / "q.csv")]) == 1
    assert "no such file" in capsys.readouterr().err


def test_fuse_refuses_input_that_gives_no_orientation_and_counts_invalid_rows(tmp_path, capsys):
    n = 300
    t = np.arange(n) / 100.0
    gyr, mag = np.zeros((n, 3)), np.tile([0.0, 20.0, -40.0], (n, 1))
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    dead = np.zeros((n, 3))                      # a dead accelerometer: no gravity, no orientation
    bad_mag = mag.copy()
    bad_mag[50:60] = np.nan
    sensors = {"S01": SensorSamples("S01", t, np.arange(n), acc=acc, gyr=gyr, mag_uT=bad_mag),
               "S02": SensorSamples("S02", t, np.arange(n), acc=dead, gyr=gyr, mag_uT=mag)}
    path = write_session(tmp_path / "rec.h5", Session(metadata={}, sensors=sensors))
    out = tmp_path / "q.csv"
    assert main(["fuse", str(path), "--out", str(out)]) == 1
    error = capsys.readouterr().err
    assert "rec.h5: sensor S02: fusion gave no orientation" in error and "nothing was written" in error
    assert not list(tmp_path.glob("q*.csv"))     # not even the good sensor's: one command, one outcome
    assert main(["fuse", str(path), "--sensor", "S01", "--out", str(out)]) == 0
    assert "magnetometer rejected 0 and missing or invalid 10" in capsys.readouterr().out

    empty = {"S01": SensorSamples("S01", np.zeros(0), np.zeros(0, int), acc=np.zeros((0, 3)), gyr=np.zeros((0, 3)),
                                 mag_uT=np.zeros((0, 3)))}
    path = write_session(tmp_path / "empty.h5", Session(metadata={}, sensors=empty))
    assert main(["fuse", str(path), "--out", str(out)]) == 1
    assert "empty.h5: sensor S01: no samples (0 rows): nothing to fuse" in capsys.readouterr().err


@pytest.mark.data("broad")
def test_fuse_names_the_dataset_a_broad_trial_lacks(tmp_path, capsys):
    """Was: "not a MimuCap session (no 'format' attribute; foreign HDF5 file?)" for a BROAD
    trial without ``imu_mag``: the BROAD layout was recognised only when complete."""
    for missing, meaning in (("imu_mag", "magnetometer, µT"), ("imu_acc", "accelerometer, m/s²"),
                             ("imu_gyr", "gyroscope, rad/s")):
        trial = tmp_path / f"no_{missing}.hdf5"
        with h5py.File(TRIAL) as src, h5py.File(trial, "w") as dst:
            for name in src:
                if name != missing:
                    dst.create_dataset(name, data=src[name][:1000])
            dst.attrs["sampling_rate"] = src.attrs["sampling_rate"]
        out = tmp_path / "q.csv"
        assert main(["fuse", str(trial), "--out", str(out)]) == 1
        err = capsys.readouterr().err
        if missing == "imu_mag":
            assert f"{trial}: BROAD trial without 'imu_mag' (magnetometer, µT): fuse it without the " \
                   "magnetometer with --no-mag" in err
        else:
            assert f"{trial}: BROAD trial without '{missing}' ({meaning}); it holds " in err
        assert "not a MimuCap session" not in err and not out.exists()
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as handle:
        handle["x"] = np.zeros(3)
    assert main(["fuse", str(foreign), "--out", str(tmp_path / "q.csv")]) == 1
    assert "foreign.h5: not a MimuCap session (no 'format' attribute; foreign HDF5 file?)" in capsys.readouterr().err


@pytest.mark.data("broad")
def test_fuse_no_mag_reads_a_broad_trial_without_a_magnetometer(tmp_path, capsys):
    """Was: ``--no-mag`` on a BROAD trial without ``imu_mag`` was refused for the missing
    dataset the option says not to use. It now gives the same orientation as ``--no-mag`` on
    the same samples with the magnetometer present."""
    complete, partial = tmp_path / "complete.hdf5", tmp_path / "partial.hdf5"
    with h5py.File(TRIAL) as src:
        for path, names in ((complete, ("imu_gyr", "imu_acc", "imu_mag")), (partial, ("imu_gyr", "imu_acc"))):
            with h5py.File(path, "w") as dst:
                for name in names:
                    dst.create_dataset(name, data=src[name][:2000])
                dst.attrs["sampling_rate"] = src.attrs["sampling_rate"]
    outputs = []
    for path in (complete, partial):
        out = tmp_path / f"{path.stem}.npy"
        assert main(["fuse", str(path), "--no-mag", "--out", str(out)]) == 0
        outputs.append(np.load(out))
    capsys.readouterr()
    assert outputs[0].shape == (2000, 4) and np.isfinite(outputs[0][-1]).all()
    np.testing.assert_array_equal(outputs[0], outputs[1])


@pytest.mark.data("broad")
def test_bench_orientation_json(tmp_path, capsys):
    folder = tmp_path / "broad"
    folder.mkdir()
    (folder / TRIAL.name).symlink_to(TRIAL.resolve())
    assert main(["bench", "orientation", str(folder), "--algorithm", "ekf-taylor3",
                 "--algorithm", "taylor3", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["algorithms"] == ["ekf-taylor3", "taylor3"]
    row = report["trials"][0]
    assert row["trial"] == TRIAL.stem and row["category"] == "vibration"
    ours = report["mean"]["ekf-taylor3"]
    assert set(ours) == {"total_deg", "heading_deg", "inclination_deg", "time_s"}
    # VQF 9D (default parameters) scores this trial at 1.75° total RMSE
    assert ours["total_deg"] < 1.75
    # gyro-only integration drifts: far worse than any corrected filter
    assert report["mean"]["taylor3"]["total_deg"] > 3 * ours["total_deg"]
    assert main(["bench", "orientation", str(folder), "--algorithm", "rk4"]) == 0
    assert "MEAN over 1 trials" in capsys.readouterr().out


def _broad_slice(source: Path, target: Path, rows: int, nan_acc: bool = False) -> Path:
    """The first ``rows`` samples of a BROAD trial, all evaluated (``movement`` true),
    optionally with every accelerometer sample NaN."""
    with h5py.File(source) as src, h5py.File(target, "w") as dst:
        for name in ("imu_gyr", "imu_acc", "imu_mag", "opt_quat"):
            data = src[name][:rows]
            if name == "imu_acc" and nan_acc:
                data = np.full_like(data, np.nan)
            dst.create_dataset(name, data=data)
        dst.create_dataset("movement", data=np.ones(rows, dtype=np.uint8))
        dst.attrs["sampling_rate"] = src.attrs["sampling_rate"]
    return target


@pytest.mark.data("broad")
def test_bench_skips_a_trial_with_nothing_to_evaluate_and_names_it(tmp_path, capsys):
    folder = tmp_path / "broad"
    folder.mkdir()
    _broad_slice(TRIAL, folder / "01_good.hdf5", 3000)
    _broad_slice(TRIAL, folder / "02_dead_acc.hdf5", 3000, nan_acc=True)
    assert main(["bench", "orientation", str(folder), "--algorithm", "ekf-taylor3", "--json"]) == 0
    captured = capsys.readouterr()        # was: "no sample to evaluate", exit 1, no trial named
    report = json.loads(captured.out)
    assert [t["trial"] for t in report["trials"]] == ["01_good"]
    assert [s["trial"] for s in report["skipped"]] == ["02_dead_acc"]
    assert "skipped trial 02_dead_acc" in captured.err and "no sample to evaluate" in captured.err
    assert main(["bench", "orientation", str(folder), "--algorithm", "ekf-taylor3"]) == 0
    assert "MEAN over 1 trials" in capsys.readouterr().out
    (folder / "01_good.hdf5").unlink()
    assert main(["bench", "orientation", str(folder), "--algorithm", "ekf-taylor3"]) == 1
    assert "no trial could be evaluated (02_dead_acc: ekf-taylor3: no sample" in capsys.readouterr().err


def test_fuse_checks_the_output_folder_before_fusing(tmp_path, capsys, monkeypatch):
    import mimucap.cli.fuse as fuse_command

    def must_not_read(path, sensor):
        raise AssertionError("the input was read before the output path was checked")

    monkeypatch.setattr(fuse_command, "_inputs", must_not_read)
    blocker = tmp_path / "notes.txt"
    blocker.write_text("a file")
    assert main(["fuse", str(TRIAL), "--out", str(tmp_path / "missing" / "q.csv")]) == 1  # was: [Errno 2] after fusing
    assert f"cannot write {tmp_path / 'missing' / 'q.csv'}: folder {tmp_path / 'missing'} does not exist" \
        in capsys.readouterr().err
    assert main(["fuse", str(TRIAL), "--out", str(blocker / "q.csv")]) == 1
    assert f"{blocker} is a file, not a folder" in capsys.readouterr().err
