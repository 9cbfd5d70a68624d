"""Orientation tables: every Xsens MT Manager layout, OpenSim .sto, APDM, CSV and sessions.

Real files are checked against physics (a resting accelerometer reads +g along world up once
rotated by the file's orientation) and against each other (the same samples exported in two
formats), never against this reader's own earlier output.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.io import orientation_inputs, orientation_tables, xsens_text

G = 9.81


@pytest.fixture
def opensense(shared_data) -> Path:
    return shared_data / "body" / "opensense_example"


@pytest.fixture
def variants(opensense) -> Path:
    return opensense / "xsens_format_variants"


def world_acc(rec: xsens_text.XsensRecording) -> np.ndarray:
    return rot.rotate(rec.q_world_from_sensor, rec.acc)


# --------------------------------------------------------------------------------------------
# Xsens exports
# --------------------------------------------------------------------------------------------

STILL_FILES = [
    "MT2022_ACC_GYRO_ROT_ALL_TAB_NAN_00B42D4B.txt", "MT2022_ACC_GYRO_ROT_EULER_TAB_00B42D4F.txt",
    "MT2022_ACC_GYRO_ROT_MAT_COMMA_00B42D4B.txt", "MT2022_ACC_GYRO_ROT_MAT_SEMICOLON_00B42D4B.txt",
    "MT2022_ACC_GYRO_ROT_MAT_SPACE_00B42D4B.txt", "MT46_01-000_00B42D4D.txt", "MT46_01-000_00B42D4E.txt",
    "MT_01200312-002-000_00B474BA.txt", "test1_00B421E6.txt",
]


@pytest.mark.data("opensense")
@pytest.mark.parametrize("name", STILL_FILES)
def test_resting_sensor_reads_gravity_up_in_every_layout(variants, name):
    rec = xsens_text.read_xsens_file(variants / name)
    acc = world_acc(rec)
    acc = acc[np.all(np.isfinite(acc), axis=1)]
    assert acc.shape[0] >= 2
    np.testing.assert_allclose(acc.mean(axis=0), [0.0, 0.0, G], atol=0.25)
    assert rec.coordinate_system == "ENU"


@pytest.mark.data("opensense")
def test_moving_and_long_recordings_read_gravity_up_on_average(variants, opensense):
    moving = world_acc(xsens_text.read_xsens_file(variants / "MT_01200454_000-000_00B40DE4.txt"))
    assert np.all(moving[:, 2] > 8.5) and np.all(np.abs(moving[:, :2]) < 1.5)
    # Over a recording that starts and ends at rest the mean acceleration vanishes.
    for path in [variants / "MT_012005D6_031-000_00B421AF.txt", *sorted((opensense / "IMUData").glob("*.txt"))]:
        acc = world_acc(xsens_text.read_xsens_file(path))
        np.testing.assert_allclose(acc.mean(axis=0), [0.0, 0.0, G], atol=0.2, err_msg=path.name)


@pytest.mark.data("opensense")
def test_quaternion_matrix_and_euler_columns_agree(variants):
    """The ALL file exports Quat, Roll/Pitch/Yaw and Mat of the same samples."""
    path = variants / "MT2022_ACC_GYRO_ROT_ALL_TAB_NAN_00B42D4B.txt"
    lines = path.read_text().splitlines()
    header = lines[12].split("\t")
    data = np.array([[float(v) for v in line.split("\t")] for line in lines[13:]])
    col = {c: data[:, i] for i, c in enumerate(header)}
    q_quat = np.column_stack([col[f"Quat_q{i}"] for i in range(4)])
    mat = np.stack([np.stack([col[f"Mat[{i}][{j}]"] for j in (1, 2, 3)], -1) for i in (1, 2, 3)], -2)
    rec = xsens_text.read_xsens_file(path)
    assert rec.orientation_source.startswith("Quat")
    assert np.degrees(rot.angle_between(rec.q_world_from_sensor, q_quat)).max() < 1e-6
    assert np.degrees(rot.angle_between(rec.q_world_from_sensor, rot.from_matrix(mat))).max() < 0.01
    # The same samples exported with matrices only, in three delimiters.
    for name in ("COMMA", "SEMICOLON", "SPACE"):
        other = xsens_text.read_xsens_file(variants / f"MT2022_ACC_GYRO_ROT_MAT_{name}_00B42D4B.txt")
        assert other.orientation_source.startswith("Mat")
        assert np.degrees(rot.angle_between(other.q_world_from_sensor, rec.q_world_from_sensor)).max() < 0.01
        np.testing.assert_array_equal(other.packet_counter, rec.packet_counter)
        np.testing.assert_allclose(other.gyr, rec.gyr)
    # Roll/Pitch/Yaw of the ALL file (R = Rz(yaw) Ry(pitch) Rx(roll)) give the same rotation.
    roll, pitch, yaw = np.radians([col["Roll"], col["Pitch"], col["Yaw"]])
    q_euler = rot.multiply(rot.multiply(rot.from_axis_angle([0, 0, 1.0], yaw), rot.from_axis_angle([0, 1.0, 0], pitch)),
                           rot.from_axis_angle([1.0, 0, 0], roll))
    assert np.degrees(rot.angle_between(q_euler, q_quat)).max() < 0.01


@pytest.mark.data("opensense")
def test_nan_and_empty_fields_are_kept_as_missing(variants):
    rec = xsens_text.read_xsens_file(variants / "MT2022_ACC_GYRO_ROT_ALL_TAB_NAN_00B42D4B.txt")
    assert np.isnan(rec.acc[0, 0]) and np.isfinite(rec.acc[1:]).all()
    assert rec.mag_au is None and rec.gyr is not None
    space = xsens_text.read_xsens_file(variants / "MT2022_ACC_GYRO_ROT_MAT_SPACE_00B42D4B.txt")
    assert space.acc[0] == pytest.approx([0.074225, -0.040975, 9.922524])


@pytest.mark.data("opensense")
def test_rates_time_and_lost_packets(variants):
    old = xsens_text.read_xsens_file(variants / "MT_012005D6-000_sit_to_stand-000_00B421ED.txt")
    assert old.rate_hz == 40.0 and old.rate_from_header
    assert old.acc is None
    # Packet 35169 is missing in the file: the time axis keeps the gap.
    assert old.t_s[:4] == pytest.approx([0.0, 0.025, 0.05, 0.1])
    new = xsens_text.read_xsens_file(variants / "MT2022_ACC_GYRO_ROT_MAT_COMMA_00B42D4B.txt", rate_hz=60.0)
    assert new.rate_hz == 60.0 and not new.rate_from_header
    assert xsens_text.read_xsens_file(variants / "MT_01200312-002-000_00B474BA.txt").rate_hz == xsens_text.XSENS_DEFAULT_RATE_HZ
    mag = xsens_text.read_xsens_file(variants / "MT_012005D6_031-000_00B421AF.txt")
    assert mag.mag_au.shape == (mag.packet_counter.size, 3)


@pytest.mark.data("opensense")
def test_export_without_orientation_is_named(variants):
    rec = xsens_text.read_xsens_file(variants / "MT2022_ACC_00B42D4B.txt")
    assert rec.q_world_from_sensor is None and rec.acc.shape == (5, 3)
    with pytest.raises(ValueError, match="MT2022_ACC_00B42D4B.txt: sensor 00B42D4B: no orientation columns"):
        orientation_inputs.read_quaternion_table(variants / "MT2022_ACC_00B42D4B.txt")


@pytest.mark.data("opensense")
def test_every_file_in_the_variants_folder_is_read(variants):
    for path in sorted(variants.iterdir()):
        if path.name == "MT2022_ACC_00B42D4B.txt":
            continue
        table = orientation_inputs.read_quaternion_table(path)
        assert len(table) >= 3 and table.up_world.tolist() == [0.0, 0.0, 1.0], path.name


def export_text(rows, header="PacketCounter\tQuat_q0\tQuat_q1\tQuat_q2\tQuat_q3", preamble="// Update Rate: 100.0Hz"):
    return preamble + "\n" + header + "\n" + "\n".join("\t".join(str(v) for v in row) for row in rows) + "\n"


def test_counter_wraps_and_ned_is_turned_into_enu(tmp_path):
    q = [0.9238795, 0.0, 0.0, 0.3826834]  # 45° about the file's z
    rows = [[c] + q for c in (65534, 65535, 0, 1)]
    path = tmp_path / "trial_00B40000.txt"
    path.write_text(export_text(rows, preamble="// Update Rate: 100.0Hz\n// Coordinate system: NED"))
    rec = xsens_text.read_xsens_file(path)
    assert rec.packet_counter.tolist() == [65534, 65535, 65536, 65537]
    assert rec.t_s == pytest.approx([0.0, 0.01, 0.02, 0.03])
    # NED: x north, y east, z down. The sensor x axis points 45° from north towards east.
    x_world = rot.rotate(rec.q_world_from_sensor[0], [1.0, 0.0, 0.0])
    np.testing.assert_allclose(x_world, [np.sqrt(0.5), np.sqrt(0.5), 0.0], atol=1e-6)
    z_world = rot.rotate(rec.q_world_from_sensor[0], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(z_world, [0.0, 0.0, -1.0], atol=1e-6)


def test_packets_without_any_orientation_are_skipped_and_counted(tmp_path):
    rows = [[1, 1.0, 0.0, 0.0, 0.0], [2, "NaN", "NaN", "NaN", "NaN"], [3, "", "", "", ""], [4, 1.0, 0.0, 0.0, 0.0]]
    path = tmp_path / "gaps_00B40003.txt"
    path.write_text(export_text(rows))
    rec = xsens_text.read_xsens_file(path)
    assert rec.rows_without_orientation == 2
    assert rec.t_s == pytest.approx([0.0, 0.03])
    path.write_text(export_text([[1, "NaN", "NaN", "NaN", "NaN"]]))
    with pytest.raises(ValueError, match="every row lacks its orientation"):
        xsens_text.read_xsens_file(path)


@pytest.mark.parametrize(("rows", "message"), [
    ([[1, 1.0, 0.0, 0.0, 0.0], [2, 1.0, 0.0]], "line 4: 3 fields, the header has 5"),
    ([[1, 1.0, 0.0, 0.0, 0.0], [2, "NaN", 0.0, 0.0, 0.0]], "line 4: sensor 00B40001: NaN quaternion"),
    ([[1, 1.0, 0.0, 0.0, 0.0], [2, 0.0, 0.0, 0.0, 0.0]], "line 4: sensor 00B40001: non-unit"),
    ([[1, 1.0, 0.0, 0.0, 0.0], [2, "abc", 0.0, 0.0, 0.0]], "line 4: column Quat_q0: not a number"),
    ([[5, 1.0, 0.0, 0.0, 0.0], [5, 1.0, 0.0, 0.0, 0.0]], "line 4: PacketCounter does not increase"),
])
def test_malformed_xsens_rows_are_named(tmp_path, rows, message):
    path = tmp_path / "bad_00B40001.txt"
    path.write_text(export_text(rows))
    with pytest.raises(ValueError, match=message):
        xsens_text.read_xsens_file(path)


def test_bad_rotation_matrix_is_named(tmp_path):
    header = "PacketCounter\t" + "\t".join(f"Mat[{i}][{j}]" for j in (1, 2, 3) for i in (1, 2, 3))
    path = tmp_path / "bad_00B40002.txt"
    path.write_text(export_text([[1, 1, 0, 0, 0, 1, 0, 0, 0, 1], [2, 2, 0, 0, 0, 1, 0, 0, 0, 1]], header))
    with pytest.raises(ValueError, match="line 4: sensor 00B40002: Mat.* is not a rotation matrix"):
        xsens_text.read_xsens_file(path)


@pytest.mark.data("opensense")
def test_folder_with_opensense_mapping(opensense):
    table = orientation_inputs.read_quaternion_table(opensense / "IMUData", sensor_names=opensense / "myIMUMappings.xml")
    assert set(table.sensor_ids) == {"torso_imu", "pelvis_imu", "tibia_r_imu", "femur_r_imu", "tibia_l_imu",
                                     "femur_l_imu", "calcn_r_imu", "calcn_l_imu"}
    assert table.t_s[1] == pytest.approx(0.01)
    # The files hold 2438..2511 packets; only packets every sensor delivered are kept.
    assert 2400 < len(table) <= 2438
    raw = xsens_text.read_xsens_file(opensense / "IMUData" / "MT_012005D6_009-001_00B42279.txt")
    assert np.degrees(rot.angle_between(table.q_world_from_sensor["pelvis_imu"][0], raw.q_world_from_sensor[0])) < 1e-9
    by_id = orientation_inputs.read_quaternion_table(opensense / "IMUData")
    assert "00B42279" in by_id.sensor_ids


@pytest.mark.data("opensense")
def test_mapping_errors(opensense, variants, tmp_path):
    mapping = xsens_text.read_xsens_mapping(opensense / "myIMUMappings.xml")
    assert mapping.trial_prefix == "MT_012005D6_009-001" and mapping.names["00B42279"] == "pelvis_imu"
    other = xsens_text.read_xsens_mapping(opensense / "test_resources" / "myIMUMappings_complexTasks.xml")
    with pytest.raises(ValueError, match="no files for trial 'MT_012005D6_005-000'"):
        xsens_text.read_xsens_folder(opensense / "IMUData", other)
    missing = tmp_path / "map.xml"
    missing.write_text(
        "<OpenSimDocument><XsensDataReaderSettings><trial_prefix>MT_012005D6_009-001</trial_prefix>"
        "<ExperimentalSensors><ExperimentalSensor name='_00B4FFFF'><name_in_model>x_imu</name_in_model>"
        "</ExperimentalSensor></ExperimentalSensors></XsensDataReaderSettings></OpenSimDocument>")
    with pytest.raises(ValueError, match="no file for mapped sensor.s. 00B4FFFF"):
        xsens_text.read_xsens_folder(opensense / "IMUData", missing)
    broken = tmp_path / "broken.xml"
    broken.write_text("<OpenSimDocument><XsensDataReaderSettings>")
    with pytest.raises(ValueError, match="malformed XML"):
        xsens_text.read_xsens_mapping(broken)
    with pytest.raises(ValueError, match="several trials"):
        xsens_text.read_xsens_folder(variants)
    table = xsens_text.read_xsens_folder(variants, trial_prefix="MT46_01-000")
    assert set(table.sensor_ids) == {"00B42D4D", "00B42D4E"}


# --------------------------------------------------------------------------------------------
# OpenSim .sto and APDM
# --------------------------------------------------------------------------------------------

@pytest.mark.data("opensense")
def test_sto_tables_are_the_xsens_enu_world(opensense):
    """The facing −X calibration trial begins in the pose the Xsens ENU exports of the walking
    trial (IMUData) begin with: the .sto keeps the vendor's z-up world."""
    sto = orientation_inputs.read_quaternion_table(
        opensense / "test_resources" / "MT_012005D6_009-quaternions_calibration_trial_Facing_negX.sto")
    assert sto.up_world.tolist() == [0.0, 0.0, 1.0]
    assert sto.t_s[0] == 678.0 and sto.t_s[1] == pytest.approx(678.01)  # times as in the file
    xsens = orientation_inputs.read_quaternion_table(opensense / "IMUData", sensor_names=opensense / "myIMUMappings.xml")
    for sensor in sto.sensor_ids:
        # Within 0.2° (the subject stands still; the sensors differ from each other by tens of degrees).
        assert np.degrees(rot.angle_between(sto.q_world_from_sensor[sensor][0], xsens.q_world_from_sensor[sensor][0])) < 0.2
    # Standing: the leg sensors' long (x) axes point up.
    for sensor in ("femur_r_imu", "femur_l_imu", "tibia_r_imu", "tibia_l_imu"):
        assert rot.rotate(sto.q_world_from_sensor[sensor][0], [1.0, 0, 0]) @ sto.up_world > 0.95
    declared = orientation_inputs.read_quaternion_table(opensense / "test_resources" / "imuOrientations.sto", up_axis="y")
    assert declared.up_world.tolist() == [0.0, 1.0, 0.0]


@pytest.mark.data("opensense")
def test_relative_sensor_headings_differ_between_the_facing_trials(opensense):
    """A fact of the data behind test_bodycal's facing-trial figures: the tibia sensors'
    headings relative to the pelvis sensor differ by about 22° between the two trials."""
    def relative_heading(table, sensor):
        def heading(q):
            v = rot.rotate(q, [0.0, 0.0, 1.0])
            return np.degrees(np.arctan2(v[1], v[0]))
        return heading(table.q_world_from_sensor[sensor][0]) - heading(table.q_world_from_sensor["pelvis_imu"][0])

    x = orientation_tables.read_opensim_sto(opensense / "test_resources" / "MT_012005D6_009-quaternions_calibration_trial_Facing_X.sto")
    neg = orientation_tables.read_opensim_sto(opensense / "test_resources" / "MT_012005D6_009-quaternions_calibration_trial_Facing_negX.sto")
    for sensor in ("tibia_r_imu", "tibia_l_imu"):
        change = (relative_heading(neg, sensor) - relative_heading(x, sensor) + 180.0) % 360.0 - 180.0
        assert 18.0 < abs(change) < 26.0


def test_sto_errors(tmp_path):
    path = tmp_path / "bad.sto"
    path.write_text("DataType=Quaternion\nendheader\ntime\ta_imu\n0\t1,0,0,0\n0.01\t1,0,0\n")
    with pytest.raises(ValueError, match="line 5: sensor a_imu: expected 'w,x,y,z'"):
        orientation_tables.read_opensim_sto(path)
    path.write_text("DataType=Quaternion\nendheader\ntime\ta_imu\n0\t1,0,0,0\n0.01\tnan,0,0,0\n")
    with pytest.raises(ValueError, match="line 5: sensor a_imu: NaN quaternion"):
        orientation_tables.read_opensim_sto(path)
    path.write_text("DataType=Quaternion\ntime\ta_imu\n")
    with pytest.raises(ValueError, match="no 'endheader'"):
        orientation_tables.read_opensim_sto(path)
    path.write_text("DataType=Vec3\nendheader\ntime\ta\n0\t1,0,0\n")
    with pytest.raises(ValueError, match="DataType=Vec3 is not Quaternion"):
        orientation_tables.read_opensim_sto(path)


@pytest.mark.data("opensense")
def test_apdm_orientations_rotate_gravity_up(variants):
    path = variants / "apdm_format7.csv"
    table = orientation_inputs.read_quaternion_table(path)
    assert table.sensor_ids == ("Lumbar", "Right Ankle", "Left Ankle", "Left Foot", "Chest", "Right Foot")
    rows = np.genfromtxt(path, delimiter=",", skip_header=3)
    # Per sensor block of 14 columns (acc 3, gyr 3, mag 3, baro 1, orientation 4) after Time.
    for k, sensor in enumerate(table.sensor_ids):
        acc = rows[:, 1 + 14 * k:4 + 14 * k]
        up = rot.rotate(table.q_world_from_sensor[sensor], acc)
        # Specific force within 25° of world up (a moving foot included).
        assert np.all(up[:, 2] > 0.9 * np.linalg.norm(acc, axis=1) - 0.2), sensor
    assert table.t_s[1] == pytest.approx(0.0078125, abs=1e-4)  # 128 Hz, Time in microseconds


# --------------------------------------------------------------------------------------------
# MimuCap CSV and sessions
# --------------------------------------------------------------------------------------------

def random_table(n=20, sensors=("A", "B"), seed=0):
    rng = np.random.default_rng(seed)
    return orientation_tables.QuaternionTable(np.arange(n) * 0.01, {s: rot.normalize(rng.normal(size=(n, 4))) for s in sensors},
                              source="random")


def test_csv_round_trip(tmp_path):
    table = random_table()
    path = tmp_path / "q.csv"
    orientation_tables.write_quaternion_csv(path, table)
    again = orientation_inputs.read_quaternion_table(path)
    assert again.sensor_ids == ("A", "B")
    np.testing.assert_allclose(again.t_s, table.t_s)
    for s in table.sensor_ids:
        assert np.degrees(rot.angle_between(again.q_world_from_sensor[s], table.q_world_from_sensor[s])).max() < 1e-6
    assert again.up_world.tolist() == [0.0, 0.0, 1.0]


@pytest.mark.parametrize(("text", "message"), [
    ("t_s,A_qw,A_qx,A_qy,A_qz\n0,1,0,0,0\n0.1,nan,0,0,0\n", "line 3: sensor A: NaN quaternion"),
    ("t_s,A_qw,A_qx,A_qy,A_qz\n0,1,0,0,0\n0.1,,0,0,0\n", "line 3: sensor A: NaN quaternion"),
    ("t_s,A_qw,A_qx,A_qy,A_qz\n0,1,0,0,0\n0.1,1,0,0\n", "line 3: 4 fields, the header has 5"),
    ("t_s,A_qw,A_qx,A_qz\n0,1,0,0\n", "sensor A: missing column.s. A_qy"),
    ("t_s,A_qx,A_qy,A_qz\n0,1,0,0\n", "quaternion column.s. without '_qw'"),
    ("time,A_qw,A_qx,A_qy,A_qz\n0,1,0,0,0\n", "no 't_s' column"),
    ("t_s,A_qw,A_qx,A_qy,A_qz\n0,1,0,0,0\n0,1,0,0,0\n", "line 3: time does not increase"),
    ("t_s,A_qw,A_qx,A_qy,A_qz\n0,1,0,0,x\n", "line 2: column A_qz: not a number"),
    ("# only a comment\n", "empty file"),
])
def test_csv_errors_name_line_and_sensor(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        orientation_inputs.read_quaternion_table(path)


def test_a_declared_up_axis_that_is_not_an_axis_names_file_and_line(tmp_path):
    path = tmp_path / "q.csv"
    path.write_text("# MimuCap quaternion table\n\n# up_axis: w\nt_s,A_qw,A_qx,A_qy,A_qz\n0,1,0,0,0\n")
    with pytest.raises(ValueError, match=r"q\.csv: line 3: '# up_axis': unknown axis 'w'"):
        orientation_inputs.read_quaternion_table(path)   # was: "unknown axis 'w'" without file or line
    assert orientation_inputs.read_quaternion_table(path, up_axis="y").up_world.tolist() == [0.0, 1.0, 0.0]  # the override wins


@pytest.mark.data("opensense")
def test_an_up_axis_for_a_z_up_input_is_refused_not_ignored(tmp_path, variants):
    xsens = variants / "MT2022_ACC_GYRO_ROT_EULER_TAB_00B42D4F.txt"
    apdm = variants / "apdm_format7.csv"
    for path in (xsens, apdm):
        with pytest.raises(ValueError, match=f"{path.name}: up axis -y cannot apply"):
            orientation_inputs.read_quaternion_table(path, up_axis="-y")
        assert orientation_inputs.read_quaternion_table(path, up_axis="z").up_world.tolist() == [0.0, 0.0, 1.0]


def test_a_session_is_refused_its_orientations_come_from_the_processing_path(tmp_path):
    """A reader never fuses: a session's raw samples go through core.pipeline (the commands
    read sessions that way, tests/cli)."""
    from mimucap.core.sensor_samples import SensorSamples
    from mimucap.io.session import Session, write_session

    t = np.arange(0.0, 1.0, 0.01)
    session = tmp_path / "s.h5"
    write_session(session, Session(sensors={"A": SensorSamples("A", t, np.arange(t.size),
                                                              q_world_from_sensor=rot.identity((t.size,)))}))
    with pytest.raises(ValueError, match="s.h5: MimuCap sessions hold raw samples.*processing path"):
        orientation_inputs.read_quaternion_table(session)


@pytest.mark.data("opensense")
@pytest.mark.parametrize("rate", [0.0, -100.0, float("nan"), float("inf")])
def test_a_given_xsens_rate_must_be_positive(variants, rate):
    """Was: 0 fell back to the 100-Hz default, NaN gave "time must be finite"."""
    with pytest.raises(ValueError, match="the update rate must be a positive number of Hz"):
        xsens_text.read_xsens_file(variants / "MT2022_ACC_GYRO_ROT_EULER_TAB_00B42D4F.txt", rate)


def test_unknown_file_types(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such file"):
        orientation_inputs.read_quaternion_table(tmp_path / "missing.csv")
    other = tmp_path / "x.dat"
    other.write_text("1")
    with pytest.raises(ValueError, match="unknown orientation file type '.dat'"):
        orientation_inputs.read_quaternion_table(other)
    with pytest.raises(ValueError, match="unknown axis 'w'"):
        orientation_tables.axis_vector("w")


