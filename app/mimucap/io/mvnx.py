"""Xsens MVNX files (MVN Analyze/Animate XML export, versions 3 and 4): read, and turn into a
MimuCap session.

An MVNX file (Xsens, "MVN User Manual", section "MVNX file format") holds the subject's segments
(with anatomical points), sensors, joints, ergonomic joints, and one ``frame`` element per sample:
calibration frames first (``type`` ``identity``, ``tpose``, ``tpose-isb``, ``npose``…), then the
recording (``type="normal"``). Each frame lists, segment after segment, ``orientation``
(quaternions w, x, y, z: ``q_global_from_segment``), ``position`` (m), and, sensor after sensor,
``sensorOrientation`` (``q_global_from_sensor``), ``sensorFreeAcceleration`` (m/s², global frame,
gravity removed), ``sensorMagneticField`` (sensor frame, arbitrary units normalised to the local
field), plus Xsens's own joint angles ``jointAngle`` (Euler Z-X-Y, degrees, per joint),
``jointAngleXZY`` and ``jointAngleErgo`` (per ergonomic joint). :func:`read_mvnx` reads all of it
that is present, version 3 or 4, without the file's XML namespace mattering, and streams through
the file (frames are cleared once read, so recordings of hours fit).

Frames:

* Xsens's global frame is z up, x along the heading reference (magnetic north unless a heading
  reset moved it), y to the left (west): NWU. MimuCap's world is ENU:
  ``R_ENU_from_global = [[0,-1,0],[1,0,0],[0,0,1]]``.
* Xsens segment frames (the MVN biomechanical model): x forward, y left, z up, all parallel to the
  global frame in the ``identity`` pose, which stands with the arms stretched out sideways
  (a T-pose). MimuCap segment frames: x anterior, y along the segment (up), z right, all parallel
  in the N-pose (arms down). So ``q_world_from_segment = q_ENU_from_global ⊗ q_global_from_xsens
  ⊗ q_xsens_from_ours``, with ``R_xsens_from_ours = [[1,0,0],[0,0,-1],[0,1,0]]`` followed, for the
  arm segments (upper arm, forearm, hand), by a 90° turn about x that lowers the arm from the
  T-pose to the N-pose (``Rx(-90°)`` right, ``Rx(+90°)`` left): :data:`Q_XSENS_FROM_OURS`.

Segment mapping to MimuCap's fifteen-segment model (:data:`SEGMENT_OF_XSENS`): Pelvis → pelvis,
T8 → thorax, Head → head, Right/LeftUpperArm → upper_arm, ForeArm → forearm, Hand → hand,
UpperLeg → thigh, LowerLeg → shank, Foot → foot. The spine segments L5, L3, T12, the neck, the
shoulder blades and the toes have no MimuCap segment.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mimucap.core import rotation

#: Why an MVNX session's sensors have no device id.
NO_DEVICE_IN_MVNX = "an MVNX file names its sensors by body position, not by device"
#: Xsens segment label → MimuCap segment (fifteen-segment model).
SEGMENT_OF_XSENS: dict[str, str] = {
    "Pelvis": "pelvis", "T8": "thorax", "Head": "head",
    "RightUpperArm": "upper_arm_r", "RightForeArm": "forearm_r", "RightHand": "hand_r",
    "LeftUpperArm": "upper_arm_l", "LeftForeArm": "forearm_l", "LeftHand": "hand_l",
    "RightUpperLeg": "thigh_r", "RightLowerLeg": "shank_r", "RightFoot": "foot_r",
    "LeftUpperLeg": "thigh_l", "LeftLowerLeg": "shank_l", "LeftFoot": "foot_l",
}

R_ENU_FROM_GLOBAL = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
Q_ENU_FROM_GLOBAL = rotation.from_matrix(R_ENU_FROM_GLOBAL)
_R_AXES = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
_Q_AXES = rotation.from_matrix(_R_AXES)
_X = np.array([1.0, 0.0, 0.0])


def _xsens_from_ours(segment: str) -> np.ndarray:
    if segment.startswith(("upper_arm", "forearm", "hand")):
        lower = rotation.from_axis_angle(_X, -math.pi / 2 if segment.endswith("_r") else math.pi / 2)
        return rotation.multiply(_Q_AXES, lower)
    return _Q_AXES


#: MimuCap segment → ``q_xsens_from_ours`` (4,) (see the module doc).
Q_XSENS_FROM_OURS: dict[str, np.ndarray] = {s: _xsens_from_ours(s) for s in SEGMENT_OF_XSENS.values()}

GRAVITY_MPS2 = 9.81


@dataclass(frozen=True)
class MvnxJoint:
    """A joint of the file: ``label`` (e.g. ``jRightKnee``), its parent and child segment labels."""

    label: str
    parent: str
    child: str


@dataclass
class MvnxRecording:
    """What :func:`read_mvnx` found. Arrays run over the ``normal`` frames (F).

    ``t_s`` (F,) s from the first frame; ``q_global_from_segment`` label → (F, 4) and
    ``position_m`` label → (F, 3) (Xsens global frame, NWU); ``q_global_from_sensor`` sensor label
    → (F, 4); ``free_acc_mps2`` (F, 3) global frame, gravity removed; ``mag_au`` (F, 3) sensor
    frame, Xsens arbitrary units; ``joint_angle_deg`` joint label → (F, 3) Xsens's Z-X-Y angles in
    the file's order (x, y, z); ``joint_angle_xzy_deg`` likewise; ``ergo_angle_deg`` ergonomic
    joint label → (F, 3); ``calibration_poses`` pose type → segment label → (4,) orientation;
    ``points_m`` segment label → point label → (3,) position in the segment frame.
    """

    path: Path
    version: int
    frame_rate_hz: float
    configuration: str
    subject_label: str
    segments: tuple[str, ...]
    sensors: tuple[str, ...]
    joints: tuple[MvnxJoint, ...]
    ergo_joints: tuple[MvnxJoint, ...]
    t_s: np.ndarray
    q_global_from_segment: dict[str, np.ndarray]
    position_m: dict[str, np.ndarray]
    q_global_from_sensor: dict[str, np.ndarray] = field(default_factory=dict)
    free_acc_mps2: dict[str, np.ndarray] = field(default_factory=dict)
    mag_au: dict[str, np.ndarray] = field(default_factory=dict)
    joint_angle_deg: dict[str, np.ndarray] = field(default_factory=dict)
    joint_angle_xzy_deg: dict[str, np.ndarray] = field(default_factory=dict)
    ergo_angle_deg: dict[str, np.ndarray] = field(default_factory=dict)
    calibration_poses: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    points_m: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    rec_date: str = ""

    def q_world_from_segment(self) -> dict[str, np.ndarray]:
        """MimuCap segment → ``q_world_from_segment`` (F, 4), world ENU, our segment frames."""
        result = {}
        for label, segment in SEGMENT_OF_XSENS.items():
            if label in self.q_global_from_segment:
                q = rotation.multiply(Q_ENU_FROM_GLOBAL, self.q_global_from_segment[label])
                result[segment] = rotation.multiply(q, Q_XSENS_FROM_OURS[segment])
        return result

    def height_m(self) -> float | None:
        """The subject's height from the model: the top of the head over the lowest foot point
        in the ``identity`` pose (m), or ``None`` when the file lacks those points."""
        pose = self.calibration_poses.get("identity_position")
        head = self.points_m.get("Head", {}).get("pTopOfHead")
        if pose is None or head is None or "Head" not in pose:
            return None
        top = pose["Head"][2] + head[2]
        feet = [pose[s][2] + p[2] for s in ("RightFoot", "LeftFoot", "RightToe", "LeftToe") if s in pose
                for p in self.points_m.get(s, {}).values()]
        bottom = min(feet) if feet else 0.0
        height = float(top - bottom)
        return height if 0.5 < height < 2.5 else None


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _numbers(element: ET.Element, path: Path, what: str, frame: str) -> np.ndarray:
    try:
        return np.array((element.text or "").split(), dtype=np.float64)
    except ValueError:
        raise ValueError(f"{path}: frame {frame}: {what}: not a list of numbers") from None


def _reshape(values: np.ndarray, count: int, width: int, path: Path, what: str, frame: str) -> np.ndarray:
    if values.size != count * width:
        raise ValueError(f"{path}: frame {frame}: {what} has {values.size} numbers, expected {count} × {width}")
    return values.reshape(count, width)


def read_mvnx(path: str | Path) -> MvnxRecording:
    """Read an MVNX file (version 3 or 4; contents in the module doc).

    ``ValueError`` naming the file (and frame) for: not MVNX XML, an unsupported version, no
    segments or no ``normal`` frames, a frame whose value count does not match the segment,
    sensor or joint count, a non-unit quaternion, or a time that does not increase.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    version = None
    rate = 0.0
    configuration = subject_label = rec_date = ""
    segments: list[str] = []
    sensors: list[str] = []
    joints: list[MvnxJoint] = []
    ergo: list[MvnxJoint] = []
    points: dict[str, dict[str, np.ndarray]] = {}
    poses: dict[str, dict[str, np.ndarray]] = {}
    frames: dict[str, list[np.ndarray]] = {}
    times: list[float] = []
    indices: list[float] = []
    current_segment = None
    stack: list[str] = []
    try:
        for event, element in ET.iterparse(path, events=("start", "end")):
            tag = _local(element.tag)
            if event == "start":
                stack.append(tag)
                if tag == "mvnx":
                    try:
                        version = int(float(element.get("version", "")))
                    except ValueError:
                        raise ValueError(f"{path}: mvnx element without a version number") from None
                    if version not in (3, 4):
                        raise ValueError(f"{path}: MVNX version {version} is not supported (3 and 4 are)")
                elif tag == "subject":
                    rate = float(element.get("frameRate", "0") or 0)
                    configuration = element.get("configuration", "")
                    subject_label = element.get("label", "")
                    rec_date = element.get("recDate", "")
                elif tag == "segment" and "segments" in stack[:-1]:
                    current_segment = element.get("label", "")
                    segments.append(current_segment)
                    points[current_segment] = {}
                continue
            stack.pop()
            if tag == "point" and current_segment is not None:
                pos = next((c for c in element if _local(c.tag) == "pos_b"), None)
                if pos is not None:
                    points[current_segment][element.get("label", "")] = _numbers(pos, path, "pos_b", "header")
            elif tag == "segment":
                current_segment = None
            elif tag == "sensor" and "sensors" in stack:
                sensors.append(element.get("label", ""))
            elif tag == "joint" and "joints" in stack:
                parts = {_local(c.tag): (c.text or "").strip() for c in element}
                parent = parts.get("connector1", "").split("/")[0]
                child = parts.get("connector2", "").split("/")[0]
                joints.append(MvnxJoint(element.get("label", ""), parent, child))
            elif tag == "ergonomicJointAngle":
                ergo.append(MvnxJoint(element.get("label", ""), element.get("parentSegment", ""),
                                      element.get("childSegment", "")))
            elif tag == "frame":
                kind = element.get("type", "normal")
                name = element.get("index", kind)
                values = {_local(c.tag): c for c in element}
                if kind == "normal":
                    try:
                        times.append(float(element.get("time", "nan")) / 1000.0)
                        indices.append(float(element.get("index", "nan")))
                    except ValueError:
                        raise ValueError(f"{path}: frame {name}: time is not a number") from None
                    for key, child in values.items():
                        frames.setdefault(key, []).append(_numbers(child, path, key, name))
                elif "orientation" in values:
                    q = _reshape(_numbers(values["orientation"], path, "orientation", kind), len(segments), 4,
                                 path, "orientation", kind)
                    poses[kind] = dict(zip(segments, q))
                    if "position" in values:
                        p = _reshape(_numbers(values["position"], path, "position", kind), len(segments), 3,
                                     path, "position", kind)
                        poses[kind + "_position"] = dict(zip(segments, p))
                element.clear()
    except ET.ParseError as error:
        raise ValueError(f"{path}: not readable XML: {error}") from None
    if version is None:
        raise ValueError(f"{path}: not an MVNX file (no mvnx element)")
    if not segments:
        raise ValueError(f"{path}: no segments in the file")
    if not times:
        raise ValueError(f"{path}: no recorded (normal) frames")
    # ``time`` is rounded to whole milliseconds; the frame index over the rate is exact.
    index = np.array(indices)
    t = (index - index[0]) / rate if rate > 0 and np.all(np.isfinite(index)) else np.array(times)
    if np.any(~np.isfinite(t)) or np.any(np.diff(t) <= 0.0):
        bad = int(np.argmax(np.diff(t) <= 0.0)) + 1 if t.size > 1 else 0
        raise ValueError(f"{path}: frame {bad}: time does not increase")
    t = t - t[0]
    if rate <= 0.0 and t.size > 1:
        rate = 1.0 / float(np.median(np.diff(t))) if t.size > 1 else 0.0

    def table(key: str, labels: list[str], width: int) -> dict[str, np.ndarray]:
        rows = frames.get(key)
        if not rows or not labels:
            return {}
        sizes = {r.size for r in rows}
        if sizes != {len(labels) * width}:
            wrong = next(i for i, r in enumerate(rows) if r.size != len(labels) * width)
            raise ValueError(f"{path}: frame {wrong}: {key} has {rows[wrong].size} numbers, "
                             f"expected {len(labels)} × {width}")
        data = np.stack(rows).reshape(len(rows), len(labels), width)
        return {label: data[:, i] for i, label in enumerate(labels)}

    def quaternions(key: str, labels: list[str]) -> dict[str, np.ndarray]:
        result = table(key, labels, 4)
        for label, q in result.items():
            norm = np.linalg.norm(q, axis=1)
            bad = np.flatnonzero(~np.isfinite(norm) | (np.abs(norm - 1.0) > 0.01))
            if bad.size:
                raise ValueError(f"{path}: frame {int(bad[0])}: {key} of {label} is not a unit quaternion")
            result[label] = q / norm[:, None]
        return result

    segment_q = quaternions("orientation", segments)
    if not segment_q:
        raise ValueError(f"{path}: the frames hold no segment orientations")
    joint_labels = [j.label for j in joints]
    return MvnxRecording(
        path=path, version=version, frame_rate_hz=rate, configuration=configuration,
        subject_label=subject_label, segments=tuple(segments), sensors=tuple(sensors), joints=tuple(joints),
        ergo_joints=tuple(ergo), t_s=t, q_global_from_segment=segment_q,
        position_m=table("position", segments, 3),
        q_global_from_sensor=quaternions("sensorOrientation", sensors),
        free_acc_mps2=table("sensorFreeAcceleration", sensors, 3),
        mag_au=table("sensorMagneticField", sensors, 3),
        joint_angle_deg=table("jointAngle", joint_labels, 3),
        joint_angle_xzy_deg=table("jointAngleXZY", joint_labels, 3),
        ergo_angle_deg=table("jointAngleErgo", [j.label for j in ergo], 3),
        calibration_poses=poses, points_m=points, rec_date=rec_date,
    )


# --------------------------------------------------------------------------------------------
# Xsens's joint angles beside ours
# --------------------------------------------------------------------------------------------

#: MimuCap joint → (Xsens table, label, sign of X): the Xsens angle whose two segments are our
#: joint's two segments. ``jointAngleErgo`` for the lumbar spine (Pelvis → T8), the neck (T8 →
#: Head) and the shoulders (T8 → upper arm): Xsens's ``jointAngle`` splits those across the spine
#: segments and the shoulder blade. Xsens writes each angle as (X, Y, Z) of a Z-X-Y decomposition
#: in ISB-like frames: Z = flexion, X = ab/adduction, Y = axial rotation; for the arm joints its X is
#: positive for abduction, ours for adduction, hence the sign. The legs are left out: the sample
#: file (an upper-body recording) holds no leg motion to check their signs against.
XSENS_JOINTS: dict[str, tuple[str, str, float]] = {
    "lumbar": ("ergo", "Pelvis_T8", 1.0), "neck": ("ergo", "T8_Head", 1.0),
    "shoulder_r": ("ergo", "T8_RightUpperArm", -1.0), "shoulder_l": ("ergo", "T8_LeftUpperArm", -1.0),
    "elbow_r": ("joint", "jRightElbow", -1.0), "elbow_l": ("joint", "jLeftElbow", -1.0),
    "wrist_r": ("joint", "jRightWrist", -1.0), "wrist_l": ("joint", "jLeftWrist", -1.0),
}


#: Xsens's forearm and hand frames are ours turned about the long axis (y) by these angles (rad):
#: Xsens counts the forearm's axial rotation from the anatomical position, palms forward (ISB,
#: Wu et al., "ISB recommendation on definitions of joint coordinate systems ... Part II: shoulder,
#: elbow, wrist and hand", J. Biomech. 38:981, 2005), ours from the N-pose, palms towards the
#: thighs. Turned so, our joint-angle code gives Xsens's elbow and wrist angles to rounding
#: (``bench/bench_mvnx_angles.py``).
ANATOMICAL_TURN_RAD = {"forearm_r": math.pi / 2, "hand_r": math.pi / 2, "forearm_l": -math.pi / 2, "hand_l": -math.pi / 2}


def anatomical_forearms(q_world_from_segment: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``q_world_from_segment`` with the forearm and hand frames turned to Xsens's (palms forward
    at zero, :data:`ANATOMICAL_TURN_RAD`); the other segments unchanged."""
    result = dict(q_world_from_segment)
    for segment, angle in ANATOMICAL_TURN_RAD.items():
        if segment in result:
            result[segment] = rotation.multiply(result[segment], rotation.from_axis_angle(np.array([0.0, 1.0, 0.0]), angle))
    return result


def xsens_angles_as_ours(recording: MvnxRecording, joint: str) -> np.ndarray | None:
    """Xsens's own angles of our ``joint`` as (F, 3) (flexion, adduction, rotation) degrees with our
    signs (:data:`XSENS_JOINTS`), or ``None`` when the file does not hold them."""
    if joint not in XSENS_JOINTS:
        return None
    table, label, x_sign = XSENS_JOINTS[joint]
    source = recording.ergo_angle_deg if table == "ergo" else recording.joint_angle_deg
    if label not in source:
        return None
    xyz = source[label]
    return np.column_stack([xyz[:, 2], x_sign * xyz[:, 0], xyz[:, 1]])


# --------------------------------------------------------------------------------------------
# An MVNX recording as a MimuCap session
# --------------------------------------------------------------------------------------------

def _sensor_segment(label: str) -> str | None:
    return SEGMENT_OF_XSENS.get(label)


def session_from_mvnx(recording: MvnxRecording):
    """A :class:`mimucap.io.session.Session` of ``recording``, reviewed and exported like ours.

    * one sensor stream per Xsens sensor (id = its label): ``q_world_from_sensor`` (ENU) from
      ``sensorOrientation`` (Xsens's fusion, as a sensor that fuses on board sends it; a file
      exported without sensor data gives one stream per mapped segment, aligned with it); ``acc`` the
      specific force in the sensor frame, ``R_sensor_from_global·(free acceleration + g·up)``;
      the magnetic field as the extra channel ``mag_au`` (Xsens units, not µT); no gyroscope (MVNX
      holds none); ``segment`` our segment where the sensor's segment has one;
    * the body calibration Xsens applied, as ours (``calibrations["body"]``): each sensor's
      ``q_segment_from_sensor`` is the mean over the recording of ``q_world_from_segment⁻¹ ⊗
      q_world_from_sensor`` (constant in MVN, which carries each segment on its sensor);
    * metadata: ``skeleton_model`` fifteen_segment, the subject (label, height from the model),
      the file's version, configuration and rate; markers: none (MVNX has none);
    * ``results["xsens"]``: Xsens's own joint angles (``jointAngle``, ``jointAngleXZY``,
      ``jointAngleErgo``, degrees), segment orientations and positions (global frame), the
      calibration poses, for comparison and reports.
    """
    from mimucap.core.bodycal import BodyCalibration, CalibrationQuality
    from mimucap.core.samples import SensorSamples
    from mimucap.io.session import Session, make_subject

    t = recording.t_s
    segments = recording.q_world_from_segment()
    sensors = {}
    mapping: dict[str, str] = {}
    q_seg_from_sensor: dict[str, np.ndarray] = {}
    up = np.array([0.0, 0.0, 1.0])
    sensor_q = recording.q_global_from_sensor
    if not sensor_q:
        # An export without sensor data: each segment Xsens tracked stands for a sensor aligned
        # with it (Xsens's fusion output, as a sensor fusing on board would send it).
        sensor_q = {label: rotation.multiply(recording.q_global_from_segment[label], Q_XSENS_FROM_OURS[segment])
                    for label, segment in SEGMENT_OF_XSENS.items() if label in recording.q_global_from_segment}
    for label, q_global in sensor_q.items():
        q_world = rotation.multiply(Q_ENU_FROM_GLOBAL, q_global)
        acc = None
        if label in recording.free_acc_mps2:
            specific_global = recording.free_acc_mps2[label] + GRAVITY_MPS2 * up
            acc = rotation.rotate(rotation.conjugate(q_global), specific_global)
        extra = {"mag_au": recording.mag_au[label]} if label in recording.mag_au else {}
        segment = _sensor_segment(label)
        sensors[label] = SensorSamples.checked(label, t, np.arange(len(t)), acc=acc, q_world_from_sensor=q_world,
                                               segment=segment, extra=extra)
        if segment is not None and segment in segments:
            mapping[segment] = label
            relative = rotation.multiply(rotation.conjugate(segments[segment]), q_world)
            q_seg_from_sensor[segment] = rotation.average(relative)
    if "pelvis" not in mapping:
        raise ValueError(f"{recording.path}: no sensor on the pelvis: the skeleton has no root to hang on")
    q_world_from_body = rotation.multiply(Q_ENU_FROM_GLOBAL, _Q_AXES)
    quality = CalibrationQuality(method="xsens-mvn", stillness=(), verdict="good",
                                 problems=())
    calibration = BodyCalibration(q_world_from_body, up, mapping, q_seg_from_sensor, quality,
                                  {"origin": f"Xsens MVN calibration imported from {recording.path.name}"})
    height = recording.height_m() or 1.75
    xsens: dict = {
        "joint_angle_deg": dict(recording.joint_angle_deg),
        "joint_angle_xzy_deg": dict(recording.joint_angle_xzy_deg),
        "ergo_angle_deg": dict(recording.ergo_angle_deg),
        "q_global_from_segment": dict(recording.q_global_from_segment),
        "position_m": dict(recording.position_m),
        "t_s": t,
    }
    poses = {kind: {label: np.asarray(v) for label, v in pose.items()}
             for kind, pose in recording.calibration_poses.items()}
    if poses:
        xsens["calibration_poses"] = {kind.replace("-", "_"): pose for kind, pose in poses.items()}
    metadata = {
        "source": {"kind": "mvnx", "file": recording.path.name, "mvnx_version": recording.version,
                   "configuration": recording.configuration, "rate_hz": recording.frame_rate_hz,
                   "recorded": recording.rec_date},
        "subject": make_subject(recording.subject_label, height, "unknown",
                                "height from the Xsens model" if recording.height_m() else "height unknown"),
        "skeleton_model": "fifteen_segment",
        "sensor_segments": {label: s.segment for label, s in sensors.items()},
        # MVNX names its sensors by where they are worn, never by device: say so for each
        "devices": {label: {"device_id": None, "missing": NO_DEVICE_IN_MVNX} for label in sensors},
    }
    return Session(metadata=metadata, sensors=sensors, calibrations={"body": calibration.to_dict()},
                   results={"xsens": xsens})
