"""C3D export of the pipeline's motion: joint angles, segment orientations, joint centres, events.

C3D (Motion Lab Systems, "The C3D File Format User Guide") is the file of clinical gait
laboratories: Vicon Nexus, Visual3D, Mokka, OpenSim's C3D adapter and the ``ezc3d``/``c3d``
Python libraries open it. It is written with ``ezc3d`` (Michaud & Begon, "ezc3d: An easy C3D file
I/O cross-platform solution for C++, Python and MATLAB", JOSS 6(58):2911, 2021), the library that
OpenSim itself uses to read C3D.

What a file holds, on a uniform frame grid (:mod:`mimucap.io.motion_grid`; ``POINT:RATE`` Hz,
the first frame at the first pose, ``TRIAL:ACTUAL_START_FIELD = 1``):

* **Joint angles** as points in the clinical convention of Plug-in Gait-style files, listed in
  ``POINT:ANGLES`` with ``POINT:ANGLE_UNITS = deg``: ``LHipAngles``, ``RHipAngles``,
  ``LKneeAngles``, ``RKneeAngles``, ``LAnkleAngles``, ``RAnkleAngles``, ``LShoulderAngles``,
  ``RShoulderAngles``, ``LElbowAngles``, ``RElbowAngles``, ``LWristAngles``, ``RWristAngles``,
  ``SpineAngles`` (our lumbar joint, pelvis → thorax) and ``NeckAngles``: X = flexion (+),
  Y = adduction (+), Z = internal rotation (+), degrees; our ISB Z-X'-Y'' angles with the left
  side mirrored (:data:`mimucap.core.skeleton.JOINT_ANGLE_SIGNS_DOC`), so a joint's X, Y and Z are
  its ``_flexion_deg``, ``_adduction_deg`` and ``_rotation_deg`` columns.
* **Segment orientations** as points ``<Segment>Orientation`` (``PelvisOrientation``,
  ``ThighROrientation`` ...), listed in ``POINT:ORIENTATIONS``: the rotation vector (axis × angle,
  degrees) of ``q_world_from_segment``, world ENU (x east, y north, z up); segment frames x anterior,
  y along the segment, z right.
* **Joint centres** as ordinary points in millimetres, world ENU (z up), from forward kinematics
  of the skeleton model scaled to the subject's height: ``LHipJC``, ``LKneeJC`` ... and
  ``PelvisOrigin`` (the root's proximal point), ``<Segment>End`` at the distal end of every
  segment without a child. Where the pipeline knows no root translation the pelvis stays put.
* **Subject**: ``SUBJECTS:NAMES`` and ``PROCESSING:Height`` (mm); ``MANUFACTURER:SOFTWARE``.
* **What the result holds** in the group ``MIMUCAP`` (:data:`PROVENANCE_GROUP`): ``RESULT`` (as
  seen live or reprocessed), ``BODY_CALIBRATION``, ``MAGNETOMETER`` (one string per sensor),
  ``SKELETON_MODEL``, ``SOFTWARE``, ``SOURCE_FILE``.
* **Events** in the ``EVENT`` group: the recording's markers (context ``General``, label the
  marker's text) and any gait events given as ``(t_s, context, label)``, e.g.
  ``(3.21, "Left", "Foot Strike")``; ``EVENT:TIMES`` are seconds from the first frame (C3D's
  minutes row is 0, seconds may exceed 60 as the format allows).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from mimucap.core import rotation, skeleton
from mimucap.io.motion_grid import sample_orientations, sample_series, uniform_grid

#: Joint kind → clinical point label stem (``L``/``R`` prefixed for sided joints).
CLINICAL_JOINTS = {
    "hip": "HipAngles", "knee": "KneeAngles", "ankle": "AnkleAngles", "shoulder": "ShoulderAngles",
    "elbow": "ElbowAngles", "wrist": "WristAngles", "lumbar": "SpineAngles", "neck": "NeckAngles",
}
_AXES = ("flexion", "adduction", "rotation")
#: The parameter group saying what the result holds (result, calibrations, model, software, source).
PROVENANCE_GROUP = "MIMUCAP"


def _camel(name: str) -> str:
    """``thigh_r`` → ``ThighR``."""
    return "".join(part.capitalize() for part in name.split("_"))


def angle_label(joint: skeleton.Joint) -> str:
    """Clinical C3D label of a joint's angles (``knee_l`` → ``LKneeAngles``)."""
    stem = CLINICAL_JOINTS.get(joint.kind, _camel(joint.kind) + "Angles")
    return (joint.side.upper() + stem) if joint.side else stem


def joint_centre_label(joint: skeleton.Joint) -> str:
    """Point label of a joint's centre (``knee_l`` → ``LKneeJC``, ``lumbar`` → ``LumbarJC``)."""
    stem = _camel(joint.kind) + "JC"
    return (joint.side.upper() + stem) if joint.side else stem


def write_c3d(
    path: str | Path,
    model: skeleton.SkeletonModel,
    height_m: float,
    t_s: np.ndarray,
    q_world_from_segment: Mapping[str, np.ndarray],
    angles_deg: Mapping[str, np.ndarray],
    root_position_m: np.ndarray | None = None,
    markers: Sequence[tuple[float, str]] = (),
    events: Sequence[tuple[float, str, str]] = (),
    subject: str = "",
    provenance: Mapping[str, Sequence[str]] | None = None,
) -> Path:
    """Write a C3D file (contents in the module doc).

    ``t_s`` (T,) s the pose times; ``q_world_from_segment`` segment → (T, 4) (world ENU, w first),
    every segment of ``model``; ``angles_deg`` column → (T,) (``<joint>_<axis>_deg``); a joint's
    angles are written when its three Z-X'-Y'' columns are there; ``root_position_m`` (T, 3) or
    ``None``; ``markers`` ``(t_s, label)``; ``events`` ``(t_s, context, label)``; ``provenance``
    parameter name → strings, what the result holds (group ``MIMUCAP``). Returns the path.
    """
    import ezc3d

    path = Path(path)
    if path.suffix.lower() != ".c3d":
        raise ValueError(f"{path}: a C3D file must end in .c3d")
    t = np.asarray(t_s, dtype=np.float64)
    missing = [s for s in model.segment_names if s not in q_world_from_segment]
    if missing:
        raise ValueError(f"{path}: no orientation for segment(s) {', '.join(missing)}")
    frames_t, rate = uniform_grid(t)
    q = np.stack([sample_orientations(t, q_world_from_segment[s], frames_t) for s in model.segment_names])
    root = None if root_position_m is None else sample_series(t, root_position_m, frames_t)
    proximal, distal = skeleton.forward_kinematics_stacked(model, q, height_m, root)

    labels: list[str] = []
    values: list[np.ndarray] = []          # each (F, 3)
    angle_labels: list[str] = []
    for joint in model.joints:
        columns = [f"{joint.name}_{axis}_deg" for axis in _AXES]
        if all(c in angles_deg for c in columns):
            label = angle_label(joint)
            labels.append(label)
            angle_labels.append(label)
            values.append(np.column_stack([np.interp(frames_t, t, np.asarray(angles_deg[c], dtype=np.float64))
                                           for c in columns]))
    orientation_labels = []
    for i, segment in enumerate(model.segment_names):
        label = _camel(segment) + "Orientation"
        labels.append(label)
        orientation_labels.append(label)
        values.append(np.degrees(rotation.to_rotvec(q[i])))
    index = {name: i for i, name in enumerate(model.segment_names)}
    labels.append("PelvisOrigin" if model.root == "pelvis" else _camel(model.root) + "Origin")
    values.append(proximal[0] * 1000.0)
    for joint in model.joints:
        labels.append(joint_centre_label(joint))
        values.append(proximal[index[joint.distal]] * 1000.0)
    parents = {s.parent for s in model.segments}
    for segment in model.segment_names:
        if segment not in parents:
            labels.append(_camel(segment) + "End")
            values.append(distal[index[segment]] * 1000.0)

    n_frames = len(frames_t)
    points = np.ones((4, len(labels), n_frames))
    points[:3] = np.stack(values, axis=1).transpose(2, 1, 0)
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = np.array([rate])
    c3d["parameters"]["POINT"]["LABELS"]["value"] = labels
    c3d["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    descriptions = []
    for label in labels:
        if label in angle_labels:
            descriptions.append("deg X flexion Y adduction Z internal rotation (ISB ZXY, left mirrored)")
        elif label in orientation_labels:
            descriptions.append("deg rotation vector of q_world_from_segment, world ENU")
        else:
            descriptions.append("mm position, world ENU (z up)")
    c3d["parameters"]["POINT"]["DESCRIPTIONS"]["value"] = descriptions
    c3d["data"]["points"] = points
    c3d.add_parameter("POINT", "ANGLES", angle_labels or [""])
    c3d.add_parameter("POINT", "ANGLE_UNITS", ["deg"])
    c3d.add_parameter("POINT", "ORIENTATIONS", orientation_labels)
    c3d.add_parameter("POINT", "ORIENTATION_UNITS", ["deg"])
    c3d.add_parameter("POINT", "X_SCREEN", ["+X"])
    c3d.add_parameter("POINT", "Y_SCREEN", ["+Z"])
    c3d.add_parameter("SUBJECTS", "NAMES", [subject or "subject"])
    c3d.add_parameter("SUBJECTS", "USES_PREFIXES", 0)
    c3d.add_parameter("PROCESSING", "Height", float(height_m) * 1000.0)
    c3d.add_parameter("MANUFACTURER", "COMPANY", ["MimuCap"])
    c3d.add_parameter("MANUFACTURER", "SOFTWARE", ["MimuCap joint angles from magnetic-inertial sensors"])
    for name, texts in (provenance or {}).items():
        c3d.add_parameter(PROVENANCE_GROUP, name, [str(text) for text in texts] or [""])
    start = float(frames_t[0])
    for time, label in markers:
        if frames_t[0] - 1e-9 <= time <= frames_t[-1] + 1e-9:
            c3d.add_event([0, float(time) - start], "General", str(label), "MimuCap marker")
    for time, context, label in events:
        if context not in ("Left", "Right", "General"):
            raise ValueError(f"{path}: event {label!r} at {time:.3f} s: context must be Left, Right or General")
        if frames_t[0] - 1e-9 <= time <= frames_t[-1] + 1e-9:
            c3d.add_event([0, float(time) - start], context, str(label), "gait event")
    c3d.write(str(path))
    return path
