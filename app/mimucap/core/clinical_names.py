"""The names a person reads: segments, the sensors worn on them, joints and joint-angle columns.

Programs and files keep the machine names (``thigh_r``, ``knee_r_flexion_deg``, see
:func:`mimucap.core.skeleton.joint_angle_columns`); every label shown on screen or written as
a readable header comes from this one table:

* segment ``upper_arm_l`` → "Left upper arm"; the sensor worn on it → "Left upper arm sensor";
* joint ``knee_r`` → "Right knee";
* column ``knee_r_flexion_deg`` → "Right knee flexion (°)", and its sign in words
  ("+ flexion / − extension").

The axis meanings are the table "Clinical name of every axis" of ``docs/conventions.md``
(ISB joint coordinate systems: Wu et al., "ISB recommendation on definitions of joint coordinate
systems of various joints for the reporting of human joint motion", parts I (2002) and II
(2005); Grood & Suntay, "A joint coordinate system for the clinical description of
three-dimensional motions: application to the knee", 1983): about z flexion/extension
(dorsiflexion at the ankle); about the floating x ab/adduction, which is varus/valgus at the
knee, the carrying angle at the elbow, ulnar/radial deviation at the wrist, inversion/eversion
at the ankle and lateral bending for the spine and the neck; about y internal/external
rotation, which is pronation/supination at the elbow and axial rotation for the wrist, the
spine and the neck. The shoulder's X-Z'-Y'' and Y-X'-Y'' sequences name their own axes
(:data:`mimucap.core.skeleton.JOINT_ANGLE_SIGNS_DOC`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: Segments without a side, by machine name.
_MIDLINE_SEGMENTS = {"pelvis": "Pelvis", "thorax": "Thorax", "head": "Head"}
#: Sided segments by machine name without the ``_l``/``_r`` suffix.
_SIDED_SEGMENTS = {"upper_arm": "upper arm", "forearm": "forearm", "hand": "hand", "thigh": "thigh",
                   "shank": "shank", "foot": "foot"}
#: Joints without a side.
_MIDLINE_JOINTS = {"lumbar": "Lumbar spine", "neck": "Neck"}
#: Sided joints, without the suffix.
_SIDED_JOINTS = {"shoulder": "shoulder", "elbow": "elbow", "wrist": "wrist", "hip": "hip", "knee": "knee",
                 "ankle": "ankle"}
_SIDES = {"l": "Left", "r": "Right"}


@dataclass(frozen=True)
class AxisMeaning:
    """What one joint-angle axis means: ``name`` (the positive direction, e.g. "flexion"),
    ``negative`` (the opposite movement, e.g. "extension"; "" for an angle without one)."""

    name: str
    negative: str
    #: A few words for a plot legend and a label ("varus/valgus"); the name itself when empty.
    short: str = ""

    def sign_text(self) -> str:
        """"+ flexion / − extension", or the name alone for an angle without a negative side."""
        return f"+ {self.name} / − {self.negative}" if self.negative else self.name


#: (joint kind, axis in the column name) → meaning; kind "*" applies to every joint not listed.
_AXES = {
    ("*", "flexion"): AxisMeaning("flexion", "extension"),
    ("*", "adduction"): AxisMeaning("adduction", "abduction"),
    ("*", "rotation"): AxisMeaning("internal rotation", "external rotation"),
    ("knee", "adduction"): AxisMeaning("varus", "valgus", "varus/valgus"),
    ("elbow", "adduction"): AxisMeaning("varus", "valgus", "carrying angle"),
    ("elbow", "rotation"): AxisMeaning("pronation", "supination", "pronation/supination"),
    ("wrist", "adduction"): AxisMeaning("ulnar deviation", "radial deviation", "ulnar/radial deviation"),
    ("wrist", "rotation"): AxisMeaning("axial rotation (towards pronation)", "", "axial rotation"),
    ("ankle", "flexion"): AxisMeaning("dorsiflexion", "plantarflexion"),
    ("ankle", "adduction"): AxisMeaning("inversion", "eversion", "inversion/eversion"),
    ("lumbar", "adduction"): AxisMeaning("lateral bending right", "lateral bending left", "lateral bending"),
    ("lumbar", "rotation"): AxisMeaning("axial rotation left", "axial rotation right", "axial rotation"),
    ("neck", "adduction"): AxisMeaning("lateral bending right", "lateral bending left", "lateral bending"),
    ("neck", "rotation"): AxisMeaning("axial rotation left", "axial rotation right", "axial rotation"),
    ("shoulder", "plane_of_elevation"): AxisMeaning("plane of elevation (0° abduction, 90° forward flexion)", "",
                                                    "plane of elevation"),
    ("shoulder", "elevation"): AxisMeaning("elevation", ""),
}
#: Axis names as they end a column (longest first: ``plane_of_elevation`` before ``elevation``).
_AXIS_NAMES = ("plane_of_elevation", "elevation", "adduction", "flexion", "rotation")


def _split_side(name: str) -> tuple[str, str | None]:
    base, sep, side = name.rpartition("_")
    if sep and side in _SIDES:
        return base, side
    return name, None


def segment_name(segment: str) -> str:
    """"Left upper arm" for ``upper_arm_l``; an unknown name is shown spelled out
    (``"lower_back"`` → "Lower back"), never refused: a model read from a file may add one."""
    if segment in _MIDLINE_SEGMENTS:
        return _MIDLINE_SEGMENTS[segment]
    base, side = _split_side(segment)
    if side is not None and base in _SIDED_SEGMENTS:
        return f"{_SIDES[side]} {_SIDED_SEGMENTS[base]}"
    return _spelled(segment)


def sensor_name(segment: str | None, sensor_id: str | None = None) -> str:
    """The sensor worn on ``segment``: "Pelvis sensor"; with ``sensor_id``, "Pelvis sensor (3)";
    a sensor on no segment: "Sensor 3"."""
    if segment is None:
        return f"Sensor {sensor_id}" if sensor_id is not None else "Sensor"
    name = f"{segment_name(segment)} sensor"
    return f"{name} ({sensor_id})" if sensor_id is not None else name


def joint_name(joint: str) -> str:
    """"Right knee" for ``knee_r``, "Lumbar spine" for ``lumbar``."""
    if joint in _MIDLINE_JOINTS:
        return _MIDLINE_JOINTS[joint]
    base, side = _split_side(joint)
    if side is not None and base in _SIDED_JOINTS:
        return f"{_SIDES[side]} {_SIDED_JOINTS[base]}"
    return _spelled(joint)


def split_angle_column(column: str) -> tuple[str, str]:
    """``knee_r_flexion_deg`` → ``("knee_r", "flexion")``; ``ValueError`` for a name that is
    not ``<joint>_<axis>_deg`` with a known axis."""
    if column.endswith("_deg"):
        stem = column[: -len("_deg")]
        for axis in _AXIS_NAMES:
            if stem.endswith("_" + axis) and len(stem) > len(axis) + 1:
                return stem[: -len(axis) - 1], axis
    raise ValueError(f"{column!r} is not a joint-angle column <joint>_<axis>_deg "
                     f"(axis one of {', '.join(_AXIS_NAMES)})")


def axis_meaning(joint: str, axis: str) -> AxisMeaning:
    """The meaning of ``axis`` (as in the column name) of ``joint`` (``knee_r``, ``lumbar``…)."""
    kind, _side = _split_side(joint)
    meaning = _AXES.get((kind, axis)) or _AXES.get(("*", axis))
    if meaning is None:
        return AxisMeaning(axis.replace("_", " "), "")
    return meaning


def axis_short_name(joint: str, axis: str) -> str:
    """The axis meaning in a few words, for a plot legend ("flexion", "lateral bending")."""
    meaning = axis_meaning(joint, axis)
    return meaning.short or meaning.name


def angle_name(column: str) -> str:
    """"Right knee varus/valgus" for ``knee_r_adduction_deg`` (no unit); another column that is
    not a joint angle is spelled out (``pelvis_tilt`` → "Pelvis tilt")."""
    try:
        joint, axis = split_angle_column(column)
    except ValueError:
        return _spelled(column)
    return f"{joint_name(joint)} {axis_short_name(joint, axis)}"


def angle_label(column: str) -> str:
    """"Right knee flexion (°)" for ``knee_r_flexion_deg``; "Time (s)" for ``t_s``; another
    column that is not a joint angle is spelled out (``pelvis_tilt`` → "Pelvis tilt")."""
    if column == "t_s":
        return "Time (s)"
    try:
        split_angle_column(column)
    except ValueError:
        return _spelled(column)
    return f"{angle_name(column)} (°)"


def angle_sign_text(column: str) -> str:
    """The sign of ``column`` in words: "+ flexion / − extension" ("" if not a joint angle)."""
    try:
        joint, axis = split_angle_column(column)
    except ValueError:
        return ""
    return axis_meaning(joint, axis).sign_text()


_SIDED_TOKEN = re.compile(r"\b(" + "|".join(sorted({*_SIDED_SEGMENTS, *_SIDED_JOINTS}, key=len, reverse=True))
                          + r")_([lr])\b")


def in_clinical_words(text: str) -> str:
    """``text`` (a message written for files and the command line) with the sided machine names
    of segments and joints in words: "no sensor on upper_arm_r" → "no sensor on right upper arm"."""
    def words(match: re.Match) -> str:
        name = f"{match.group(1)}_{match.group(2)}"
        readable = segment_name(name) if match.group(1) in _SIDED_SEGMENTS else joint_name(name)
        return readable[:1].lower() + readable[1:]
    return _SIDED_TOKEN.sub(words, text)


def _spelled(name: str) -> str:
    text = name.replace("_", " ").strip()
    return text[:1].upper() + text[1:]
