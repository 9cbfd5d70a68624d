"""Camera presets of the 3D view, in scene coordinates (y up, z towards the default viewer).

A preset is a :class:`CameraPose` (position, focal point and view-up vector, metres, scene
frame) computed from the figure's root position, the subject's height and the view's aspect
ratio, so that a standing figure with its arms spread (a T pose) fits the picture with a
margin. Every preset follows the subject: the view moves the camera with the root along the
floor (:func:`follow_shift`), keeping whatever turn and zoom the user gave it, so a subject
walking away stays framed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

CAMERA_PRESETS = ("front", "side", "top")

#: The camera's vertical view angle (degrees).
VIEW_ANGLE_DEG = 30.0
#: What must fit in the picture, as multiples of the subject's height: the figure's T pose, from
#: one hand's tip to the other, is 1.13 heights wide (a person's arm span is about their height;
#: the figure's hands are drawn straight out).
FIT_WIDTH_HEIGHTS, FIT_HEIGHT_HEIGHTS = 1.15, 1.0
#: Room left around that box, as a fraction of its size on either side.
FIT_MARGIN = 0.12
#: Height of the focal point above the floor, as a fraction of the subject's height.
FOCUS_HEIGHT_RATIO = 0.5
#: Elevation of the front/side cameras above the focal point, as a fraction of the distance.
ELEVATION_RATIO = 0.12


@dataclass(frozen=True)
class CameraPose:
    """A camera placement in the scene frame (metres); ``view_angle_deg`` vertical."""

    position: NDArray[np.float64]
    focal_point: NDArray[np.float64]
    view_up: NDArray[np.float64]
    view_angle_deg: float = VIEW_ANGLE_DEG


def fit_distance(height_m: float, aspect: float) -> float:
    """How far (m) from the focal point the camera stands for a box of
    :data:`FIT_WIDTH_HEIGHTS` × :data:`FIT_HEIGHT_HEIGHTS` subject heights around it, plus
    :data:`FIT_MARGIN`, to fit a picture of ``aspect`` (width / height) with
    :data:`VIEW_ANGLE_DEG`: the larger of what the height and the width need. The box's near
    side is half the box's depth (a body's, small) closer, which the margin covers."""
    if not height_m > 0.0:
        raise ValueError(f"the subject's height must be positive, got {height_m!r} m")
    if not aspect > 0.0:
        raise ValueError(f"the view's aspect ratio must be positive, got {aspect!r}")
    half_tan = math.tan(math.radians(VIEW_ANGLE_DEG) / 2.0)
    half_height = 0.5 * FIT_HEIGHT_HEIGHTS * height_m * (1.0 + FIT_MARGIN)
    half_width = 0.5 * FIT_WIDTH_HEIGHTS * height_m * (1.0 + FIT_MARGIN)
    return max(half_height / half_tan, half_width / (half_tan * aspect))


def camera_preset(name: str, root_scene_m: ArrayLike, height_m: float, aspect: float = 1.0) -> CameraPose:
    """The camera for preset ``name`` looking at a figure whose root is at ``root_scene_m``,
    in a view of ``aspect`` (width / height).

    ``front`` looks along scene -z (towards world north) at the figure; ``side`` looks along
    scene -x (from the east); ``top`` looks straight down with scene -z (north) up on screen.
    """
    if name not in CAMERA_PRESETS:
        raise ValueError(f"camera preset must be one of {CAMERA_PRESETS}, got {name!r}")
    root = np.asarray(root_scene_m, dtype=float)
    focus = np.array([root[0], FOCUS_HEIGHT_RATIO * height_m, root[2]])
    distance = fit_distance(height_m, aspect)
    lift = ELEVATION_RATIO * distance
    up = np.array([0.0, 1.0, 0.0])
    if name == "front":
        position = focus + np.array([0.0, lift, distance])
    elif name == "side":
        position = focus + np.array([distance, lift, 0.0])
    else:
        # From above the figure is seen head first: its top is half a height nearer.
        position = focus + np.array([0.0, distance + 0.5 * height_m, 0.0])
        up = np.array([0.0, 0.0, -1.0])
    return CameraPose(position=position, focal_point=focus, view_up=up)


def follow_shift(previous_root_scene_m: ArrayLike, root_scene_m: ArrayLike) -> NDArray[np.float64]:
    """How far (scene frame, metres, ``(3,)``) a following camera moves when the root goes
    from ``previous_root_scene_m`` to ``root_scene_m``: along the floor only (scene x and z),
    so the figure's bobbing up and down does not shake the view."""
    shift = np.asarray(root_scene_m, dtype=float) - np.asarray(previous_root_scene_m, dtype=float)
    shift[1] = 0.0
    return shift
