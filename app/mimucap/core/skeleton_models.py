"""The built-in skeleton models as data: ten segments (the product card's skeleton) and
fifteen (the same ten plus head, hands and feet).

Each model is a ``mimucap-skeleton`` document (format version 1) that
:func:`mimucap.core.skeleton.model_from_dict` turns into a :class:`SkeletonModel`; the same
format, stored as JSON, is how a user supplies a model of their own
(:mod:`mimucap.io.skeleton_model_file`). Kept here as constants, not files, so that ``core``
reads nothing from disk. Ratios are fractions of body height H; :data:`FRAMES` says how to
read them and :data:`ANTHROPOMETRY_SOURCE` where the numbers come from.
"""

from __future__ import annotations

FRAMES = (
    "Segment frames are ISB-like: x anterior, y superior (long axis), z to the right; in the "
    "N-pose every segment frame equals the body frame. attach_ratio: position of the segment's "
    "proximal joint in its parent's frame, as a fraction of body height, measured from the "
    "parent's proximal joint; direction: unit vector in the segment frame from the proximal "
    "joint to the distal end; length_ratio and radius_ratio: fractions of body height."
)

ANTHROPOMETRY_SOURCE = (
    "Segment length ratios of body height H after Drillis & Contini (1966) as tabulated by "
    "Winter, Biomechanics and Motor Control of Human Movement (4th ed., 2009, fig. 4.1): hip "
    "(greater trochanter) 0.530 H, knee 0.285 H, ankle 0.039 H, shoulder 0.818 H, upper arm "
    "0.186 H, forearm 0.146 H, hand 0.108 H, foot length 0.152 H, shoulder width 0.259 H, hip "
    "width 0.191 H. The trunk from hip to shoulder level (0.288 H) is split into a "
    "lumbar/pelvis part (0.100 H) and a thoracic part (0.188 H); head and neck take the "
    "remaining 0.182 H."
)

DOWN = [0, -1, 0]
UP = [0, 1, 0]
#: Foot length (heel to toe) as a fraction of body height (:data:`ANTHROPOMETRY_SOURCE`).
FOOT_LENGTH_RATIO = 0.152


def _segment(name, parent, joint, side, length_ratio, attach_ratio, direction, radius_ratio) -> dict:
    return {"name": name, "parent": parent, "joint": joint, "side": side, "length_ratio": length_ratio,
            "attach_ratio": attach_ratio, "direction": direction, "radius_ratio": radius_ratio}


#: Pelvis, thorax, arms, thighs and shanks (the ten-segment model, in this order).
TEN_SEGMENTS = [
    _segment("pelvis", None, None, None, 0.1, [0, 0, 0], UP, 0.06),
    _segment("thorax", "pelvis", "lumbar", None, 0.188, [0, 0.1, 0], UP, 0.07),
    _segment("upper_arm_l", "thorax", "shoulder_l", "l", 0.186, [0, 0.18, -0.11], DOWN, 0.026),
    _segment("forearm_l", "upper_arm_l", "elbow_l", "l", 0.146, [0, -0.186, 0], DOWN, 0.021),
    _segment("upper_arm_r", "thorax", "shoulder_r", "r", 0.186, [0, 0.18, 0.11], DOWN, 0.026),
    _segment("forearm_r", "upper_arm_r", "elbow_r", "r", 0.146, [0, -0.186, 0], DOWN, 0.021),
    _segment("thigh_l", "pelvis", "hip_l", "l", 0.245, [0, 0, -0.052], DOWN, 0.037),
    _segment("shank_l", "thigh_l", "knee_l", "l", 0.246, [0, -0.245, 0], DOWN, 0.029),
    _segment("thigh_r", "pelvis", "hip_r", "r", 0.245, [0, 0, 0.052], DOWN, 0.037),
    _segment("shank_r", "thigh_r", "knee_r", "r", 0.246, [0, -0.245, 0], DOWN, 0.029),
]

#: What the fifteen-segment model adds to the ten (feet point forward and down).
HEAD_HANDS_FEET = [
    _segment("head", "thorax", "neck", None, 0.182, [0, 0.188, 0], UP, 0.05),
    _segment("hand_l", "forearm_l", "wrist_l", "l", 0.108, [0, -0.146, 0], DOWN, 0.017),
    _segment("hand_r", "forearm_r", "wrist_r", "r", 0.108, [0, -0.146, 0], DOWN, 0.017),
    _segment("foot_l", "shank_l", "ankle_l", "l", 0.117, [0, -0.246, 0], [0.94, -0.34, 0], 0.022),
    _segment("foot_r", "shank_r", "ankle_r", "r", 0.117, [0, -0.246, 0], [0.94, -0.34, 0], 0.022),
]


def _document(name: str, description: str, segments: list[dict]) -> dict:
    return {"format": "mimucap-skeleton", "format_version": 1, "name": name, "description": description,
            "frames": FRAMES, "anthropometry_source": ANTHROPOMETRY_SOURCE, "root_height_ratio": 0.53,
            "segments": segments}


BUILT_IN_MODELS: dict[str, dict] = {
    "ten_segment": _document(
        "ten_segment",
        "The ten segments of Podoprosvetov et al., \"Calibration algorithm for MIMU sensors group\": pelvis (lumbar), thorax (upper spine and shoulder girdle), upper "
        "arms, forearms, thighs, shanks; spherical joints.",
        TEN_SEGMENTS),
    "fifteen_segment": _document(
        "fifteen_segment", "The ten-segment model plus head, hands and feet.", TEN_SEGMENTS + HEAD_HANDS_FEET),
}

#: Names of the built-in models (``ten_segment``, ``fifteen_segment``).
MODEL_NAMES = tuple(BUILT_IN_MODELS)
#: Euler sequences the shoulder's joint angles can be given in (kept here, with the model
#: names, so that the command line lists both without importing numpy).
SHOULDER_SEQUENCES = ("zxy", "xzy", "yxy")
