"""Run OpenSense's IMUPlacer and IMUInverseKinematicsTool on an orientation table, as a user
would with the settings MimuCap's .sto export names (run in a subprocess by the tests: OpenSim's
native library stays out of the test process).

Usage: python opensense_runner.py MODEL.osim TABLE.sto OUT_DIR [CALIBRATION.sto]
IMUPlacer calibrates on CALIBRATION.sto (the export's ``<stem>_calibration.sto``) when given,
else on TABLE.sto's first row; IMU inverse kinematics runs on TABLE.sto.
Writes OUT_DIR/calibrated.osim and OUT_DIR/ik_<table>.mot (OpenSim coordinates, degrees).
"""

import math
import sys
from pathlib import Path

import opensim as osim

model_path, table_path, out_dir = sys.argv[1:4]
calibration_path = sys.argv[4] if len(sys.argv) > 4 else table_path
out = Path(out_dir)
out.mkdir(parents=True, exist_ok=True)
osim.Logger.setLevelString("error")
rotations = osim.Vec3(-math.pi / 2, 0, 0)
placer = osim.IMUPlacer()
placer.set_model_file(model_path)
placer.set_orientation_file_for_calibration(calibration_path)
placer.set_sensor_to_opensim_rotations(rotations)
placer.set_base_imu_label("pelvis_imu")
placer.set_base_heading_axis("x")
placer.run(False)
calibrated = str(out / "calibrated.osim")
placer.getCalibratedModel().printToXML(calibrated)
table = osim.TimeSeriesTableQuaternion(table_path)
times = table.getIndependentColumn()
ik = osim.IMUInverseKinematicsTool()
ik.set_model_file(calibrated)
ik.set_orientations_file(table_path)
ik.set_sensor_to_opensim_rotations(rotations)
ik.set_results_directory(str(out))
ik.set_time_range(0, times[0])
ik.set_time_range(1, times[-1])
ik.run(False)
