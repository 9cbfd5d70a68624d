"""``mimucap magcal fit`` and ``mimucap magcal study`` as a user runs them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mimucap.cli import main
from mimucap.cli.magcal import FAIL_EXIT_STATUS
from mimucap.io.calibration_store import CalibrationStore

JSON_KEYS = {
    "offset_uT", "soft_iron", "field_uT", "rms_residual_uT", "rms_residual_pct", "condition",
    "samples_used", "samples_rejected", "verdict", "reasons", "gyr_correction", "gyr_quality",
}
SET2 = ("mag", "sunsided_hmc5883l", "set-2")


def synthetic_counts(n: int = 600, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    a = np.array([[1.1, 0.05, -0.02], [0.05, 0.95, 0.03], [-0.02, 0.03, 1.0]])
    b_counts = np.array([120.0, -80.0, 35.0])
    counts = (49.3 * u @ a.T) / 0.15 + b_counts
    return counts, a, b_counts


def run_json(capsys, *args: str, status: int = 0) -> dict:
    assert main(["magcal", "fit", "--json", *args]) == status
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("separator", [",", " ", "\t"])
def test_fit_counts_csv_json(tmp_path: Path, capsys, separator: str) -> None:
    counts, a, b_counts = synthetic_counts()
    path = tmp_path / "mag.txt"
    path.write_text("\n".join(separator.join(f"{v:.9f}" for v in row) for row in counts) + "\n")
    result = run_json(capsys, str(path), "--unit", "counts", "--scale-to-uT", "0.15", "--field-uT", "49.3")
    assert set(result) == JSON_KEYS
    np.testing.assert_allclose(result["offset_uT"], 0.15 * b_counts, atol=1e-5)
    np.testing.assert_allclose(result["soft_iron"], np.linalg.inv(a), atol=1e-7)
    assert result["field_uT"] == 49.3 and result["verdict"] == "good" and result["reasons"] == []
    assert result["samples_used"] == 600 and result["samples_rejected"] == 0
    assert result["rms_residual_uT"] < 1e-5 and result["condition"] < 15


def test_counts_without_scale_is_an_error(tmp_path: Path, capsys) -> None:
    counts, _, _ = synthetic_counts()
    path = tmp_path / "mag.csv"
    np.savetxt(path, counts, delimiter=",", header="mx_counts,my_counts,mz_counts", comments="")
    assert main(["magcal", "fit", str(path)]) == 1
    assert "--scale-to-uT" in capsys.readouterr().err


@pytest.mark.data("mag-hmc5883l")
def test_fit_real_recordings_and_save(shared_data: Path, capsys) -> None:
    folder = shared_data.joinpath(*SET2)
    full = run_json(capsys, str(folder / "full-sphere" / "mag_hmc5883l.csv.gz"))
    assert full["rms_residual_pct"] < 1.0 and full["verdict"] == "good"
    turns = [str(folder / f"rotate-ccw-around-{name}" / "mag_hmc5883l.csv.gz")
             for name in ("x-pointing-forward", "y-pointing-left", "z-pointing-up")]
    union = run_json(capsys, *turns, "--format", "csv")
    assert np.linalg.norm(np.subtract(union["offset_uT"], full["offset_uT"])) < 0.5
    # The board's gyroscope, checked against the field over the same turns, turns its y axis the
    # other way than the magnetometer's (the data set leaves the magnetometer's axes undocumented):
    # no scale correction is applied, and the output says why.
    assert union["gyr_correction"] == np.eye(3).tolist()
    assert not union["gyr_quality"]["applied"]
    assert union["gyr_quality"]["reason"].startswith("the gyroscope's y axis turns opposite to the magnetometer's")
    single = run_json(capsys, turns[1], status=FAIL_EXIT_STATUS)
    assert single["verdict"] == "fail" and any("coverage" in r for r in single["reasons"])
    assert main(["magcal", "fit", *turns, "--sensor", "HMC-1", "--save"]) == 0
    text = capsys.readouterr().out
    assert "verdict        good" in text and "saved" in text
    stored = CalibrationStore().load("HMC-1")
    np.testing.assert_allclose(stored.offset_uT, union["offset_uT"])
    assert stored.protocol == "file" and stored.samples_used == union["samples_used"]


def test_refused_fit_exits_with_the_reason(tmp_path: Path, capsys) -> None:
    path = tmp_path / "few.csv"
    np.savetxt(path, np.random.default_rng(1).normal(size=(12, 3)) * 40)
    assert main(["magcal", "fit", str(path)]) == 1
    assert "at least 30" in capsys.readouterr().err
    assert main(["magcal", "fit", str(path), "--sensor", "S07"]) == 1   # was: no file, no sensor
    assert f"error: {path}: sensor S07: only 12 valid samples" in capsys.readouterr().err


def test_an_unrecognised_csv_header_is_an_error_not_x_y_z(tmp_path: Path, capsys) -> None:
    counts, _, _ = synthetic_counts()
    path = tmp_path / "missing_col.csv"
    np.savetxt(path, np.column_stack((np.arange(len(counts)) * 0.01, counts[:, :2])), delimiter=",",
               header="t_s,mx_uT,my_uT", comments="")
    assert main(["magcal", "fit", str(path)]) == 1   # was: t_s read as x, exit 0
    assert f"{path}:1: the header t_s,mx_uT,my_uT has no mz column" in capsys.readouterr().err


def test_study_folders_without_trials_are_errors(tmp_path: Path, capsys) -> None:
    study = tmp_path / "study"
    (study / "reference").mkdir(parents=True)
    assert main(["magcal", "study", "--folder", str(study)]) == 1
    assert f"{study / 'reference'}: no recording in the reference folder" in capsys.readouterr().err
    counts, _, _ = synthetic_counts()
    np.savetxt(study / "reference" / "dense.csv", counts * 0.15, delimiter=",")
    (study / "figure8-1").mkdir()
    assert main(["magcal", "study", "--folder", str(study)]) == 1   # was: a row of nan, exit 0
    assert f"{study / 'figure8-1'}: no trial" in capsys.readouterr().err


def test_study_checks_the_plot_path_before_the_study(tmp_path: Path, capsys, monkeypatch) -> None:
    import mimucap.core.magcal.study as magcal_study

    def must_not_run(settings):
        raise AssertionError("the study ran before the plot path was checked")

    monkeypatch.setattr(magcal_study, "simulate_study", must_not_run)
    blocker = tmp_path / "notes.txt"
    blocker.write_text("a file")
    assert main(["magcal", "study", "--trials", "1", "--plot", str(blocker / "x.png")]) == 1
    assert f"cannot write {blocker / 'x.png'}: {blocker} is a file, not a folder" in capsys.readouterr().err


def test_study_prints_both_tables(capsys) -> None:
    assert main(["magcal", "study", "--trials", "2", "--seed", "3"]) == 0
    text = capsys.readouterr().out
    assert "Table 1: figure-8" in text and "Table 2: single-axis" in text
    rows = [line.split() for line in text.splitlines() if line.strip() and line.split()[0].isdigit()]
    assert len(rows) == 8  # figure-8 ×1..5, single-axis ×1..3
    figure8_five, single_once = rows[4], rows[5]
    assert float(single_once[2]) < float(figure8_five[2])  # centre RMSE
    assert float(single_once[3]) < float(figure8_five[3])  # radii RMSE


@pytest.mark.data("mag-hmc5883l")
def test_study_on_a_folder_of_real_recordings(shared_data: Path, tmp_path: Path, capsys) -> None:
    folder = shared_data.joinpath(*SET2)
    study = tmp_path / "study"
    (study / "reference").mkdir(parents=True)
    (study / "reference" / "full.csv.gz").symlink_to(folder / "full-sphere" / "mag_hmc5883l.csv.gz")
    trial = study / "single_axis-1" / "trial1"
    trial.mkdir(parents=True)
    for name in ("x-pointing-forward", "y-pointing-left", "z-pointing-up"):
        (trial / f"{name}.csv.gz").symlink_to(folder / f"rotate-ccw-around-{name}" / "mag_hmc5883l.csv.gz")
    single = study / "single_axis_alone-1"
    single.mkdir()
    (single / "y.csv.gz").symlink_to(folder / "rotate-ccw-around-y-pointing-left" / "mag_hmc5883l.csv.gz")
    assert main(["magcal", "study", "--folder", str(study)]) == 0
    lines = [line.split() for line in capsys.readouterr().out.splitlines() if line.strip()]
    rows = [line for line in lines if line[0] == "1"]
    assert len(rows) == 2
    union_row = next(r for r in rows if r[-1] == "1/0/0")  # the three turns: judged good
    assert float(union_row[2]) < 0.5 and float(union_row[1]) > 60  # about 77 s of recording
    bad = study / "not a protocol"
    bad.mkdir()
    assert main(["magcal", "study", "--folder", str(study)]) == 1


def test_study_plot_writes_a_png_with_every_panel(tmp_path: Path, capsys) -> None:
    from vtkmodules.vtkIOImage import vtkPNGReader
    from vtkmodules.util.numpy_support import vtk_to_numpy

    out = tmp_path / "study.png"
    assert main(["magcal", "study", "--trials", "1", "--plot", str(out)]) == 0
    assert f"figure: {out}" in capsys.readouterr().out
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    reader = vtkPNGReader()
    reader.SetFileName(str(out))
    reader.Update()
    width, height, _ = reader.GetOutput().GetDimensions()
    assert (width, height) == (4 * 360, 2 * 360)  # eight protocols, four per row
    pixels = vtk_to_numpy(reader.GetOutput().GetPointData().GetScalars()).reshape(height, width, -1)[..., :3]
    for row in range(2):
        for column in range(4):
            panel = pixels[row * 360:(row + 1) * 360, column * 360:(column + 1) * 360].astype(int)
            red = (panel[..., 0] > 180) & (panel[..., 1] < 110) & (panel[..., 2] < 90)
            assert red.sum() > 50  # the trial's samples are drawn in every panel
    assert main(["magcal", "study", "--trials", "1", "--plot", str(tmp_path / "missing" / "x.png")]) == 1


def test_fit_one_sensor_of_a_session(tmp_path: Path, capsys) -> None:
    from mimucap.core.sensor_samples import SensorSamples
    from mimucap.core.simulate.hand_held import calibration_motion
    from mimucap.io.session import Session, write_session

    motions = {sid: calibration_motion("single_axis", 1, seed=seed, errors="mpu9250", sensor_id=sid)
               for sid, seed in (("S01", 1), ("S02", 2))}
    session = Session(metadata={"source": "test"}, sensors={
        sid: SensorSamples(sid, m.t_s, np.arange(len(m.t_s)), acc=m.acc, gyr=m.gyr, mag_uT=m.mag_uT)
        for sid, m in motions.items()
    })
    path = write_session(tmp_path / "calibration.h5", session)
    result = run_json(capsys, str(path), "--sensor", "S02")
    np.testing.assert_allclose(result["offset_uT"], motions["S02"].mag_b_uT, atol=0.3)
    assert result["verdict"] == "good"
    assert main(["magcal", "fit", str(path), "--json"]) == 0   # a session: every sensor on its own
    fits = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [fit.pop("sensor") for fit in fits] == ["S01", "S02"] and set(fits[1]) == JSON_KEYS
    np.testing.assert_allclose(fits[0]["offset_uT"], motions["S01"].mag_b_uT, atol=0.3)
    assert main(["magcal", "fit", str(path), "--format", "session", "--sensor", "S02"]) == 0
    assert "dip" in capsys.readouterr().out  # the session's accelerometer gives the dip figure


@pytest.mark.data("mag-hmc5883l")
def test_a_failed_fit_is_not_saved_over_a_good_one(shared_data: Path, capsys) -> None:
    folder = shared_data.joinpath(*SET2)
    turns = [str(folder / f"rotate-ccw-around-{name}" / "mag_hmc5883l.csv.gz")
             for name in ("x-pointing-forward", "y-pointing-left", "z-pointing-up")]
    assert main(["magcal", "fit", *turns, "--sensor", "HMC-2", "--save"]) == 0
    good = CalibrationStore().load("HMC-2")
    capsys.readouterr()
    assert main(["magcal", "fit", turns[1], "--sensor", "HMC-2", "--save"]) == FAIL_EXIT_STATUS
    captured = capsys.readouterr()
    assert "verdict        fail" in captured.out and "saved " not in captured.out
    assert "not saved" in captured.err
    np.testing.assert_array_equal(CalibrationStore().load("HMC-2").offset_uT, good.offset_uT)
