"""Motion files for other programs, each checked by an independent reader, never by our writer's
twin: OpenSense orientation tables by OpenSim 4.6 itself (placer and IMU inverse kinematics), C3D
by the ``c3d`` package (the writer is ``ezc3d``), BVH by ``bvhio``'s own forward kinematics.

The motion comes through the pipeline (``mimucap export`` → ``load_review``) from a simulated
walk; accuracy is judged against the simulator's ground truth (``session.truth``), with
tolerances a real sensor pipeline meets. Tests marked so depend on the pipeline's accuracy.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from mimucap.cli import main
from mimucap.core import rotation as rot
from mimucap.core import skeleton
from mimucap.io import opensense
from mimucap.io.angles_export import read_angles_mot
from mimucap.session.recorded.export import write_motion_file
from mimucap.session.recorded.review import load_review

HERE = Path(__file__).resolve().parent


def rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(a))))


@pytest.fixture(scope="module")
def walk(tmp_path_factory, record_calibrated) -> Path:
    """A calibrated 6-s recording of the simulated fifteen-segment suit (17 sensors, default
    sensor errors): the subject stands in N-pose for the first second, then walks; markers
    'N-pose' at 0 s and 'walk' at 1 s."""
    path = tmp_path_factory.mktemp("walk") / "walk.h5"
    return record_calibrated(path, seconds=6.0, seed=4, n_sensors=17, settle_s=0.0,
                                     markers=((0.0, "N-pose"), (1.0, "walk")))


@pytest.fixture(scope="module")
def review(walk):
    return load_review(walk)


def truth_on(t_s: np.ndarray, review, column: str) -> np.ndarray:
    truth = review.session.truth
    return np.interp(t_s, truth.t_s, truth.joint_angles_deg[column])


def truth_segment_on(t_s: np.ndarray, review, segment: str) -> np.ndarray:
    truth = review.session.truth
    index = np.clip(np.searchsorted(truth.t_s, t_s - 1e-9), 0, len(truth.t_s) - 1)
    return truth.q_world_from_segment[segment][index]


# --------------------------------------------------------------------------------------------
# OpenSense
# --------------------------------------------------------------------------------------------

@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("opensim") is None,
                    reason="opensim (OpenSim 4.6, test extra) is not installed: pip install opensim")
@pytest.mark.data("opensense")
def test_opensense_placer_and_ik_follow_the_walk(walk, review, shared_data, tmp_path, capsys):
    table = tmp_path / "walk.sto"
    # The N-pose second (IMUPlacer's calibration frame) and three seconds of walking.
    assert main(["export", str(walk), "--format", "sto", "--to", "4.0", "--out", str(table)]) == 0
    model = shared_data / "body" / "opensense_example" / "Rajagopal_2015.osim"
    run = subprocess.run([sys.executable, str(HERE / "opensense_runner.py"), str(model), str(table), str(tmp_path / "ik")],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    ik = read_angles_mot(tmp_path / "ik" / "ik_walk.mot")
    assert ik.t_s[0] < 0.05 and ik.t_s[-1] > 3.95  # every row was solved
    figures = {}
    for ours, theirs in (("knee_r_flexion_deg", "knee_angle_r"), ("knee_l_flexion_deg", "knee_angle_l"),
                         ("hip_r_flexion_deg", "hip_flexion_r"), ("hip_l_flexion_deg", "hip_flexion_l")):
        truth = truth_on(ik.t_s, review, ours)
        assert np.ptp(truth) > 15.0  # the joint really moved
        figures[theirs] = rms(ik.angles_deg[theirs] - truth)
    with capsys.disabled():
        print(f"\nOpenSense IK vs simulator truth over {ik.t_s[-1]:.2f} s, RMS deg: "
              + ", ".join(f"{k} {v:.2f}" for k, v in figures.items()))
    # OpenSim's knee and hip are other joints than ours (a knee with a moving centre, other axes).
    assert max(figures.values()) < 8.0, figures


def test_sto_columns_are_opensim_bodies_and_raw_sensors_carry_the_mounting(walk, review, tmp_path):
    virtual, raw = tmp_path / "virtual.sto", tmp_path / "raw.sto"
    assert main(["export", str(walk), "--out", str(virtual)]) == 0
    assert main(["export", str(walk), "--format", "sto", "--raw-sensors", "--out", str(raw)]) == 0
    from mimucap.io.orientation_tables import read_opensim_sto

    v, r = read_opensim_sto(virtual), read_opensim_sto(raw)
    segments = review.model.segment_names
    assert set(v.sensor_ids) == {opensense.imu_label(s) for s in segments if s in opensense.OPENSIM_BODIES}
    assert {"pelvis_imu", "torso_imu", "femur_r_imu", "tibia_l_imu", "humerus_r_imu", "radius_l_imu"} <= set(v.sensor_ids)
    assert set(r.sensor_ids) >= set(v.sensor_ids)  # every sensor on a segment with an OpenSim body
    header = virtual.read_text().split("endheader")[0]
    assert "DataType=Quaternion" in header and "base_heading_axis x" in header
    assert re.search(r'marker 0\.0\d+ "N-pose"', header), header
    # A raw sensor turned back by its true mounting is its segment. Inclination only: the heading
    # of a sensor fused without a magnetometer calibration is the pipeline's business, not the file's.
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.core.simulate.suit import SuitSimulator

    mounting = SuitSimulator(SimulationConfig(seed=4, n_sensors=17)).mounting  # the walk's true mounting
    for label in ("femur_r_imu", "tibia_l_imu", "torso_imu"):
        segment = opensense.segment_of_label(label)
        sensor = review.body_calibration.sensors[segment]  # the sensor the export used for it
        q_segment = rot.multiply(r.q_world_from_sensor[label], rot.conjugate(mounting[sensor].q_segment_from_sensor))
        up = np.array([0.0, 0.0, 1.0])
        ours = rot.rotate(rot.conjugate(q_segment), up)
        theirs = rot.rotate(rot.conjugate(truth_segment_on(r.t_s, review, segment)), up)
        error = np.degrees(np.arccos(np.clip(np.sum(ours * theirs, axis=1), -1.0, 1.0)))
        assert np.median(error) < 3.0 and np.percentile(error, 95) < 8.0, (label, np.median(error), np.percentile(error, 95))


def test_mot_with_opensim_coordinate_names_has_opensim_signs(walk, review, tmp_path):
    out = tmp_path / "walk.mot"
    assert main(["export", str(walk), "--format", "mot", "--opensim-names", "--out", str(out)]) == 0
    mot = read_angles_mot(out)
    assert {"hip_flexion_r", "knee_angle_r", "knee_angle_l", "lumbar_extension", "arm_flex_r", "elbow_flex_l"} <= set(mot.angles_deg)
    # Rajagopal's knee_angle is positive in flexion (range 0..120 deg), lumbar_extension positive backwards.
    assert rms(mot.angles_deg["knee_angle_r"] - truth_on(mot.t_s, review, "knee_r_flexion_deg")) < 3.0
    assert rms(mot.angles_deg["lumbar_extension"] + truth_on(mot.t_s, review, "lumbar_flexion_deg")) < 3.0
    assert mot.angles_deg["knee_angle_r"].max() > 40.0
    with pytest.raises(ValueError, match="OpenSim coordinate names are for .mot"):
        from mimucap.io.angles_export import write_angles

        write_angles(tmp_path / "x.csv", mot.t_s, {"knee_r_flexion_deg": mot.t_s}, opensim_names=True)


# --------------------------------------------------------------------------------------------
# C3D
# --------------------------------------------------------------------------------------------

def read_c3d(path: Path):
    import c3d

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "no analog data": there is none, as intended
        with path.open("rb") as handle:
            reader = c3d.Reader(handle)
            labels = [label.strip() for label in reader.point_labels]
            frames = np.stack([points[:, :3] for _i, points, _analog in reader.read_frames()])
            group = {name: reader.get(name) for name in ("EVENT", "POINT", "SUBJECTS", "PROCESSING")}
            events = (
                [s.strip() for s in group["EVENT"].get("CONTEXTS").string_array],
                [s.strip() for s in group["EVENT"].get("LABELS").string_array],
                np.asarray(group["EVENT"].get("TIMES").float_array).reshape(-1, 2),
            )
            point = group["POINT"]
            meta = {
                "rate": reader.point_rate, "first_frame": reader.first_frame,
                "angles": [s.strip() for s in point.get("ANGLES").string_array],
                "angle_units": point.get("ANGLE_UNITS").string_array[0].strip(),
                "subject": group["SUBJECTS"].get("NAMES").string_array[0].strip(),
                "height_mm": group["PROCESSING"].get("HEIGHT").float_value,
            }
    return labels, frames, events, meta


def test_c3d_read_by_the_other_library(review, tmp_path):
    pytest.importorskip("c3d", reason="the c3d package (test extra) reads the file back")
    path = tmp_path / "walk.c3d"
    write_motion_file(review, "c3d", path, events=[(2.5, "Left", "Foot Strike"), (3.0, "Right", "Foot Off")])
    labels, frames, (contexts, names, times), meta = read_c3d(path)
    assert meta["rate"] == pytest.approx(100.0) and meta["first_frame"] == 1
    assert meta["angle_units"] == "deg" and meta["subject"] == "simulated"
    assert meta["height_mm"] == pytest.approx(1750.0)
    assert {"LKneeAngles", "RKneeAngles", "LHipAngles", "RHipAngles", "SpineAngles", "RElbowAngles"} <= set(meta["angles"])
    assert frames.shape[0] == len(review.t_s)
    t = review.t_s  # the walk's pose grid is uniform: C3D frames fall on it
    knee = frames[:, labels.index("RKneeAngles")]
    # X flexion, Y adduction, Z rotation (clinical convention) against the simulator's truth.
    assert rms(knee[:, 0] - truth_on(t, review, "knee_r_flexion_deg")) < 3.0
    hip = frames[:, labels.index("LHipAngles")]
    assert rms(hip[:, 0] - truth_on(t, review, "hip_l_flexion_deg")) < 3.0
    assert rms(hip[:, 1] - truth_on(t, review, "hip_l_adduction_deg")) < 3.0
    # Orientations: rotation vectors (deg) of q_world_from_segment.
    thigh = rot.from_rotvec(np.radians(frames[:, labels.index("ThighROrientation")]))
    error = np.degrees(rot.angle_between(thigh, truth_segment_on(t, review, "thigh_r")))
    assert np.percentile(error, 95) < 5.0
    # What the other library decodes is what the pipeline handed the writer (C3D stores float32).
    assert np.abs(knee - np.column_stack([review.angles_deg[f"knee_r_{a}_deg"] for a in ("flexion", "adduction", "rotation")])).max() < 1e-3
    decoded = np.degrees(rot.angle_between(thigh, review.q_world_from_segment["thigh_r"]))
    assert decoded.max() < 0.01
    # Joint centres in mm, z up: the knee under the hip, about a thigh length apart.
    hip_jc, knee_jc = frames[0, labels.index("RHipJC")], frames[0, labels.index("RKneeJC")]
    assert np.linalg.norm(hip_jc - knee_jc) == pytest.approx(0.245 * 1750.0, rel=0.01)
    assert hip_jc[2] > knee_jc[2] + 300.0
    # Markers and gait events in the EVENT group, seconds from the first frame.
    assert ("General", "walk") in zip(contexts, names)
    strike = names.index("Foot Strike")
    assert contexts[strike] == "Left" and times[strike, 1] == pytest.approx(2.5 - review.t_s[0], abs=1e-4)
    assert contexts[names.index("Foot Off")] == "Right"


# --------------------------------------------------------------------------------------------
# BVH
# --------------------------------------------------------------------------------------------

def wxyz(q) -> np.ndarray:
    """A glm quaternion (bvhio's) as [w, x, y, z]."""
    return np.array([q.w, q.x, q.y, q.z])


def test_bvh_forward_kinematics_reproduce_the_segments(walk, review, tmp_path):
    bvhio = pytest.importorskip("bvhio", reason="bvhio (test extra) reads the file back")
    from mimucap.io.bvh import CENTIMETRES, R_BVH_FROM_WORLD, segment_from_bvh_global

    path = tmp_path / "walk.bvh"
    assert main(["export", str(walk), "--format", "bvh", "--out", str(path)]) == 0
    text = path.read_text()
    assert "CHANNELS 3 Zrotation Xrotation Yrotation" in text and "Frame Time: 0.010000" in text
    assert (tmp_path / "walk_markers.csv").read_text().count(",General,") == 2
    root = bvhio.readAsHierarchy(str(path))
    root.loadRestPose()
    # bvhio turns each joint so that its bone points along its own y: take that rest turn out.
    rest = {j.Name: wxyz(j.RotationWorld) for j, _i, _d in root.layout()}
    names = set(rest)
    assert names == set(review.model.segment_names)
    frames = range(0, len(review.t_s), 37)
    worst_deg, worst_cm = 0.0, 0.0
    height = review.height_m
    for frame in frames:
        root.loadPose(frame)
        q = {}
        for joint, _index, _depth in root.layout():
            world = wxyz(joint.RotationWorld)
            q[joint.Name] = segment_from_bvh_global(rot.multiply(world, rot.conjugate(rest[joint.Name])))
            ours = review.q_world_from_segment[joint.Name][frame]
            worst_deg = max(worst_deg, float(np.degrees(rot.angle_between(q[joint.Name], ours))))
        root_m = None if review.root_position_m is None else review.root_position_m[frame]
        poses = skeleton.forward_kinematics(review.model, {s: review.q_world_from_segment[s][frame] for s in names},
                                            height, root_m)
        for joint, _index, _depth in root.layout():
            position = np.array(joint.PositionWorld) / CENTIMETRES
            expected = R_BVH_FROM_WORLD @ poses[joint.Name].proximal_m
            worst_cm = max(worst_cm, float(np.linalg.norm(position - expected)) * 100.0)
    assert worst_deg < 0.01, worst_deg
    assert worst_cm < 0.01, worst_cm


def blender_python() -> str | None:
    """A Python with ``bpy``: this one, or the one ``MIMUCAP_BLENDER_PYTHON`` names (bpy 5.0 wants
    numpy < 2, which the project's own environment does not have)."""
    if importlib.util.find_spec("bpy") is not None:
        return sys.executable
    return os.environ.get("MIMUCAP_BLENDER_PYTHON") or None


@pytest.mark.slow
@pytest.mark.skipif(blender_python() is None,
                    reason="no bpy: Blender as a Python module (pip install bpy, Python 3.11, numpy < 2) in a "
                           "separate environment named by MIMUCAP_BLENDER_PYTHON")
def test_blender_imports_the_bvh_where_our_skeleton_is(walk, review, tmp_path):
    path = tmp_path / "walk.bvh"
    assert main(["export", str(walk), "--format", "bvh", "--out", str(path)]) == 0
    frames = [0, 150, 333, 480]
    run = subprocess.run([blender_python(), str(HERE / "blender_bvh_import.py"), str(path), *map(str, frames)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    bones = json.loads(next(line for line in run.stdout.splitlines() if line.startswith("BONES "))[6:])
    worst = 0.0
    for frame in frames:
        root_m = None if review.root_position_m is None else review.root_position_m[frame]
        poses = skeleton.forward_kinematics(review.model, {s: q[frame] for s, q in review.q_world_from_segment.items()},
                                            review.height_m, root_m)
        for name, head in bones[str(frame)].items():
            # Blender's world is z up with y = -BVH z: our ENU world.
            worst = max(worst, float(np.linalg.norm(np.array(head) - poses[name].proximal_m)))
    assert worst < 1e-4, worst


def test_bvh_refuses_a_model_segment_without_orientation(review, tmp_path):
    from mimucap.io.bvh import write_bvh

    partial = {s: q for s, q in review.q_world_from_segment.items() if s != "shank_l"}
    with pytest.raises(ValueError, match="shank_l"):
        write_bvh(tmp_path / "x.bvh", review.model, review.height_m, review.t_s, partial)


# --------------------------------------------------------------------------------------------
# The command
# --------------------------------------------------------------------------------------------

def test_export_command_refuses_unknown_suffix_and_misplaced_options(walk, tmp_path, capsys):
    assert main(["export", str(walk), "--out", str(tmp_path / "x.xyz")]) == 1
    assert "cannot tell the format" in capsys.readouterr().err
    assert main(["export", str(walk), "--format", "c3d", "--opensim-names", "--out", str(tmp_path / "x.c3d")]) == 1
    assert "--opensim-names applies to --format mot" in capsys.readouterr().err
    assert main(["export", str(walk), "--from", "3", "--to", "2", "--out", str(tmp_path / "x.c3d")]) == 1
    assert "export range must have its end after its start, got 3.000..2.000 s" in capsys.readouterr().err
    assert not (tmp_path / "x.c3d").exists()
    before = walk.read_bytes()
    assert main(["export", str(walk), "--format", "csv", "--out", str(walk)]) == 1
    assert "would overwrite the input" in capsys.readouterr().err and walk.read_bytes() == before
    assert main(["import", str(tmp_path / "x.sto"), "--out", str(walk)]) == 1
    assert "exists" in capsys.readouterr().err and walk.read_bytes() == before


def test_writers_refuse_bad_input_naming_what_is_wrong(review, tmp_path):
    from mimucap.io.c3d_export import write_c3d

    t = np.array([0.0, 0.01, 0.02])
    q = np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))
    q[1] = np.nan
    with pytest.raises(ValueError, match="IMU femur_r_imu: non-finite quaternion at row 1"):
        opensense.write_orientation_sto(tmp_path / "x.sto", t, {"pelvis_imu": np.tile([1.0, 0, 0, 0], (3, 1)), "femur_r_imu": q})
    with pytest.raises(ValueError, match="strictly increasing"):
        opensense.write_orientation_sto(tmp_path / "x.sto", t[::-1], {"pelvis_imu": np.tile([1.0, 0, 0, 0], (3, 1))})
    with pytest.raises(ValueError, match="no OpenSim body: OpenSim's full-body models carry the head"):
        opensense.imu_label("head")
    with pytest.raises(ValueError, match="context must be Left, Right or General"):
        write_c3d(tmp_path / "x.c3d", review.model, review.height_m, review.t_s, review.q_world_from_segment,
                  review.angles_deg, events=[(1.0, "left", "Foot Strike")])


# --------------------------------------------------------------------------------------------
# Segment orientations of a session calibrated in the window (issue 31, point 1)
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("fmt", ["c3d", "bvh", "sto"])
def test_exported_segment_headings_of_a_window_calibration_follow_the_truth(walk, review, tmp_path, fmt, capsys):
    """The export of a session whose body calibration was made live (stored in the session),
    read back by another program's reader: every segment's heading within 3° of the simulator's
    in the N-pose (mean) and while walking (RMS), as for the command-line route
    (``tests/cli/test_session_route.py``)."""
    from tests.io.exported_segments import bvh_segments, c3d_segments, heading_figures, sto_segments

    path = tmp_path / f"walk.{fmt}"
    assert main(["export", str(walk), "--format", fmt, "--out", str(path)]) == 0
    t, segments = {"c3d": lambda: c3d_segments(path, review.markers), "bvh": lambda: bvh_segments(path, review.markers),
                   "sto": lambda: sto_segments(path)}[fmt]()
    figures = heading_figures(t, segments, review.truth, still=[(0.1, 0.9)], moving=[(1.5, review.end_s)])
    assert len(figures) >= 14  # every segment (the head has no OpenSense body)
    with capsys.disabled():
        print(f"\nwindow route, {fmt}: worst segment heading error N-pose {max(f[0] for f in figures.values()):.2f}°, "
              f"walking RMS {max(f[1] for f in figures.values()):.2f}°")
    for segment, (npose_deg, walking_deg) in figures.items():
        assert npose_deg < 3.0 and walking_deg < 3.0, (segment, npose_deg, walking_deg)


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("opensim") is None,
                    reason="opensim (OpenSim 4.6, test extra) is not installed: pip install opensim")
@pytest.mark.data("opensense")
def test_opensense_calibrates_on_the_calibration_table_of_a_window_calibration(walk, review, shared_data, tmp_path,
                                                                              capsys):
    """A table of walking alone (it does not begin in the N-pose) and its calibration table:
    OpenSense's knee flexion within 3° RMS of the simulator's."""
    table = tmp_path / "walking.sto"
    assert main(["export", str(walk), "--format", "sto", "--from", "1.5", "--out", str(table)]) == 0
    calibration = tmp_path / "walking_calibration.sto"
    header = table.read_text().split("endheader")[0]
    assert "calibrate on walking_calibration.sto" in header
    model = shared_data / "body" / "opensense_example" / "Rajagopal_2015.osim"
    from tests.io.exported_segments import opensense_knee_errors

    errors = opensense_knee_errors(table, calibration, model, tmp_path / "ik", lambda t, c: truth_on(t, review, c))
    with capsys.disabled():
        print("\nOpenSense IK (calibration table) vs truth while walking, window route, RMS deg: "
              + ", ".join(f"{k} {v:.2f}" for k, v in errors.items()))
    assert max(errors.values()) < 3.0, errors


# --------------------------------------------------------------------------------------------
# Every output says what it holds (issue 31, point 5)
# --------------------------------------------------------------------------------------------

def test_every_file_says_what_it_holds(walk, review, tmp_path):
    """One record (result, body calibration, magnetometer calibrations, skeleton model, software,
    source file) in every file an export and the analysis write: the header lines of the text
    files, the BVH's sidecar, the C3D's parameters (read by the ``c3d`` package)."""
    from mimucap.session.recorded.analysis import analyse_review, write_analysis_csv
    from mimucap.session.recorded.export import ExportRequest, run_export

    record = review.provenance
    assert record.result.startswith("reprocessed")
    # in clinical words: the quality in words, when in local date and time, the model by its size
    assert re.search(r"^N-pose/T-pose, (good|fair|poor), made \d\d [A-Z][a-z]{2} 20\d\d, \d\d:\d\d \(.*made live",
                     record.body_calibration), record.body_calibration
    # a quality and an age per sensor (the wizard's calibrations, made just before recording), and
    # whether it corrected the gyroscope's scale
    assert all(re.search(r"^S\d\d(, S\d\d)* magnetometers?: (good|fair), made within a minute of the recording, "
                         r"gyroscope scale corrected$", text) for text in record.magnetometer), record.magnetometer
    assert sum(text.count("S") for text in record.magnetometer) == 17
    assert record.skeleton_model.startswith("15-segment skeleton, subject height ")
    assert record.software.startswith("MimuCap ") and record.source_file == "walk.h5"
    lines = record.lines()
    exported = run_export(review, ExportRequest(tmp_path / "all", review.start_s, review.end_s, sensors_csv=True,
                                                opensim_mot=True, c3d=True, bvh=True, opensense_sto=True))
    tables = write_analysis_csv(tmp_path / "tables", analyse_review(review))
    names = sorted(p.name for p in exported.files + tables)
    assert {"all_joint_angles.csv", "all_joint_angles.mot", "all_joint_angle_summary.csv", "all_sensor_S01_raw.csv",
            "all_opensim_coordinates.mot", "all_skeleton.bvh", "all_skeleton_markers.csv", "all_motion.c3d",
            "all_orientations.sto", "all_orientations_calibration.sto", "strides.csv", "parameters.csv"} <= set(names)
    for path in exported.files + tables:
        if path.suffix == ".c3d" or path.suffix == ".bvh":
            continue
        text = path.read_text(encoding="utf-8")
        for line in lines:
            assert line in text or line.replace("=", ":") in text, (path.name, line)
    import c3d

    with (tmp_path / "all_motion.c3d").open("rb") as handle:
        group = c3d.Reader(handle).get("MIMUCAP")
        found = {name: [s.strip() for s in group.get(name).string_array] for name in record.parameters()}
    assert found == record.parameters()
