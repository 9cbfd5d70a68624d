"""Where the 3D view puts things in its picture (used by the scene tests): VTK's projection of
scene points to display pixels for many points at once, and the world axes' names on screen."""

from __future__ import annotations

import numpy as np
from vtkmodules.vtkRenderingCore import vtkRenderer


def world_to_display(renderer: vtkRenderer, points: np.ndarray) -> np.ndarray:
    """What ``renderer.WorldToDisplay()`` gives for each of ``points`` ``(n, 3)`` (scene frame,
    metres), in one product: ``(n, 3)`` display x, y (pixels from the window's bottom left)
    and depth (0 at the near plane, 1 at the far one; outside that range the point is not
    drawn). VTK's own call makes three Python round trips per point."""
    window = renderer.GetRenderWindow()
    width, height = window.GetSize()
    camera = renderer.GetActiveCamera()
    composite = camera.GetCompositeProjectionTransformMatrix(renderer.GetTiledAspectRatio(), 0.0, 1.0)
    matrix = np.asarray(composite.GetData()).reshape(4, 4)  # row-major
    view = np.c_[points, np.ones(len(points))] @ matrix.T
    view = view[:, :3] / view[:, 3:]
    left, bottom, right, top = renderer.GetViewport()
    display = np.empty_like(view)
    display[:, 0] = (view[:, 0] + 1.0) * (width * (right - left)) / 2.0 + width * left
    display[:, 1] = (view[:, 1] + 1.0) * (height * (top - bottom)) / 2.0 + height * bottom
    display[:, 2] = view[:, 2]
    return display


def axis_label_positions(view) -> dict[str, tuple[float, float]]:
    """Where the world axes' names of a :class:`~mimucap.gui.scene.view.SceneView` stand in its
    picture: name → (x, y) device pixels from the top left; none while the axes are hidden, nor
    those behind the camera or outside the picture."""
    labels = [label for label in view.stage.axis_labels if label.GetVisibility()]
    if not labels:
        return {}
    points = np.array([label.GetPositionCoordinate().GetValue() for label in labels])
    width, height = view.render_window.GetSize()
    shown = {}
    for label, (x, y, depth) in zip(labels, world_to_display(view.renderer, points).tolist()):
        if 0.0 < depth < 1.0 and 0.0 <= x < width and 0.0 <= y < height:
            shown[label.GetInput()] = (x, height - y)
    return shown
