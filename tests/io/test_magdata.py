"""Magnetometer readers: plain/headered CSV, sunsided companions, Xsens exports, sessions."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest

from mimucap.io.magdata import (
    detect_format,
    read_csv,
    read_mag_files,
    read_xsens,
    to_microtesla,
)
from mimucap.core.samples import SensorSamples
from mimucap.io.session import Session, write_session

SAMPLES = np.array([[12.5, -3.25, 40.0], [11.0, -4.0, 41.5], [-0.5, 2e-3, 1e2]])


@pytest.mark.parametrize("separator", [",", " ", "\t", ";", "  "])
@pytest.mark.parametrize("header", [None, "x,y,z", "mx_uT,my_uT,mz_uT"])
def test_plain_three_column_csv(tmp_path: Path, separator: str, header: str | None) -> None:
    lines = [separator.join(str(float(v)) for v in row) for row in SAMPLES]
    if header is not None:
        lines.insert(0, header.replace(",", separator))
    path = tmp_path / "mag.csv"
    path.write_text("# comment line\n" + "\n".join(lines) + "\n\n")
    recording = read_csv(path)
    np.testing.assert_array_equal(recording.mag, SAMPLES)
    assert recording.unit == ("uT" if header and "uT" in header else None)
    assert recording.t_s is None and recording.imu is None


def test_headered_csv_picks_named_columns_time_and_unit(tmp_path: Path) -> None:
    path = tmp_path / "mag.csv.gz"
    with gzip.open(path, "wt") as handle:
        handle.write("t_s,temperature,mag_x_gauss,mag_y_gauss,mag_z_gauss\n")
        for k, row in enumerate(SAMPLES):
            handle.write(f"{0.1 * k},21.5,{row[0]},{row[1]},{row[2]}\n")
    recording = read_csv(path)
    np.testing.assert_array_equal(recording.mag, SAMPLES)
    np.testing.assert_allclose(recording.t_s, [0.0, 0.1, 0.2])
    assert recording.unit == "gauss"
    np.testing.assert_allclose(to_microtesla(recording.mag, recording.unit, None), 100 * SAMPLES)


def test_malformed_csv_names_file_and_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.csv"
    path.write_text("1,2,3\n4,five,6\n")
    with pytest.raises(ValueError, match=r"bad\.csv:2"):
        read_csv(path)
    path.write_text("1,2,3,4\n")
    with pytest.raises(ValueError, match="exactly 3 columns"):
        read_csv(path)
    path.write_text("a,b,c,d\n1,2,3,4\n")
    with pytest.raises(ValueError, match="no magnetometer columns"):
        read_csv(path)
    path.write_text("")
    with pytest.raises(ValueError, match="no samples"):
        read_csv(path)


@pytest.mark.parametrize(("header", "message"), [
    ("t_s,mx_uT,my_uT", r"mag\.csv:2: the header t_s,mx_uT,my_uT has no mz column; expected mx,my,mz"),
    ("mx,mz,temperature", r"mag\.csv:2: the header mx,mz,temperature has no my column"),
    ("time,a,b", r"mag\.csv:2: no magnetometer columns in the header time,a,b: expected mx,my,mz"),
])
def test_an_unrecognised_three_column_header_is_not_read_as_x_y_z(tmp_path: Path, header: str, message: str) -> None:
    """Was: any 3-field header fell back to plain x, y, z (a time column read as x)."""
    path = tmp_path / "mag.csv"
    path.write_text("# comment\n" + header + "\n" + "\n".join(",".join(map(str, row)) for row in SAMPLES) + "\n")
    with pytest.raises(ValueError, match=message):
        read_csv(path)


def test_units() -> None:
    with pytest.raises(ValueError, match="--scale-to-uT"):
        to_microtesla(SAMPLES, "counts", None)
    np.testing.assert_allclose(to_microtesla(SAMPLES, "counts", 0.15), 0.15 * SAMPLES)
    with pytest.raises(ValueError, match="counts only"):
        to_microtesla(SAMPLES, "uT", 2.0)
    with pytest.raises(ValueError, match="unit"):
        to_microtesla(SAMPLES, "mG", None)


@pytest.mark.data("mag-hmc5883l")
def test_sunsided_recording_with_companion_in_project_conventions(shared_data: Path) -> None:
    base = shared_data / "mag" / "sunsided_hmc5883l" / "set-2"
    # README: "X forward, Y left, Z up ... should give a negative accelerometer reading on Z".
    level = read_mag_files([base / "unmoved-with-x-pointing-forward"])[0]
    assert level.unit == "gauss" and level.mag.shape[1] == 3
    acc = level.imu.acc
    np.testing.assert_allclose(np.median(acc, axis=0), [0, 0, 9.81], atol=0.6)  # specific force: up
    x_up = read_mag_files([base / "unmoved-with-z-pointing-front-and-x-up" / "mag_hmc5883l.csv.gz"])[0]
    np.testing.assert_allclose(np.median(x_up.imu.acc, axis=0), [9.81, 0, 0], atol=0.6)
    # Counter-clockwise turns about z (seen from above) are positive rotations about +z.
    turn = read_mag_files([base / "rotate-ccw-around-z-pointing-up"])[0]
    dt = np.diff(turn.imu.t_s)
    swept = np.degrees(np.sum(turn.imu.gyr[1:] * dt[:, None], axis=0))
    assert swept[2] > 300 and abs(swept[0]) < 150 and abs(swept[1]) < 150
    turn_x = read_mag_files([base / "rotate-ccw-around-x-pointing-forward"])[0]
    dt = np.diff(turn_x.imu.t_s)
    assert np.degrees(np.sum(turn_x.imu.gyr[1:, 0] * dt)) > 300  # x flipped back to ccw-positive
    interpolated = turn.acc_at_mag_times()
    assert interpolated.shape == turn.mag.shape
    assert np.all(np.isfinite(interpolated[5:-5]))


@pytest.mark.data("mag-hmc5883l")
def test_sunsided_set1_accelerometer_convention(shared_data: Path) -> None:
    # Set 1 README: the accelerometer gives the up vector, with its x axis sign flipped.
    base = shared_data / "mag" / "sunsided_hmc5883l" / "set-1"
    level = read_mag_files([base / "unmoved-x-pointing-forward"])[0]
    np.testing.assert_allclose(np.median(level.imu.acc, axis=0), [0, 0, 9.81], atol=0.8)
    x_up = read_mag_files([base / "unmoved-x-pointing-up"])[0]
    np.testing.assert_allclose(np.median(x_up.imu.acc, axis=0), [9.81, 0, 0], atol=0.8)
    # Set 1 mounts the magnetometer differently: its accelerometer is not in the mag frame.
    assert not level.imu_in_mag_frame and level.acc_at_mag_times() is None


@pytest.mark.data("opensense")
def test_xsens_export_with_magnetometer(shared_data: Path) -> None:
    path = shared_data / "body" / "opensense_example" / "xsens_format_variants" / "MT_012005D6_031-000_00B421AF.txt"
    assert detect_format(path) == "xsens"
    recording = read_xsens(path)
    assert recording.sensor_id == "00B421AF" and recording.unit == "counts"
    assert recording.mag.shape == (3369, 3)
    np.testing.assert_allclose(recording.mag[0], [-0.045410, -0.266113, 0.897217])
    assert recording.t_s[1] - recording.t_s[0] == pytest.approx(0.01)  # 100 Hz update rate header
    norms = np.linalg.norm(recording.imu.acc, axis=1)
    assert np.median(norms) == pytest.approx(9.81, abs=0.5)
    # Xsens normalises the magnetometer to the local field: magnitudes near 1 a.u.
    assert 0.5 < np.median(np.linalg.norm(recording.mag, axis=1)) < 1.5


@pytest.mark.data("opensense")
def test_xsens_new_header_and_missing_columns(shared_data: Path) -> None:
    folder = shared_data / "body" / "opensense_example" / "xsens_format_variants"
    recording = read_xsens(folder / "MT_01200454_000-000_00B40DE4.txt")
    assert recording.sensor_id == "00B40DE4" and recording.mag.shape == (4, 3)
    np.testing.assert_allclose(recording.mag[0], [-0.835693, -0.422607, -0.119629])
    with pytest.raises(ValueError, match=r"MT2022_ACC_00B42D4B\.txt.*no Mag_X"):
        read_xsens(folder / "MT2022_ACC_00B42D4B.txt")


@pytest.mark.parametrize("separator", ["\t", ",", ";", " "])
def test_xsens_delimiters_and_empty_fields(tmp_path: Path, separator: str) -> None:
    names = ["PacketCounter", "SampleTimeFine", "Year", "Acc_X", "Acc_Y", "Acc_Z", "Mag_X", "Mag_Y", "Mag_Z"]
    rows = [["100", "", "", "0.1", "0.2", "9.8", "0.5", "-0.25", "0.75"], ["101", "", "", "0.1", "0.2", "9.8", "0.4", "-0.2", "0.7"]]
    text = "// General information:\n//  DeviceId: 00B4ABCD\n// Update Rate: 50.0Hz\n"
    text += separator.join(names) + "\n" + "\n".join(separator.join(r) for r in rows) + "\n"
    path = tmp_path / "export.txt"
    path.write_text(text)
    recording = read_mag_files([path], sensor_id="00B4ABCD")[0]
    np.testing.assert_allclose(recording.mag, [[0.5, -0.25, 0.75], [0.4, -0.2, 0.7]])
    np.testing.assert_allclose(recording.t_s, [0.0, 0.02])
    with pytest.raises(ValueError, match="holds sensor 00B4ABCD, not S9"):
        read_mag_files([path], sensor_id="S9")


def test_session_files(tmp_path: Path) -> None:
    n = 50
    t = np.arange(n) * 0.01
    mag = np.column_stack([np.cos(t), np.sin(t), t]) * 40.0
    session = Session(
        metadata={"source": "test"},
        sensors={
            "S01": SensorSamples("S01", t, np.arange(n), acc=np.tile([0, 0, 9.81], (n, 1)), mag_uT=mag),
            "S02": SensorSamples("S02", t, np.arange(n), mag_uT=mag + 1.0),
            "S03": SensorSamples("S03", t, np.arange(n), gyr=np.zeros((n, 3))),
        },
    )
    path = write_session(tmp_path / "take.h5", session)
    assert detect_format(path) == "session"
    recordings = read_mag_files([path])
    assert [r.sensor_id for r in recordings] == ["S01", "S02"]
    assert recordings[0].unit == "uT"
    np.testing.assert_allclose(recordings[1].mag, mag + 1.0)
    np.testing.assert_allclose(recordings[0].acc_at_mag_times(), np.tile([0, 0, 9.81], (n, 1)))
    assert [r.sensor_id for r in read_mag_files([path], sensor_id="S02")] == ["S02"]
    with pytest.raises(ValueError, match="no sensor S09"):
        read_mag_files([path], sensor_id="S09")
    with pytest.raises(ValueError, match="S03 has no magnetometer"):
        read_mag_files([path], sensor_id="S03")


def test_missing_paths(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        read_mag_files([tmp_path / "nothing.csv"])
    with pytest.raises(ValueError, match="mag_hmc5883l"):
        read_mag_files([tmp_path])
    with pytest.raises(ValueError, match="format"):
        read_mag_files([tmp_path], fmt="matlab")


@pytest.mark.data("opensense")
def test_an_xsens_export_names_its_device_and_a_fit_of_it_says_so(shared_data: Path, capsys) -> None:
    """The export's DeviceId is the device a calibration of it belongs to (``xsens:<id>``)."""
    from mimucap.cli import main

    path = shared_data / "body" / "opensense_example" / "xsens_format_variants" / "MT_012005D6_031-000_00B421AF.txt"
    assert read_xsens(path).device_id == "xsens:00B421AF"
    main(["magcal", "fit", str(path), "--scale-to-uT", "49.3"])   # a short recording: its fit fails, as it should
    assert "device         Xsens 00B421AF" in capsys.readouterr().out
