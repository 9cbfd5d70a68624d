"""``mimucap gait`` on a foot-IMU CSV in the gaitmap layout, and its refusals."""

from __future__ import annotations

from pathlib import Path

import pytest

from mimucap.cli import main
from mimucap.io.analysis_tables import read_table
from mimucap.io.gaitmap import read_foot_imu_csv
from tests.external_data import data_path

GAITMAP = data_path("gaitmap")


@pytest.mark.data("gaitmap")
def test_gait_csv_writes_strides_and_parameters(tmp_path, capsys):
    out = tmp_path / "gait"
    assert main(["gait", str(GAITMAP / "imu_sample.csv"), "--rate", "204.8", "--out", str(out)]) == 0
    assert "55 strides analysed" in capsys.readouterr().out
    strides = read_table(out / "strides.csv")
    assert list(strides[0])[:7] == ["foot", "ic_s", "fc_s", "next_ic_s", "stride_time_s", "stride_length_m", "straight"]
    assert {r["straight"] for r in strides} == {"true", "false"}
    for row in strides:
        assert float(row["ic_s"]) < float(row["fc_s"]) < float(row["next_ic_s"])
        if row["analysed"] == "false":
            assert row["refused_because"]
    parameters = read_table(out / "parameters.csv")
    cadence = [r for r in parameters if r["parameter"] == "cadence" and r["side"] == "both"][0]
    # Reference stride time 1.09 s (optical): about 110 steps/min.
    assert float(cadence["mean"]) == pytest.approx(110.0, abs=2.0)


def write_csv(path: Path, rows: list[list[str]]) -> Path:
    path.write_text("\n".join(",".join(r) for r in rows) + "\n")
    return path


HEADER = [["sensor"] + ["left_sensor"] * 6, ["axis", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]]


def test_gait_csv_refusals_name_the_problem(tmp_path, capsys):
    missing_rate = write_csv(tmp_path / "a.csv", HEADER + [["0", "0", "0", "9.8", "0", "0", "0"]] * 3)
    assert main(["gait", str(missing_rate), "--out", str(tmp_path / "o")]) == 1
    assert "--rate" in capsys.readouterr().err
    bad_value = write_csv(tmp_path / "b.csv", HEADER + [["0", "0", "0", "9.8", "0", "0", "0"],
                                                       ["1", "0", "x", "9.8", "0", "0", "0"]])
    with pytest.raises(ValueError, match="b.csv: line 4"):
        read_foot_imu_csv(bad_value, 100.0)
    no_channel = write_csv(tmp_path / "c.csv", [r[:-1] for r in HEADER] + [["0", "0", "0", "9.8", "0", "0"]])
    with pytest.raises(ValueError, match="lacks channel.*gyr_z"):
        read_foot_imu_csv(no_channel, 100.0)
    fast = write_csv(tmp_path / "d.csv", HEADER + [["0", "0", "0", "9.8", "0", "5000", "0"],
                                                  ["1", "0", "0", "9.8", "0", "0", "0"]])
    with pytest.raises(ValueError, match="gyroscope"):
        read_foot_imu_csv(fast, 100.0, "rad/s")
    backwards = write_csv(tmp_path / "e.csv", HEADER + [["1", "0", "0", "9.8", "0", "0", "0"],
                                                       ["0", "0", "0", "9.8", "0", "0", "0"]])
    with pytest.raises(ValueError, match="line 4: sample numbers must increase"):
        read_foot_imu_csv(backwards, 100.0)


def test_gait_csv_with_no_walking_says_so(tmp_path, capsys):
    rows = HEADER + [[str(i), "0", "0", "9.81", "0", "0", "0"] for i in range(500)]
    still = write_csv(tmp_path / "still.csv", rows)
    assert main(["gait", str(still), "--rate", "100", "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "0 strides analysed" in out


def test_gait_on_a_session_writes_every_table(tmp_path, capsys):
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.session.recorded.gait_validation import simulated_analysis

    config = SimulationConfig(scenario="demo", duration_s=30.0, n_sensors=10, errors="bno055", seed=8)
    _, analysis = simulated_analysis(config, tmp_path)
    out = tmp_path / "out"
    assert main(["gait", str(analysis.review.path), "--out", str(out)]) == 0
    assert "strides analysed" in capsys.readouterr().out
    for name in ("strides.csv", "parameters.csv", "bouts_turns.csv", "gait_cycle_curves.csv"):
        assert (out / name).is_file()
    assert main(["gait", str(analysis.review.path), "--rate", "100", "--out", str(out)]) == 1
    assert "--rate applies to CSV input only" in capsys.readouterr().err
