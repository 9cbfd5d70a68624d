"""``mimucap bodycal`` and ``mimucap angles`` as a user runs them: files in, files out."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mimucap.cli import main
from mimucap.core import rotation as rot
from mimucap.core import skeleton as sk
from mimucap.io.angles_export import read_angles_csv, read_angles_mot
from mimucap.io.orientation_tables import QuaternionTable, write_quaternion_csv

TEN = sk.load_model("ten_segment")
EX, EY, EZ = np.eye(3)


@pytest.fixture(scope="module")
def suit():
    """A subject facing 130°, random mountings: N-pose 0–1 s, both arms raised sideways
    1–2 s, T-pose 2–3 s, then hips, knees and elbows moving (3–5 s)."""
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 5.0, 0.01)
    q_body = sk.q_world_from_body_facing(np.radians(130.0))
    angles = {j: np.zeros((t.size, 3)) for j in TEN.joint_names}
    moving = t >= 3.0
    wave = np.sin(np.pi * (t[moving] - 3.0) / 2.0)
    for side in ("l", "r"):
        angles[f"hip_{side}"][moving] = np.column_stack((40 * wave, 5 * wave, 10 * wave))
        angles[f"knee_{side}"][moving, 0] = 70 * wave
        angles[f"elbow_{side}"][moving, 0] = 100 * wave
        angles[f"shoulder_{side}"][moving] = np.column_stack((30 * wave, -20 * wave, 15 * wave))
    segments = sk.segment_orientations_from_joint_angles(TEN, np.broadcast_to(q_body, (t.size, 4)), angles)
    level = np.clip(t - 1.0, 0.0, 1.0) * (t < 3.0)
    for side, sign in (("l", 1.0), ("r", -1.0)):
        raised = rot.multiply(q_body, rot.from_axis_angle(EX, sign * np.radians(90.0) * level))
        for seg in (f"upper_arm_{side}", f"forearm_{side}"):
            segments[seg] = np.where((t < 3.0)[:, None], raised, segments[seg])
    mountings = {s: rot.normalize(rng.normal(size=4)) for s in TEN.segment_names}
    sensors = {f"imu{i}": rot.multiply(segments[s], mountings[s]) for i, s in enumerate(TEN.segment_names)}
    mapping = ",".join(f"imu{i}={s}" for i, s in enumerate(TEN.segment_names))
    return t, sensors, mapping, mountings, segments


@pytest.fixture
def suit_csv(suit, tmp_path):
    t, sensors, *_ = suit
    path = tmp_path / "suit.csv"
    write_quaternion_csv(path, QuaternionTable(t, sensors, source="suit"))
    return path


def test_npose_tpose_calibration_file_and_joint_angles(suit, suit_csv, tmp_path, capsys):
    t, _, mapping, mountings, segments = suit
    cal = tmp_path / "CAL.json"
    code = main(["bodycal", str(suit_csv), "--mapping", mapping, "--npose", "0:0.99", "--tpose", "2:2.99",
                 "--out", str(cal)])
    assert code == 0
    out = capsys.readouterr().out
    assert "verdict good" in out and "10 segments calibrated" in out
    document = json.loads(cal.read_text())
    assert document["format"] == "mimucap-body-calibration" and document["method"] == "npose_tpose"
    assert document["verdict"] == "good" and document["model"] == "ten_segment"
    facing = sk.q_world_from_body_facing(np.radians(130.0))
    assert np.degrees(rot.angle_between(document["q_world_from_body"], facing)) < 0.5
    for i, segment in enumerate(TEN.segment_names):
        entry = document["segments"][segment]
        assert entry["sensor"] == f"imu{i}"
        assert np.degrees(rot.angle_between(entry["q_segment_from_sensor"], mountings[segment])) < 0.5
    arms = document["quality"]["arms"]
    assert {a["side"] for a in arms} == {"left", "right"}
    assert all(abs(a["rotation_angle_deg"] - 90.0) < 0.5 for a in arms)
    assert document["quality"]["left_right_disagreement_deg"] < 0.5

    for suffix, reader in ((".csv", read_angles_csv), (".mot", read_angles_mot)):
        out_path = tmp_path / f"angles{suffix}"
        assert main(["angles", str(suit_csv), "--calibration", str(cal), "--out", str(out_path)]) == 0
        table = reader(out_path)
        truth = sk.joint_angles_deg(TEN, segments)
        assert list(table.angles_deg) == sk.joint_angle_columns(TEN)
        moving = t >= 3.0
        for column, values in truth.items():
            np.testing.assert_allclose(table.angles_deg[column][moving], values[moving], atol=1.0, err_msg=column)
        assert table.angles_deg["knee_r_flexion_deg"].max() == pytest.approx(70.0, abs=1.0)
        assert table.angles_deg["elbow_l_flexion_deg"].max() == pytest.approx(100.0, abs=1.0)


def test_json_output_and_the_isb_shoulder_columns(suit, suit_csv, tmp_path, capsys):
    _, _, mapping, mountings, _ = suit
    cal = tmp_path / "CAL.json"
    assert main(["bodycal", str(suit_csv), "--mapping", mapping, "--npose", "0:0.99", "--tpose", "2:2.99",
                 "--forward-from", "rotation_axis", "--out", str(cal), "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed == json.loads(cal.read_text())
    shank = printed["segments"]["shank_r"]["q_segment_from_sensor"]
    assert np.degrees(rot.angle_between(shank, mountings["shank_r"])) < 0.5
    out = tmp_path / "a.csv"
    assert main(["angles", str(suit_csv), "--calibration", str(cal), "--shoulder", "yxy", "--out", str(out)]) == 0
    table = read_angles_csv(out)
    assert "shoulder_r_plane_of_elevation_deg" in table.angles_deg and "shoulder_r_elevation_deg" in table.angles_deg
    assert any("Y-X'-Y''" in line for line in table.header)
    # In the T-pose the arm is elevated 90° in the abduction plane (plane of elevation 0).
    t_pose = (table.t_s > 2.0) & (table.t_s < 3.0)
    assert np.median(table.angles_deg["shoulder_r_elevation_deg"][t_pose]) == pytest.approx(90.0, abs=0.5)
    assert np.median(table.angles_deg["shoulder_l_elevation_deg"][t_pose]) == pytest.approx(90.0, abs=0.5)


@pytest.mark.data("opensense")
def test_heading_mode_on_the_opensense_walk(shared_data, tmp_path, capsys):
    folder = shared_data / "body" / "opensense_example"
    mapping = ("pelvis_imu=pelvis,torso_imu=thorax,femur_r_imu=thigh_r,femur_l_imu=thigh_l,tibia_r_imu=shank_r,"
               "tibia_l_imu=shank_l,calcn_r_imu=foot_r,calcn_l_imu=foot_l")
    cal = tmp_path / "CAL.json"
    names = ["--sensor-names", str(folder / "myIMUMappings.xml")]
    assert main(["bodycal", str(folder / "IMUData"), *names, "--mapping", mapping,
                 "--heading-from", "pelvis_imu:z", "--out", str(cal)]) == 0
    document = json.loads(cal.read_text())
    assert document["method"] == "heading" and document["model"] == "fifteen_segment"
    assert document["heading_sensor"] == "pelvis_imu" and document["npose_s"] == [0.0, 0.0]
    out = tmp_path / "walk.mot"
    assert main(["angles", str(folder / "IMUData"), *names, "--calibration", str(cal), "--out", str(out)]) == 0
    assert "knee_r" in capsys.readouterr().out
    table = read_angles_mot(out)
    assert set(table.angles_deg) == {f"{j}_{a}_deg" for j in ("lumbar", "hip_l", "hip_r", "knee_l", "knee_r",
                                                                "ankle_l", "ankle_r")
                                     for a in ("flexion", "adduction", "rotation")}
    assert 50.0 < table.angles_deg["knee_l_flexion_deg"].max() < 80.0


def test_mapping_defaults_to_the_session_segments(tmp_path, suit):
    from mimucap.core.sensor_samples import SensorSamples
    from mimucap.io.session import Session, write_session

    t, sensors, mapping, mountings, _ = suit
    pairs = dict(item.split("=") for item in mapping.split(","))
    session = Session(sensors={s: SensorSamples(s, t, np.arange(t.size), q_world_from_sensor=q, segment=pairs[s])
                               for s, q in sensors.items()})
    path = tmp_path / "suit.h5"
    write_session(path, session)
    cal = tmp_path / "CAL.json"
    assert main(["bodycal", str(path), "--npose", "0:0.99", "--tpose", "2:2.99", "--out", str(cal)]) == 0
    document = json.loads(cal.read_text())
    assert np.degrees(rot.angle_between(document["segments"]["shank_l"]["q_segment_from_sensor"],
                                        mountings["shank_l"])) < 0.5


def run_error(argv, capsys):
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 1
    assert len(err.splitlines()) == 1
    return err


@pytest.mark.parametrize(("extra", "message"), [
    (["--mapping", "imu0=pelvis,nosuch=thorax"], "unknown sensor 'nosuch' in the mapping"),
    (["--mapping", "imu0=pelvis,=thorax"], "segment 'thorax' has no sensor"),
    (["--mapping", "imu0=pelvis,imu1="], "sensor 'imu1' has no segment"),
    (["--mapping", "imu0=pelvis,imu1=tail"], "unknown segment 'tail'"),
    (["--mapping", "imu0"], "expected SENSOR=SEGMENT"),
])
def test_mapping_errors_name_the_entry(suit_csv, tmp_path, capsys, extra, message):
    err = run_error(["bodycal", str(suit_csv), *extra, "--npose", "0:0.99", "--tpose", "2:2.99",
                     "--out", str(tmp_path / "c.json")], capsys)
    assert message in err


@pytest.mark.parametrize(("extra", "message"), [
    (["--npose", "0:0.99", "--tpose", "4.5:9"], "T-pose window 4.5:9 s lies outside the recording (0:4.99 s)"),
    (["--npose", "0:0.99"], "give --tpose T2:T3 (N/T-pose calibration) or --heading-from SENSOR:AXIS"),
    (["--tpose", "2:2.99"], "--tpose needs --npose"),
    (["--npose", "a:b", "--tpose", "2:3"], "--npose 'a:b': expected START:END"),
    (["--heading-from", "imu0:w"], "unknown axis 'w'"),
    (["--heading-from", "imu0"], "expected SENSOR:AXIS"),
    (["--heading-from", "imu0:x", "--tpose", "2:3", "--npose", "0:1"], "not both"),
])
def test_window_and_mode_errors(suit, suit_csv, tmp_path, capsys, extra, message):
    err = run_error(["bodycal", str(suit_csv), "--mapping", suit[2], *extra, "--out", str(tmp_path / "c.json")], capsys)
    assert message in err


def test_nan_and_malformed_inputs_are_named(tmp_path, capsys):
    nan = tmp_path / "nan.csv"
    nan.write_text("t_s,a_qw,a_qx,a_qy,a_qz\n0,1,0,0,0\n0.01,nan,nan,nan,nan\n")
    err = run_error(["bodycal", str(nan), "--mapping", "a=pelvis", "--heading-from", "a:x", "--out", str(tmp_path / "c.json")], capsys)
    assert "nan.csv: line 3: sensor a: NaN quaternion" in err
    broken = tmp_path / "broken.sto"
    broken.write_text("version=3\ntime\ta\n")
    err = run_error(["bodycal", str(broken), "--mapping", "a=pelvis", "--heading-from", "a:x", "--out", str(tmp_path / "c.json")], capsys)
    assert "broken.sto: no 'endheader'" in err
    cal = tmp_path / "bad.json"
    cal.write_text("{not json")
    err = run_error(["angles", str(nan), "--calibration", str(cal), "--out", str(tmp_path / "a.csv")], capsys)
    assert "bad.json: invalid JSON at line 1" in err


def test_refusal_is_one_clear_line(suit, suit_csv, tmp_path, capsys):
    """Both 'poses' taken while the arms hang: the arms were not raised."""
    err = run_error(["bodycal", str(suit_csv), "--mapping", suit[2], "--npose", "0:0.4", "--tpose", "0.5:0.9",
                     "--out", str(tmp_path / "c.json")], capsys)
    assert "was not raised" in err
    assert not (tmp_path / "c.json").exists()


def test_angles_errors(suit, suit_csv, tmp_path, capsys):
    cal = tmp_path / "CAL.json"
    assert main(["bodycal", str(suit_csv), "--mapping", "imu0=pelvis,imu4=upper_arm_r", "--npose", "0:0.99",
                 "--tpose", "2:2.99", "--out", str(cal)]) == 0
    capsys.readouterr()
    err = run_error(["angles", str(suit_csv), "--calibration", str(cal), "--out", str(tmp_path / "a.txt")], capsys)
    assert "written as .csv or .mot" in err
    other = tmp_path / "other.csv"
    write_quaternion_csv(other, QuaternionTable(np.arange(3) * 0.01, {"zz": rot.identity((3,))}, source="x"))
    err = run_error(["angles", str(other), "--calibration", str(cal), "--out", str(tmp_path / "a.csv")], capsys)
    assert "calibrated sensor(s) imu0, imu4 missing from the data" in err
    lone = tmp_path / "lone.json"
    document = json.loads(cal.read_text())
    document["segments"] = {"pelvis": document["segments"]["pelvis"]}
    lone.write_text(json.dumps(document))
    err = run_error(["angles", str(suit_csv), "--calibration", str(lone), "--out", str(tmp_path / "a.csv")], capsys)
    assert "no joint has calibrated segments on both sides" in err


def test_simulated_session_from_mimucap_simulate(tmp_path, capsys):
    """``mimucap simulate`` (demo: N-pose 0–3 s, T-pose 3–6 s, N-pose, walking from 8 s) with
    on-board orientations, then bodycal and angles on the session file; the session's ground
    truth is the reference."""
    from mimucap.io.session import read_session

    session_path = tmp_path / "demo.h5"
    assert main(["simulate", "--scenario", "demo", "--duration", "14", "--sensors", "10", "--seed", "5",
                 "--errors", "ideal", "--onboard", "--no-magcal-turns", "--out", str(session_path)]) == 0
    cal = tmp_path / "CAL.json"
    assert main(["bodycal", str(session_path), "--npose", "1:2.9", "--tpose", "5:5.9", "--out", str(cal)]) == 0
    out = tmp_path / "angles.csv"
    assert main(["angles", str(session_path), "--calibration", str(cal), "--out", str(out)]) == 0
    capsys.readouterr()
    session = read_session(session_path)
    document = json.loads(cal.read_text())
    for segment, entry in document["segments"].items():
        true_mounting = session.truth.sensors[entry["sensor"]].q_segment_from_sensor
        assert session.sensors[entry["sensor"]].segment == segment
        assert np.degrees(rot.angle_between(entry["q_segment_from_sensor"], true_mounting)) < 0.5
    table = read_angles_csv(out)
    walking = table.t_s >= 9.0
    truth_t = session.truth.t_s
    for column, values in table.angles_deg.items():
        expected = np.interp(table.t_s[walking], truth_t, session.truth.joint_angles_deg[column])
        np.testing.assert_allclose(values[walking], expected, atol=1.0, err_msg=column)


def test_a_calibration_file_with_a_bad_cell_or_a_shared_sensor_is_refused_naming_it(suit, suit_csv, tmp_path, capsys):
    cal = tmp_path / "CAL.json"
    assert main(["bodycal", str(suit_csv), "--mapping", suit[2], "--npose", "0:0.99", "--tpose", "2:2.99",
                 "--out", str(cal)]) == 0
    capsys.readouterr()
    document = json.loads(cal.read_text())
    text = json.loads(cal.read_text())
    text["segments"]["thorax"]["q_segment_from_sensor"][0] = "a"   # was: "could not convert string to float: 'a'"
    edited = tmp_path / "edited.json"
    edited.write_text(json.dumps(text))
    err = run_error(["angles", str(suit_csv), "--calibration", str(edited), "--out", str(tmp_path / "a.csv")], capsys)
    assert "edited.json: segment thorax: q_segment_from_sensor: expected a list of numbers" in err
    shared = json.loads(cal.read_text())
    shared["segments"]["thorax"]["sensor"] = document["segments"]["pelvis"]["sensor"]  # as --mapping refuses it
    edited.write_text(json.dumps(shared))
    err = run_error(["angles", str(suit_csv), "--calibration", str(edited), "--out", str(tmp_path / "a.csv")], capsys)
    assert "edited.json: sensor imu0 serves two segments (pelvis and thorax)" in err
    assert not (tmp_path / "a.csv").exists()


@pytest.mark.data("opensense")
def test_reader_options_are_checked_not_replaced_or_ignored(suit, suit_csv, tmp_path, capsys, shared_data):
    xsens = (shared_data / "body" / "opensense_example" / "xsens_format_variants"
             / "MT2022_ACC_GYRO_ROT_EULER_TAB_00B42D4F.txt")
    heading = ["--mapping", "00B42D4F=pelvis", "--heading-from", "00B42D4F:x"]
    cal = tmp_path / "CAL.json"
    assert main(["bodycal", str(xsens), *heading, "--out", str(cal)]) == 0
    capsys.readouterr()
    for rate in ("0", "nan", "-100", "inf"):   # was: 0 fell back to 100 Hz, nan gave a time error, -100 ignored
        err = run_error(["bodycal", str(xsens), *heading, f"--rate={rate}", "--out", str(tmp_path / "c.json")], capsys)
        assert f"--rate {rate}: the update rate must be a positive number of Hz" in err
        err = run_error(["angles", str(xsens), "--calibration", str(cal), f"--rate={rate}",
                         "--out", str(tmp_path / "a.csv")], capsys)
        assert f"--rate {rate}: the update rate must be a positive number of Hz" in err
    # --up where the world is z up by definition: refused, not ignored (was: ignored silently)
    err = run_error(["bodycal", str(xsens), *heading, "--up", "y", "--out", str(tmp_path / "c.json")], capsys)
    assert "MT2022_ACC_GYRO_ROT_EULER_TAB_00B42D4F.txt: up axis y cannot apply" in err
    assert main(["bodycal", str(xsens), *heading, "--up", "z", "--out", str(tmp_path / "c.json")]) == 0


@pytest.mark.data("broad", "opensense")
def test_xsens_reader_options_are_refused_for_inputs_they_do_not_apply_to(suit, suit_csv, tmp_path, capsys,
                                                                        shared_data):
    """Was: --sensor-names, --trial and --rate were used for Xsens exports and silently ignored
    for every other input (a session, a CSV, a BROAD trial...)."""
    from mimucap.core.sensor_samples import SensorSamples
    from mimucap.io.session import Session, write_session

    t, sensors, mapping, *_ = suit
    session = write_session(tmp_path / "suit.h5", Session(sensors={
        s: SensorSamples(s, t, np.arange(t.size), q_world_from_sensor=q) for s, q in sensors.items()}))
    opensense = shared_data / "body" / "opensense_example"
    xml = str(opensense / "myIMUMappings.xml")
    xsens_file = opensense / "xsens_format_variants" / "MT2022_ACC_GYRO_ROT_EULER_TAB_00B42D4F.txt"
    cal = tmp_path / "CAL.json"
    assert main(["bodycal", str(suit_csv), "--mapping", mapping, "--npose", "0:0.99", "--tpose", "2:2.99",
                 "--out", str(cal)]) == 0
    cases = [
        (session, ["--trial", "MT_012005D6_009-001"], "--trial applies to Xsens export folders only, "
                                                      "not to MimuCap sessions"),
        (session, ["--sensor-names", xml], "--sensor-names applies to Xsens export folders and Xsens export "
                                           "files only, not to MimuCap sessions"),
        (suit_csv, ["--sensor-names", xml], "not to quaternion CSV files"),
        (suit_csv, ["--trial", "MT"], "--trial applies to Xsens export folders only, not to quaternion CSV files"),
        (opensense / "test_resources" / "imuOrientations.sto", ["--trial", "MT"], "not to OpenSim .sto tables"),
        (opensense / "xsens_format_variants" / "apdm_format7.csv", ["--sensor-names", xml], "not to APDM CSV files"),
        (shared_data / "broad" / "24_disturbed_tapping_A.hdf5", ["--trial", "MT"], "not to BROAD trials"),
        (xsens_file, ["--trial", "MT"], "--trial applies to Xsens export folders only, not to Xsens export files"),
        (session, ["--rate", "100"], "--rate applies to Xsens export folders and Xsens export files only, "
                                     "not to MimuCap sessions"),
        (suit_csv, ["--rate", "60"], "not to quaternion CSV files"),
    ]
    for path, option, message in cases:
        err = run_error(["bodycal", str(path), "--mapping", mapping, "--npose", "0:0.99", "--tpose", "2:2.99",
                         *option, "--out", str(tmp_path / "c.json")], capsys)
        assert err.startswith(f"mimucap bodycal: error: {path}: {option[0]} applies to Xsens export folders")
        assert err.endswith(message)
        err = run_error(["angles", str(path), "--calibration", str(cal), *option,
                         "--out", str(tmp_path / "a.csv")], capsys)
        assert err.startswith(f"mimucap angles: error: {path}: {option[0]} applies to") and err.endswith(message)
    assert not (tmp_path / "c.json").exists() and not (tmp_path / "a.csv").exists()
    # where they apply they are still used: --sensor-names renames a single Xsens file's sensor
    assert main(["bodycal", str(xsens_file), "--sensor-names", xml, "--mapping", "00B42D4F=pelvis",
                 "--heading-from", "00B42D4F:x", "--out", str(tmp_path / "c.json")]) == 0


def test_a_bad_out_path_is_refused_before_the_computation(suit, suit_csv, tmp_path, capsys, monkeypatch):
    import mimucap.cli.angles as angles_command
    import mimucap.cli.bodycal as bodycal_command

    def must_not_read(args):
        raise AssertionError("the input was read before the output path was checked")

    monkeypatch.setattr(bodycal_command, "read_input", must_not_read)
    monkeypatch.setattr(angles_command, "read_input", must_not_read)
    blocker = tmp_path / "notes.txt"
    blocker.write_text("a file, not a folder")
    cal = tmp_path / "CAL.json"
    cal.write_text("{}")
    for out, message in ((tmp_path / "missing" / "c.json", f"folder {tmp_path / 'missing'} does not exist"),
                         (blocker / "c.json", f"{blocker} is a file, not a folder")):
        err = run_error(["bodycal", str(suit_csv), "--mapping", suit[2], "--npose", "0:0.99", "--tpose", "2:2.99",
                         "--out", str(out)], capsys)
        assert err.endswith(f"cannot write {out}: {message}")
    valid = {"format": "mimucap-body-calibration", "format_version": 1, "q_world_from_body": [1, 0, 0, 0],
             "up_world": [0, 0, 1], "segments": {"pelvis": {"sensor": "imu0", "q_segment_from_sensor": [1, 0, 0, 0]}}}
    cal.write_text(json.dumps(valid))
    err = run_error(["angles", str(suit_csv), "--calibration", str(cal), "--out", str(blocker / "a.csv")], capsys)
    assert f"cannot write {blocker / 'a.csv'}: {blocker} is a file, not a folder" in err


def test_session_streams_are_put_on_one_time_axis_through_the_processing_path(tmp_path):
    """The commands' view of a session: every sensor's orientation (on-board, or fused by the
    pipeline) at the instants of the best-sampled sensor where all have one."""
    from mimucap.cli.session_input import orientation_table
    from mimucap.core.sensor_samples import SensorSamples
    from mimucap.io.session import Session

    t_a = np.arange(0.0, 2.0, 0.01)
    t_b = np.arange(0.003, 2.0, 0.02)
    turn_a = rot.from_axis_angle([0, 0, 1.0], 0.5 * t_a)   # 0.5 rad/s about up
    turn_b = rot.from_axis_angle([1.0, 0, 0], -0.3 * t_b)
    q_true = rot.from_axis_angle([1.0, 0, 0], np.radians(30.0))  # F rests tilted 30° about x
    acc = np.broadcast_to(rot.rotate(rot.conjugate(q_true), [0, 0, 9.81]), (t_a.size, 3)).copy()
    session = Session(sensors={
        "A": SensorSamples("A", t_a, np.arange(t_a.size), q_world_from_sensor=turn_a, segment="pelvis"),
        "B": SensorSamples("B", t_b, np.arange(t_b.size), q_world_from_sensor=turn_b, segment="thorax"),
        "F": SensorSamples("F", t_a, np.arange(t_a.size), acc=acc, gyr=np.zeros((t_a.size, 3))),
        "M": SensorSamples("M", t_a, np.arange(t_a.size), mag_uT=np.ones((t_a.size, 3))),
    })
    table = orientation_table(session, "s.h5", {})
    assert table.t_s[0] >= 0.003 and table.t_s[-1] <= t_b[-1]
    assert set(table.q_world_from_sensor) == {"A", "B", "F"}   # M has nothing to give an orientation
    assert table.segment_hints == {"A": "pelvis", "B": "thorax"}
    expected_b = rot.from_axis_angle([1.0, 0, 0], -0.3 * table.t_s)
    assert np.degrees(rot.angle_between(table.q_world_from_sensor["B"], expected_b)).max() < 1e-6
    expected_a = rot.from_axis_angle([0, 0, 1.0], 0.5 * table.t_s)
    assert np.degrees(rot.angle_between(table.q_world_from_sensor["A"], expected_a)).max() < 1e-6
    up_in_sensor = rot.rotate(rot.conjugate(table.q_world_from_sensor["F"][-1]), [0, 0, 1.0])
    np.testing.assert_allclose(up_in_sensor, rot.rotate(rot.conjugate(q_true), [0, 0, 1.0]), atol=0.01)


# --------------------------------------------------------------------------------------------
# --method functional
# --------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def walking_session(tmp_path_factory):
    """``mimucap simulate`` demo, 18 s, on-board orientations: N-pose 0-3 s, T-pose 3-6 s,
    N-pose 6-8 s, walk 8-16 s (then a turn), each marked; the truth is stored with it."""
    path = tmp_path_factory.mktemp("functional") / "demo.h5"
    assert main(["simulate", "--scenario", "demo", "--duration", "18", "--sensors", "10", "--seed", "5",
                 "--errors", "ideal", "--onboard", "--no-magcal-turns", "--out", str(path)]) == 0
    return path


def test_functional_calibration_of_a_session_takes_its_windows_from_the_markers(walking_session, tmp_path, capsys):
    from mimucap.io.session import read_session

    cal = tmp_path / "CAL.json"
    assert main(["bodycal", str(walking_session), "--method", "functional", "--out", str(cal)]) == 0
    out = capsys.readouterr().out
    assert "windows from the session's markers: standing still 7.00-7.70 s (N-pose), movement 8.00-16.00 s (walk)" in out
    assert "verdict good" in out and "pelvis (S01) faces the walking direction" in out
    # the verdict says how well the movement defined each axis, on screen and in the file
    assert "how well the movement defined each axis:\n    Left knee axis good: it bent" in out
    assert "    Pelvis forward direction good: it faces the walking direction; the two halves of the movement found it within" in out
    document = json.loads(cal.read_text())
    axes = {axis["axis"]: axis for axis in document["quality"]["axes"]}
    assert axes["knee_r"]["verdict"] == "good" and axes["knee_r"]["segments"] == ["thigh_r", "shank_r"]
    assert axes["knee_r"]["words"].startswith("Right knee axis good: it bent")
    assert axes["thorax"]["verdict"] == "good" and axes["thorax"]["words"].startswith("Thorax forward direction good")
    assert document["method"] == "functional" and document["still_s"] == [7.0, 7.7]
    assert document["movement_s"] == [8.0, 16.0] and "tpose_s" not in document
    session = read_session(walking_session)
    for segment, entry in document["segments"].items():
        true_mounting = session.truth.sensors[entry["sensor"]].q_segment_from_sensor
        # the simulated knee turns ±3° about the shank while walking, so not quite a hinge
        assert np.degrees(rot.angle_between(entry["q_segment_from_sensor"], true_mounting)) < 2.0, segment
    out = tmp_path / "angles.csv"
    assert main(["angles", str(walking_session), "--calibration", str(cal), "--out", str(out)]) == 0
    table = read_angles_csv(out)
    walking = (table.t_s >= 9.0) & (table.t_s <= 16.0)
    for column in ("knee_r_flexion_deg", "knee_l_flexion_deg", "hip_r_flexion_deg", "hip_l_flexion_deg"):
        expected = np.interp(table.t_s[walking], session.truth.t_s, session.truth.joint_angles_deg[column])
        assert np.sqrt(np.mean((table.angles_deg[column][walking] - expected) ** 2)) < 1.0, column


def test_functional_calibration_of_a_table_with_given_windows(suit, suit_csv, tmp_path, capsys):
    """The suit's knees and elbows flex from 3 s while the pelvis stays put facing 130°."""
    _, _, mapping, mountings, _ = suit
    cal = tmp_path / "CAL.json"
    assert main(["bodycal", str(suit_csv), "--mapping", mapping, "--method", "functional", "--still", "0:0.99",
                 "--movement", "3:4.99", "--out", str(cal), "--json"]) == 0
    document = json.loads(capsys.readouterr().out)
    assert document["quality"]["axis_sources"]["shank_l"] == "knee_l"
    for segment in TEN.segment_names:
        assert np.degrees(rot.angle_between(document["segments"][segment]["q_segment_from_sensor"],
                                            mountings[segment])) < 0.5, segment
    facing = sk.q_world_from_body_facing(np.radians(130.0))
    assert np.degrees(rot.angle_between(document["q_world_from_body"], facing)) < 0.5


def test_functional_calibration_finds_the_still_second_and_takes_the_rest(suit, suit_csv, tmp_path, capsys):
    """Without windows a table's first still second is the standing and the rest the movement
    (here the arm raise of 1-3 s too: the elbows then stay straight, the knees still flex)."""
    cal = tmp_path / "CAL.json"
    assert main(["bodycal", str(suit_csv), "--mapping", suit[2], "--method", "functional", "--out", str(cal)]) == 0
    out = capsys.readouterr().out
    assert "standing still: 0.00-1.00 s, the first second in which every sensor was still" in out
    assert "movement: 1.01-4.99 s, the rest of the recording" in out


@pytest.mark.parametrize(("extra", "message"), [
    (["--method", "functional", "--tpose", "2:3"], "--tpose belongs to the npose-tpose method, not to --method functional"),
    (["--method", "functional", "--heading-from", "imu0:x"], "--heading-from belongs to the heading method"),
    (["--method", "functional", "--arms", "left", "--forward-from", "swing"],
     "--arms, --forward-from belong to the npose-tpose method"),
    (["--method", "functional", "--npose", "0:1"], "--method functional takes its standing window from --still"),
    (["--still", "0:1"], "--still belongs to the functional method, not to --method npose-tpose"),
    (["--heading-from", "imu0:x", "--movement", "1:2"], "--movement belongs to the functional method, not to "
                                                        "--method heading"),
    (["--method", "heading"], "--method heading needs --heading-from SENSOR:AXIS"),
    (["--method", "npose-tpose", "--heading-from", "imu0:x"], "--heading-from belongs to the heading method"),
    (["--method", "functional", "--still", "0:0.99", "--movement", "0.5:3"], "overlap"),
    (["--method", "functional", "--still", "4.5:4.99"], "nothing follows the still window 4.5:4.99 s: give --movement"),
])
def test_options_of_another_method_are_refused(suit, suit_csv, tmp_path, capsys, extra, message):
    err = run_error(["bodycal", str(suit_csv), "--mapping", suit[2], *extra, "--out", str(tmp_path / "c.json")], capsys)
    assert message in err
    assert not (tmp_path / "c.json").exists()


def test_a_poor_functional_calibration_is_written_and_exits_3(tmp_path, capsys):
    """Standing 0-1 s, then knees that bend only 10°: their axes are weakly defined."""
    rng = np.random.default_rng(21)
    t = np.arange(0.0, 6.0, 0.01)
    bend = 10.0 * (t > 1.0) * 0.5 * (1 - np.cos(2 * np.pi * t / 1.1))
    angles = {f"knee_{side}": np.column_stack((bend, np.zeros_like(t), np.zeros_like(t))) for side in "lr"}
    legs = ("pelvis", "thigh_l", "thigh_r", "shank_l", "shank_r")
    q_body = np.broadcast_to(sk.q_world_from_body_facing(0.7), (t.size, 4))
    segments = sk.segment_orientations_from_joint_angles(TEN, q_body, angles)
    sensors = {f"imu{i}": rot.multiply(segments[s], rot.normalize(rng.normal(size=4))) for i, s in enumerate(legs)}
    path = tmp_path / "legs.csv"
    write_quaternion_csv(path, QuaternionTable(t, sensors, source="legs"))
    argv = ["bodycal", str(path), "--mapping", ",".join(f"imu{i}={s}" for i, s in enumerate(legs)),
            "--method", "functional", "--out", str(tmp_path / "c.json")]
    assert main(argv) == 3
    err = capsys.readouterr().err
    assert "verdict is poor (the left knee moved only 10°" in err and "redo the movement" in err
    assert (tmp_path / "c.json").exists()
    assert main(argv + ["--accept-poor"]) == 0
