"""Xsens MVNX import: the sample file's own joint angles are the oracle for our joint-angle code,
its own segment orientations for the session built from its sensors.

The sample (``shared/data/body/mvnx_sample``) is an upper-body recording of Xsens MVN 2019:
MVNX version 4, 60 Hz, 23 segments, 11 sensors, 22 joints, 112 frames after three calibration
frames. A version-3 layout is made from it by removing what version 4 added.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from mimucap.cli import main
from mimucap.core import rotation as rot
from mimucap.core import skeleton
from mimucap.io import mvnx

AXES = ("flexion", "adduction", "rotation")


@pytest.fixture(scope="module")
def sample() -> Path:
    from tests.external_data import data_path

    return data_path("mvnx", "test_mocap.mvnx")


@pytest.fixture(scope="module")
def recording(sample) -> mvnx.MvnxRecording:
    return mvnx.read_mvnx(sample)


def per_joint(model, q_world_from_segment) -> dict[str, np.ndarray]:
    angles = skeleton.joint_angles_deg(model, q_world_from_segment)
    return {j: np.column_stack([angles[f"{j}_{a}_deg"] for a in AXES]) for j in mvnx.XSENS_JOINTS}


@pytest.mark.data("mvnx")
def test_reads_the_sample_as_its_header_describes_it(recording):
    assert recording.version == 4 and recording.frame_rate_hz == 60.0 and recording.configuration == "UpperBody"
    assert len(recording.segments) == 23 and len(recording.sensors) == 11 and len(recording.joints) == 22
    assert len(recording.t_s) == 112 and recording.t_s[1] == pytest.approx(1 / 60)
    assert {"identity", "tpose", "tpose-isb"} <= set(recording.calibration_poses)
    # In Xsens's identity pose every segment frame is the global frame.
    identity = np.stack(list(recording.calibration_poses["identity"].values()))
    assert np.allclose(np.abs(identity[:, 0]), 1.0)
    assert recording.joints[8] == mvnx.MvnxJoint("jRightElbow", "RightUpperArm", "RightForeArm")
    assert 1.5 < recording.height_m() < 1.9
    assert set(recording.q_global_from_sensor) == set(recording.sensors)
    # Free acceleration is small (gravity removed) in this slow upper-body movement.
    assert np.median(np.linalg.norm(recording.free_acc_mps2["Pelvis"], axis=1)) < 1.0


@pytest.mark.data("mvnx")
def test_our_joint_angles_match_xsens_where_the_definitions_match(recording):
    model = skeleton.load_model("fifteen_segment")
    ours = per_joint(model, recording.q_world_from_segment())
    for joint in ("lumbar", "neck", "shoulder_r", "shoulder_l"):
        assert np.abs(ours[joint] - mvnx.xsens_angles_as_ours(recording, joint)).max() < 0.01, joint
    for joint in ("elbow_r", "elbow_l"):
        difference = (ours[joint] - mvnx.xsens_angles_as_ours(recording, joint) + 180.0) % 360.0 - 180.0
        assert np.abs(difference[:, :2]).max() < 0.01, joint
        # Xsens counts the forearm's axial rotation from palms forward, we from the N-pose.
        assert np.abs(np.abs(difference[:, 2]) - 90.0).max() < 0.01, joint
    anatomical = per_joint(model, mvnx.anatomical_forearms(recording.q_world_from_segment()))
    for joint in mvnx.XSENS_JOINTS:
        difference = (anatomical[joint] - mvnx.xsens_angles_as_ours(recording, joint) + 180.0) % 360.0 - 180.0
        assert np.abs(difference).max() < 0.01, joint
    assert np.ptp(ours["elbow_r"][:, 0]) > 1.0 and np.ptp(ours["shoulder_l"][:, 2]) > 5.0  # they moved


@pytest.mark.data("mvnx")
def test_imported_session_is_reviewed_from_its_sensors(sample, recording, tmp_path):
    out = tmp_path / "imported.h5"
    assert main(["import", str(sample), "--out", str(out)]) == 0
    from mimucap.session.recorded.review import load_review

    data = load_review(out)
    assert data.model.name == "fifteen_segment"
    assert data.height_m == pytest.approx(recording.height_m())
    assert data.session.sensors["RightForeArm"].segment == "forearm_r"
    assert data.session.sensors["RightShoulder"].segment is None
    # Segments from the sensors and Xsens's calibration against Xsens's own segments: MVN does
    # not carry its segments rigidly on the sensors, so a few degrees remain.
    reference = recording.q_world_from_segment()
    for segment in ("pelvis", "thorax", "head", "upper_arm_r", "forearm_l", "hand_r"):
        error = np.degrees(rot.angle_between(data.q_world_from_segment[segment], reference[segment]))
        assert error.max() < 4.0, (segment, error.max())
    # Specific force in the sensor frame: about g in this slow movement.
    acc = data.session.sensors["T8"].acc
    assert np.median(np.linalg.norm(acc, axis=1)) == pytest.approx(9.81, abs=0.3)
    stored = data.session.results["xsens"]["joint_angle_deg"]["jRightElbow"]
    assert np.allclose(stored, recording.joint_angle_deg["jRightElbow"])
    c3d_file = tmp_path / "imported.c3d"
    assert main(["export", str(out), "--out", str(c3d_file)]) == 0 and c3d_file.stat().st_size > 10_000


@pytest.mark.data("mvnx")
def test_version_3_layout_is_read(sample, tmp_path):
    text = sample.read_text(encoding="utf-8")
    text = text.replace('version="4"', 'version="3"', 1).replace(' xmlns="http://www.xsens.com/mvn/mvnx"', "")
    text = re.sub(r"\s*<jointAngleXZY>.*?</jointAngleXZY>", "", text)
    text = re.sub(r"\s*<jointAngleErgo>.*?</jointAngleErgo>", "", text)
    text = re.sub(r"\s*<ergonomicJointAngles>.*?</ergonomicJointAngles>", "", text, flags=re.S)
    path = tmp_path / "v3.mvnx"
    path.write_text(text, encoding="utf-8")
    old = mvnx.read_mvnx(path)
    assert old.version == 3 and not old.ergo_angle_deg and not old.joint_angle_xzy_deg
    assert np.allclose(old.joint_angle_deg["jRightElbow"], mvnx.read_mvnx(sample).joint_angle_deg["jRightElbow"])


@pytest.mark.data("mvnx")
def test_bad_files_are_refused_with_a_reason(sample, tmp_path):
    text = sample.read_text(encoding="utf-8")
    newer = tmp_path / "v5.mvnx"
    newer.write_text(text.replace('version="4"', 'version="5"', 1), encoding="utf-8")
    with pytest.raises(ValueError, match="version 5 is not supported"):
        mvnx.read_mvnx(newer)
    cut = tmp_path / "cut.mvnx"
    cut.write_text(text[: len(text) // 2], encoding="utf-8")
    with pytest.raises(ValueError, match="not readable XML"):
        mvnx.read_mvnx(cut)
    short = tmp_path / "short.mvnx"
    start = text.index('index="5"')
    at = text.index("<orientation>", start) + len("<orientation>")
    short.write_text(text[:at] + text[at:].replace("1.0", "", 0).split(" ", 4)[4], encoding="utf-8")
    with pytest.raises(ValueError, match=r"frame 5: orientation has \d+ numbers"):
        mvnx.read_mvnx(short)
    with pytest.raises(ValueError, match="reads Xsens .mvnx files"):
        from mimucap.io.recording_import import session_from_file

        session_from_file(tmp_path / "x.bvh")


@pytest.mark.data("opensense")
def test_opensense_table_imports_with_segments(shared_data, tmp_path):
    table = shared_data / "body" / "opensense_example" / "test_resources" / "MT_012005D6_009-quaternions_calibration_trial_Facing_X.sto"
    out = tmp_path / "table.h5"
    assert main(["import", str(table), "--out", str(out)]) == 0
    from mimucap.session.recorded.review import load_review

    data = load_review(out)
    segments = {sid: s.segment for sid, s in data.session.sensors.items()}
    assert segments["femur_r_imu"] == "thigh_r" and segments["calcn_l_imu"] == "foot_l"
    assert segments["torso_imu"] == "thorax" and data.model.name == "fifteen_segment"
    # The shank's long axis (sensor axes, no calibration) points about vertically in standing.
    assert len(data.t_s) > 10


@pytest.mark.data("mvnx")
def test_export_applies_the_calibration_given(sample, tmp_path):
    """``mimucap export --calibration`` replaces the stored body calibration: a forearm calibration
    turned by 20° about the flexion axis moves the elbow's flexion by 20°."""
    from mimucap.core.bodycal import BodyCalibration
    from mimucap.io.angles_export import read_angles_csv
    from mimucap.io.body_calibration_file import write_body_calibration
    from mimucap.io.recording_import import import_recording

    session = import_recording(sample, tmp_path / "imported.h5")
    calibration = BodyCalibration.from_dict(session.calibrations["body"])
    turn = rot.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.radians(20.0))
    turned = dict(calibration.q_segment_from_sensor)
    turned["forearm_r"] = rot.multiply(turn, turned["forearm_r"])
    write_body_calibration(tmp_path / "cal.json", BodyCalibration(
        calibration.q_world_from_body, calibration.up_world, calibration.sensors, turned, calibration.quality))
    stored, given = tmp_path / "stored.csv", tmp_path / "given.csv"
    assert main(["export", str(tmp_path / "imported.h5"), "--out", str(stored)]) == 0
    assert main(["export", str(tmp_path / "imported.h5"), "--calibration", str(tmp_path / "cal.json"),
                 "--out", str(given)]) == 0
    shift = read_angles_csv(given).angles_deg["elbow_r_flexion_deg"] - read_angles_csv(stored).angles_deg["elbow_r_flexion_deg"]
    assert np.abs(np.abs(shift) - 20.0).max() < 1.0


@pytest.mark.data("mvnx")
def test_a_file_without_sensor_data_stands_its_segments_for_sensors(sample, tmp_path):
    text = sample.read_text(encoding="utf-8")
    for tag in ("sensorFreeAcceleration", "sensorMagneticField", "sensorOrientation"):
        text = re.sub(rf"\s*<{tag}>.*?</{tag}>", "", text)
    path = tmp_path / "segments_only.mvnx"
    path.write_text(text, encoding="utf-8")
    recording = mvnx.read_mvnx(path)
    assert not recording.q_global_from_sensor
    session = mvnx.session_from_mvnx(recording)
    assert session.sensors["RightForeArm"].segment == "forearm_r" and session.sensors["Pelvis"].acc is None
    from mimucap.io.session import write_session
    from mimucap.session.recorded.review import load_review

    data = load_review(write_session(tmp_path / "s.h5", session))
    model = skeleton.load_model("fifteen_segment")
    ours = per_joint(model, mvnx.anatomical_forearms(data.q_world_from_segment))
    for joint in mvnx.XSENS_JOINTS:
        difference = (ours[joint] - mvnx.xsens_angles_as_ours(recording, joint) + 180.0) % 360.0 - 180.0
        assert np.abs(difference).max() < 0.01, joint
