"""Camera presets of the 3D view, in scene coordinates (y up, z towards the default viewer).

A preset is a :class:`CameraPose` (position, focal point and view-up vector, metres, scene
frame) computed from the figure's root position and the subject's height, so the whole
figure fits the view. ``"follow"`` starts as the front view and then moves with the root
(:func:`follow_shift`), keeping whatever turn and zoom the user gave it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

CAMERA_PRESETS = ("front", "side", "top", "follow")

#: Distance from the figure, as a multiple of the subject's height.
DISTANCE_HEIGHTS = 2.4
#: Height of the focal point above the floor, as a fraction of the subject's height.
FOCUS_HEIGHT_RATIO = 0.5
#: Elevation of the front/side cameras above the focal point, as a fraction of the distance.
ELEVATION_RATIO = 0.12


@dataclass(frozen=True)
class CameraPose:
    """A camera placement in the scene frame (metres)."""

    position: NDArray[np.float64]
    focal_point: NDArray[np.float64]
    view_up: NDArray[np.float64]


def camera_preset(name: str, root_scene_m: ArrayLike, height_m: float) -> CameraPose:
    """The camera for preset ``name`` looking at a figure whose root is at ``root_scene_m``.

    ``front`` looks along scene -z (towards world north) at the figure; ``side`` looks along
    scene -x (from the east); ``top`` looks straight down with scene -z (north) up on screen;
    ``follow`` is ``front`` centred on the current root (callers re-apply it every frame).
    """
    if name not in CAMERA_PRESETS:
        raise ValueError(f"camera preset must be one of {CAMERA_PRESETS}, got {name!r}")
    root = np.asarray(root_scene_m, dtype=float)
    focus = np.array([root[0], FOCUS_HEIGHT_RATIO * height_m, root[2]])
    distance = DISTANCE_HEIGHTS * height_m
    lift = ELEVATION_RATIO * distance
    up = np.array([0.0, 1.0, 0.0])
    if name in ("front", "follow"):
        position = focus + np.array([0.0, lift, distance])
    elif name == "side":
        position = focus + np.array([distance, lift, 0.0])
    else:
        position = focus + np.array([0.0, distance, 0.0])
        up = np.array([0.0, 0.0, -1.0])
    return CameraPose(position=position, focal_point=focus, view_up=up)


def follow_shift(previous_root_scene_m: ArrayLike, root_scene_m: ArrayLike) -> NDArray[np.float64]:
    """How far (scene frame, metres, ``(3,)``) a following camera moves when the root goes
    from ``previous_root_scene_m`` to ``root_scene_m``: along the floor only (scene x and z),
    so the figure's bobbing up and down does not shake the view."""
    shift = np.asarray(root_scene_m, dtype=float) - np.asarray(previous_root_scene_m, dtype=float)
    shift[1] = 0.0
    return shift
