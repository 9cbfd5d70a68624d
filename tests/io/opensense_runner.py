"""Run OpenSense's IMUPlacer and IMUInverseKinematicsTool on an orientation table, as a user
would with the settings MimuCap's .sto export names (run in a subprocess by the tests: OpenSim's
native library stays out of the test process).

Usage: python opensense_runner.py MODEL.osim TABLE.sto OUT_DIR [CALIBRATION.sto]
[--heading-axis AXIS] [--range T0 T1]
IMUPlacer calibrates on CALIBRATION.sto (the export's ``<stem>_calibration.sto``) when given,
else on TABLE.sto's first row, with ``base_imu_label = pelvis_imu`` and ``base_heading_axis``
AXIS (default ``x``: the export's virtual sensors; ``z`` for the OpenSense example's raw Xsens
sensors, as its ``myIMUPlacer_Setup.xml``); IMU inverse kinematics runs on TABLE.sto, over
T0..T1 s (default: the whole table).
Writes OUT_DIR/calibrated.osim and OUT_DIR/ik_<table>.mot (OpenSim coordinates, degrees).
"""

import argparse
import math
from pathlib import Path

import opensim as osim

parser = argparse.ArgumentParser()
parser.add_argument("model")
parser.add_argument("table")
parser.add_argument("out_dir")
parser.add_argument("calibration", nargs="?", default=None)
parser.add_argument("--heading-axis", default="x")
parser.add_argument("--range", nargs=2, type=float, default=None)
args = parser.parse_args()
out = Path(args.out_dir)
out.mkdir(parents=True, exist_ok=True)
osim.Logger.setLevelString("error")
rotations = osim.Vec3(-math.pi / 2, 0, 0)
placer = osim.IMUPlacer()
placer.set_model_file(args.model)
placer.set_orientation_file_for_calibration(args.calibration or args.table)
placer.set_sensor_to_opensim_rotations(rotations)
placer.set_base_imu_label("pelvis_imu")
placer.set_base_heading_axis(args.heading_axis)
placer.run(False)
calibrated = str(out / "calibrated.osim")
placer.getCalibratedModel().printToXML(calibrated)
table = osim.TimeSeriesTableQuaternion(args.table)
times = table.getIndependentColumn()
start, stop = args.range if args.range else (times[0], times[-1])
ik = osim.IMUInverseKinematicsTool()
ik.set_model_file(calibrated)
ik.set_orientations_file(args.table)
ik.set_sensor_to_opensim_rotations(rotations)
ik.set_results_directory(str(out))
ik.set_time_range(0, start)
ik.set_time_range(1, stop)
ik.run(False)
