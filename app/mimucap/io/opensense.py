"""OpenSim / OpenSense files: IMU orientation tables (``.sto``) and OpenSim coordinate names.

OpenSense (Al Borno et al., "OpenSense: An open-source toolbox for inertial-measurement-unit-based
measurement of lower extremity kinematics over long durations", J. NeuroEng. Rehabil. 19:22, 2022)
reads an orientation table with one column per IMU, named ``<body>_imu`` after the OpenSim body
it sits on, each cell a quaternion ``w,x,y,z`` = ``q_world_from_sensor`` in the IMU vendor's world
frame (z up for Xsens and for MimuCap's ENU world). Its ``IMUPlacer`` turns that world into
OpenSim's ground (y up) with ``sensor_to_opensim_rotations = (-pi/2, 0, 0)``: space-fixed XYZ
angles, here a -90° turn about x, which takes ENU up (z) to ground y and ENU north (y) to ground
-z. With ``base_imu_label = pelvis_imu`` and ``base_heading_axis = x`` it then turns the data about
the vertical so that the pelvis IMU's x axis points along ground x (the model's forward), and
takes each IMU's orientation relative to its body from the first row (the subject standing in
the model's default pose).

**Virtual sensors (the default export).** Each column is a segment's orientation
``q_world_from_segment`` from the pipeline (body calibration applied): x anterior, y along the
segment (superior), z to the right, world ENU. In OpenSim's ground after the rotation above and
the heading correction, a segment frame in the N-pose is ground's own frame (x forward, y up,
z right), which is how the bodies of OpenSim's full-body models (e.g. Rajagopal et al. 2015,
"Full-Body Musculoskeletal Model for Muscle-Driven Simulation of Human Gait") are oriented in
their default pose. So ``IMUPlacer`` with the settings above and ``IMUInverseKinematicsTool``
run on it unchanged. ``IMUPlacer`` calibrates on a table's first row, which in a whole recording
is seldom the subject standing still in the N-pose; the export therefore writes beside each table
a calibration table (``<stem>_calibration.sto``, :data:`CALIBRATION_SUFFIX`): one row, the N-pose
the body calibration measured, as the same sensors, and the table's header says to calibrate on
it. **Raw sensors (an option)** export each segment's sensor orientation
``q_world_from_sensor`` instead: OpenSense then finds the sensor-to-body rotations itself, and the
base heading axis is whichever sensor axis points forward on the pelvis.

Segment → OpenSim body (:data:`OPENSIM_BODIES`, bodies of the Rajagopal 2015 and gait2392-style
models): pelvis → ``pelvis``, thorax → ``torso``, upper_arm → ``humerus``, forearm → ``radius``,
hand → ``hand``, thigh → ``femur``, shank → ``tibia``, foot → ``calcn`` (with ``_l``/``_r``). The
head has no body of its own in those models (it is part of ``torso``) and is left out.

OpenSim coordinates (:data:`OPENSIM_COORDINATES`) name our joint-angle columns as the Rajagopal
model's coordinates, with the model's signs: ``hip_flexion_r`` = hip flexion,
``hip_adduction_r`` = adduction, ``hip_rotation_r`` = internal rotation, ``knee_angle_r`` = knee
flexion (positive bending; Rajagopal's range is 0..120°), ``ankle_angle_r`` = dorsiflexion,
``lumbar_extension`` = −(lumbar flexion), ``lumbar_bending`` = lateral bending, ``lumbar_rotation``
= axial rotation, ``arm_flex_r``/``arm_add_r``/``arm_rot_r`` = shoulder Z-X'-Y'' flexion,
adduction, internal rotation, ``elbow_flex_r`` = elbow flexion, ``pro_sup_r`` = forearm axial
rotation, ``wrist_flex_r``/``wrist_dev_r`` = wrist flexion and deviation. The numbers are ours
(ISB Z-X'-Y'' of our segment frames); OpenSim's joints have other axes and centres, so an
OpenSim coordinate computed by OpenSim's own inverse kinematics differs by a few degrees.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

#: Our segment → the OpenSim body its IMU column is named after (``<body>_imu``).
OPENSIM_BODIES: dict[str, str] = {
    "pelvis": "pelvis",
    "thorax": "torso",
    "upper_arm_l": "humerus_l", "upper_arm_r": "humerus_r",
    "forearm_l": "radius_l", "forearm_r": "radius_r",
    "hand_l": "hand_l", "hand_r": "hand_r",
    "thigh_l": "femur_l", "thigh_r": "femur_r",
    "shank_l": "tibia_l", "shank_r": "tibia_r",
    "foot_l": "calcn_l", "foot_r": "calcn_r",
}

#: Segments without an OpenSim body of their own, and why.
UNMAPPED_SEGMENTS = {"head": "OpenSim's full-body models carry the head on the torso body"}

#: OpenSense's settings for a table written by :func:`write_orientation_sto` (virtual sensors).
SENSOR_TO_OPENSIM_ROTATIONS = (-np.pi / 2, 0.0, 0.0)
BASE_IMU_LABEL = "pelvis_imu"
BASE_HEADING_AXIS = "x"

#: OpenSim coordinate → (our joint-angle column, factor): ``coordinate = factor · column``.
OPENSIM_COORDINATES: dict[str, tuple[str, float]] = {
    "lumbar_extension": ("lumbar_flexion_deg", -1.0),
    "lumbar_bending": ("lumbar_adduction_deg", 1.0),
    "lumbar_rotation": ("lumbar_rotation_deg", 1.0),
}
for _side in ("r", "l"):
    OPENSIM_COORDINATES.update({
        f"hip_flexion_{_side}": (f"hip_{_side}_flexion_deg", 1.0),
        f"hip_adduction_{_side}": (f"hip_{_side}_adduction_deg", 1.0),
        f"hip_rotation_{_side}": (f"hip_{_side}_rotation_deg", 1.0),
        f"knee_angle_{_side}": (f"knee_{_side}_flexion_deg", 1.0),
        f"ankle_angle_{_side}": (f"ankle_{_side}_flexion_deg", 1.0),
        f"arm_flex_{_side}": (f"shoulder_{_side}_flexion_deg", 1.0),
        f"arm_add_{_side}": (f"shoulder_{_side}_adduction_deg", 1.0),
        f"arm_rot_{_side}": (f"shoulder_{_side}_rotation_deg", 1.0),
        f"elbow_flex_{_side}": (f"elbow_{_side}_flexion_deg", 1.0),
        f"pro_sup_{_side}": (f"elbow_{_side}_rotation_deg", 1.0),
        f"wrist_flex_{_side}": (f"wrist_{_side}_flexion_deg", 1.0),
        f"wrist_dev_{_side}": (f"wrist_{_side}_adduction_deg", 1.0),
    })
del _side


def imu_label(segment: str) -> str:
    """The OpenSense column of ``segment``'s IMU (``thigh_r`` → ``femur_r_imu``)."""
    if segment in UNMAPPED_SEGMENTS:
        raise ValueError(f"segment {segment!r} has no OpenSim body: {UNMAPPED_SEGMENTS[segment]}")
    if segment not in OPENSIM_BODIES:
        raise ValueError(f"segment {segment!r} has no OpenSim body (known: {', '.join(OPENSIM_BODIES)})")
    return OPENSIM_BODIES[segment] + "_imu"


def segment_of_label(label: str) -> str | None:
    """The segment an OpenSense column ``<body>_imu`` belongs to, or ``None`` for another name."""
    for segment, body in OPENSIM_BODIES.items():
        if label == body + "_imu":
            return segment
    return None


def opensim_coordinates(angles_deg: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Joint-angle columns (deg) renamed as OpenSim coordinates with OpenSim's signs
    (:data:`OPENSIM_COORDINATES`); columns without an OpenSim coordinate are left out."""
    result = {}
    for coordinate, (column, factor) in OPENSIM_COORDINATES.items():
        if column in angles_deg:
            result[coordinate] = factor * np.asarray(angles_deg[column], dtype=np.float64)
    return result


def virtual_sensor_table(q_world_from_segment: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``<body>_imu`` → ``q_world_from_segment`` (T, 4) for every segment with an OpenSim body
    (the default export: virtual sensors aligned with the segments, world ENU)."""
    table = {imu_label(s): np.asarray(q, dtype=np.float64) for s, q in q_world_from_segment.items()
             if s in OPENSIM_BODIES}
    if not table:
        raise ValueError(f"no segment with an OpenSim body among {', '.join(q_world_from_segment) or 'none'}")
    return table


def raw_sensor_table(
    t_s: np.ndarray,
    sensor_of_segment: Mapping[str, str],
    sensor_t_s: Mapping[str, np.ndarray],
    q_world_from_sensor: Mapping[str, np.ndarray],
) -> dict[str, np.ndarray]:
    """``<body>_imu`` → the segment's sensor orientation ``q_world_from_sensor`` (world ENU)
    picked on the pose grid ``t_s`` (T,) s (latest sample at or before each time).

    ``sensor_of_segment`` maps segments to sensor ids; ``sensor_t_s`` and ``q_world_from_sensor``
    give each sensor's sample times (N,) and orientations (N, 4)."""
    t = np.asarray(t_s, dtype=np.float64)
    table = {}
    for segment, sensor in sensor_of_segment.items():
        if segment not in OPENSIM_BODIES or sensor not in q_world_from_sensor:
            continue
        times = np.asarray(sensor_t_s[sensor], dtype=np.float64)
        index = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 1)
        table[imu_label(segment)] = np.asarray(q_world_from_sensor[sensor], dtype=np.float64)[index]
    if not table:
        raise ValueError("no sensor sits on a segment with an OpenSim body")
    return table


def write_orientation_sto(
    path: str | Path,
    t_s: np.ndarray,
    q_by_label: Mapping[str, np.ndarray],
    notes: Sequence[str] = (),
) -> Path:
    """Write an OpenSense orientation table (``DataType=Quaternion``, ``version=3``).

    ``t_s`` (T,) s strictly increasing; ``q_by_label`` column → (T, 4) ``q_world_from_sensor``
    (w, x, y, z, world ENU). ``notes`` become header lines ``mimucap_note_<k>=...`` (OpenSim
    keeps ``key=value`` header lines as metadata). Rows with a non-finite quaternion are
    refused (OpenSense would fail on them without naming the sensor).
    """
    t = np.asarray(t_s, dtype=np.float64)
    if t.ndim != 1 or t.size == 0 or np.any(~np.isfinite(t)) or np.any(np.diff(t) <= 0.0):
        raise ValueError(f"{path}: orientation table needs a non-empty, strictly increasing time axis")
    labels = list(q_by_label)
    if not labels:
        raise ValueError(f"{path}: no IMU columns to write")
    stacked = []
    for label in labels:
        if any(c in label for c in "\t,\n ="):
            raise ValueError(f"{path}: IMU column {label!r} holds a tab, comma, blank or '='")
        q = np.asarray(q_by_label[label], dtype=np.float64)
        if q.shape != (t.size, 4):
            raise ValueError(f"{path}: IMU {label}: quaternions of shape {q.shape}, expected ({t.size}, 4)")
        bad = ~np.all(np.isfinite(q), axis=1)
        if np.any(bad):
            raise ValueError(f"{path}: IMU {label}: non-finite quaternion at row {int(np.argmax(bad))}")
        norm = np.linalg.norm(q, axis=1, keepdims=True)
        if np.any(norm < 1e-9):
            raise ValueError(f"{path}: IMU {label}: zero quaternion at row {int(np.argmin(norm))}")
        stacked.append(q / norm)
    rate = 1.0 / float(np.median(np.diff(t))) if t.size > 1 else 0.0
    path = Path(path)
    with path.open("w", encoding="utf-8", newline="") as handle:
        handle.write(f"DataRate={rate:.6f}\nDataType=Quaternion\nversion=3\nOpenSimVersion=4.6\n")
        for k, note in enumerate(notes):
            handle.write(f"mimucap_note_{k}={' '.join(str(note).split()).replace('=', ':')}\n")
        handle.write("endheader\n")
        handle.write("\t".join(["time"] + labels) + "\n")
        for i, time in enumerate(t):
            cells = [",".join(f"{v:.10f}" for v in q[i]) for q in stacked]
            handle.write(f"{time:.6f}\t" + "\t".join(cells) + "\n")
    return path


#: ``<table stem>`` + this: the calibration table written beside an orientation table.
CALIBRATION_SUFFIX = "_calibration.sto"
#: The first header note of a calibration table.
CALIBRATION_TABLE_NOTE = ("calibration pose for IMUPlacer: the N-pose the body calibration measured (every "
                          "virtual sensor as its segment stood then), one row; the motion is in {table}")
#: The first header note of a table without a calibration table (no body calibration).
NO_CALIBRATION_TABLE_NOTE = ("no body calibration: no calibration table; IMUPlacer calibrates on this table's "
                             "first row, which must then be the subject standing in the model's default pose")


def placer_note(calibration_table: str) -> str:
    """The first header note of an orientation table written with its calibration table."""
    return (f"IMUPlacer: calibrate on {calibration_table} (the body calibration's N-pose), not on this table's "
            "first row (it need not be a standing pose); then IMU inverse kinematics on this table")


#: Header notes every virtual-sensor table carries (how to run OpenSense on it).
VIRTUAL_SENSOR_NOTES = (
    "virtual sensors aligned with MimuCap segments (x anterior, y along the segment, z right), world ENU",
    "IMUPlacer: base_imu_label pelvis_imu, base_heading_axis x, sensor_to_opensim_rotations -pi/2 0 0",
)
RAW_SENSOR_NOTES = (
    "raw sensor orientations q_world_from_sensor (sensor axes as printed on the board), world ENU",
    "IMUPlacer: sensor_to_opensim_rotations -pi/2 0 0; base_heading_axis: the pelvis sensor's forward axis",
)


def session_from_sto(path: str | Path):
    """A :class:`mimucap.io.session.Session` of an OpenSense orientation table: one sensor's
    samples per column (``q_world_from_sensor`` as the table holds it; OpenSense readers keep the vendor's
    z-up world, read as ENU), assigned to our segment when named ``<body>_imu``; no body
    calibration, no raw channels."""
    from mimucap.io.quaternion_tables import read_opensim_sto
    from mimucap.core.samples import SensorSamples
    from mimucap.io.session import Session

    table = read_opensim_sto(path)
    sensors = {}
    for label, q in table.q_world_from_sensor.items():
        sensors[label] = SensorSamples.checked(label, table.t_s - table.t_s[0], np.arange(len(table.t_s)),
                                               q_world_from_sensor=q, segment=segment_of_label(label))
    segments = [s.segment for s in sensors.values() if s.segment]
    metadata = {
        "source": {"kind": "opensense-sto", "file": Path(path).name, "start_s": float(table.t_s[0])},
        "skeleton_model": "fifteen_segment" if any(s.startswith(("hand", "foot")) for s in segments) else "ten_segment",
        "sensor_segments": {label: s.segment for label, s in sensors.items()},
        "devices": {label: {"device_id": None, "missing": "an OpenSense table names its sensors by body, not by device"}
                    for label in sensors},
    }
    return Session(metadata=metadata, sensors=sensors)
