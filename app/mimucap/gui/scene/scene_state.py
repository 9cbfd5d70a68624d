"""What a mirror of the skeleton scene needs to draw the same frame: :class:`SceneState`.

The 3D view keeps its scene (camera, stage, figure) in the GUI process, where the mouse turns
the camera and the tests look at the figure, and may have the pictures drawn by a render
process holding a mirror of that scene (``mimucap.gui.scene.render_process``). Before each
frame the view takes a :class:`SceneState` (:func:`capture_scene`); the mirror applies it
(:func:`apply_scene`) and renders. Frames: scene (metres); colours: RGB bytes; sizes: device
pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from vtkmodules.vtkRenderingCore import vtkRenderer

from mimucap.gui.scene.environment import Stage
from mimucap.gui.scene.skeleton_actor import SkeletonActor


@dataclass(frozen=True)
class FigureLayout:
    """The names that fix a figure's pieces (and so its arrays' shapes): what a
    :class:`SkeletonActor` needs from its ``FigureBuilder``."""

    segment_names: tuple[str, ...]
    connector_names: tuple[str, ...]
    joint_names: tuple[str, ...]

    @classmethod
    def of(cls, builder) -> FigureLayout:
        return cls(tuple(builder.segment_names), tuple(builder.connector_names), tuple(builder.joint_names))


@dataclass(frozen=True)
class SceneState:
    """One frame of the skeleton scene.

    Attributes:
        size_px: ``(width, height)`` of the picture (device pixels).
        camera: position ``(3,)``, focal point ``(3,)``, view-up ``(3,)`` (scene, metres),
            view angle (degrees) and clipping range ``(near, far)`` (metres), flattened to 12
            numbers in that order.
        floor_matrix, axes_matrix: ``(4, 4)`` scene placements of the floor grids and the world
            axes (see ``Stage.placement``).
        floor_visible, axes_visible: whether floor and axes are shown.
        figure: the figure's drawn arrays (``SkeletonActor.drawn_arrays``), ``None`` without
            a figure.
        figure_visible: whether the figure is shown (hidden until its first frame).
    """

    size_px: tuple[int, int]
    camera: tuple[float, ...]
    floor_matrix: np.ndarray
    axes_matrix: np.ndarray
    floor_visible: bool
    axes_visible: bool
    figure: dict[str, np.ndarray] | None
    figure_visible: bool


def capture_scene(renderer: vtkRenderer, stage: Stage, skeleton: SkeletonActor | None) -> SceneState:
    """The state of the scene ``renderer`` shows with ``stage`` and ``skeleton`` (its window's size)."""
    camera = renderer.GetActiveCamera()
    width, height = renderer.GetRenderWindow().GetSize()
    floor, axes, floor_visible, axes_visible = stage.placement()
    return SceneState(
        size_px=(int(width), int(height)),
        camera=(*camera.GetPosition(), *camera.GetFocalPoint(), *camera.GetViewUp(), camera.GetViewAngle(),
                *camera.GetClippingRange()),
        floor_matrix=floor, axes_matrix=axes, floor_visible=floor_visible, axes_visible=axes_visible,
        figure=None if skeleton is None else skeleton.drawn_arrays(),
        figure_visible=skeleton is not None and skeleton.visible,
    )


def apply_scene(state: SceneState, renderer: vtkRenderer, stage: Stage, skeleton: SkeletonActor | None) -> None:
    """Make ``renderer``'s scene (with ``stage`` and ``skeleton``, laid out like the captured
    one's) show ``state``, its window sized to ``state.size_px``; raises ``ValueError`` when the
    state carries a figure of another layout or none is there to take it."""
    if (state.figure is None) != (skeleton is None):
        raise ValueError("the scene state and this scene disagree on whether a figure is shown")
    renderer.GetRenderWindow().SetSize(*state.size_px)
    values = state.camera
    camera = renderer.GetActiveCamera()
    camera.SetPosition(*values[0:3])
    camera.SetFocalPoint(*values[3:6])
    camera.SetViewUp(*values[6:9])
    camera.SetViewAngle(values[9])
    camera.SetClippingRange(*values[10:12])
    stage.set_placement(state.floor_matrix, state.axes_matrix, state.floor_visible, state.axes_visible)
    if skeleton is not None:
        skeleton.draw_arrays(state.figure, state.figure_visible)
