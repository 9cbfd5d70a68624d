"""The functional calibration on the OpenSense example's walk (eight Xsens MTw) against
OpenSense's own IMU inverse kinematics of the same recording, as the OpenSense example runs it.

OpenSense (OpenSim 4.6, in a subprocess): ``IMUPlacer`` on the first row (the subject standing in
the model's default pose), base IMU ``pelvis_imu`` with heading axis ``z`` (the example's
``myIMUPlacer_Setup.xml``), then ``IMUInverseKinematicsTool`` over the example's time range
7.25-15 s (``myIMUIK_Setup.xml``). The table it reads is the Xsens exports as MimuCap's reader
aligns them on their packet counters (OpenSim's own Xsens reader refuses these files: their
lengths differ).

Ours: ``mimucap bodycal IMUData --method functional`` (the first still second and the rest of
the recording, found in the data) → ``mimucap angles``. Definitions: OpenSim's ``hip_flexion``
is the first rotation, about z, of the femur from the pelvis (the Rajagopal hip is Z-X-Y, as
ours), ``knee_angle`` the one coordinate of the Rajagopal knee (its flexion about the femur's z,
with the secondary rotations it drives); both are zero in the calibration pose, standing, and
positive in flexion, as our hip and knee flexion, which are zero standing because the
functional calibration takes every long axis vertical there. No offset is removed.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mimucap.cli import main
from mimucap.io.angles_export import read_angles_csv, read_angles_mot

HERE = Path(__file__).resolve().parent
MAPPING = ("pelvis_imu=pelvis,torso_imu=thorax,femur_r_imu=thigh_r,femur_l_imu=thigh_l,tibia_r_imu=shank_r,"
           "tibia_l_imu=shank_l,calcn_r_imu=foot_r,calcn_l_imu=foot_l")
IK_RANGE_S = (7.25, 15.0)


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("opensim") is None,
                    reason="opensim (OpenSim 4.6, test extra) is not installed: pip install opensim")
@pytest.mark.data("opensense")
def test_hip_and_knee_flexion_follow_opensense_ik(shared_data, tmp_path, capsys):
    from mimucap.io.opensense import write_orientation_sto
    from mimucap.io.orientation_inputs import read_quaternion_table

    folder = shared_data / "body" / "opensense_example"
    names = ["--sensor-names", str(folder / "myIMUMappings.xml")]
    table = read_quaternion_table(folder / "IMUData", sensor_names=folder / "myIMUMappings.xml")
    sto = write_orientation_sto(tmp_path / "walk.sto", table.t_s, table.q_world_from_sensor)
    run = subprocess.run([sys.executable, str(HERE / "opensense_runner.py"), str(folder / "Rajagopal_2015.osim"),
                          str(sto), str(tmp_path / "ik"), "--heading-axis", "z", "--range", *map(str, IK_RANGE_S)],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    ik = read_angles_mot(tmp_path / "ik" / "ik_walk.mot")
    assert ik.t_s[0] == pytest.approx(IK_RANGE_S[0], abs=0.01) and ik.t_s[-1] == pytest.approx(IK_RANGE_S[1], abs=0.01)

    calibration = tmp_path / "CAL.json"
    assert main(["bodycal", str(folder / "IMUData"), *names, "--mapping", MAPPING, "--method", "functional",
                 "--out", str(calibration)]) == 0
    printed = capsys.readouterr().out
    assert "verdict poor" not in printed and "knee_r axis (femur_r_imu, tibia_r_imu)" in printed
    angles = tmp_path / "walk.csv"
    assert main(["angles", str(folder / "IMUData"), *names, "--calibration", str(calibration),
                 "--out", str(angles)]) == 0
    ours = read_angles_csv(angles)
    figures = {}
    for column, theirs in (("knee_r_flexion_deg", "knee_angle_r"), ("knee_l_flexion_deg", "knee_angle_l"),
                           ("hip_r_flexion_deg", "hip_flexion_r"), ("hip_l_flexion_deg", "hip_flexion_l")):
        a = np.interp(ik.t_s, ours.t_s, ours.angles_deg[column])
        b = ik.angles_deg[theirs]
        assert np.ptp(b) > 30.0  # the joint really moved
        figures[theirs] = (float(np.sqrt(np.mean((a - b) ** 2))), float(np.corrcoef(a, b)[0, 1]))
    with capsys.disabled():
        print("\nfunctional calibration vs OpenSense IK, 7.25-15 s: "
              + ", ".join(f"{k} RMS {rms:.2f}° r {r:.4f}" for k, (rms, r) in figures.items()))
    for name, (rms, r) in figures.items():
        assert rms <= 3.0 and r >= 0.98, (name, figures)
