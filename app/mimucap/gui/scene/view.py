"""The 3D view widget: one offscreen VTK render window shown in Qt, and a frame clock.

The widget *has* a :class:`~mimucap.gui.vtk_image_widget.VtkImageWidget` (no double
inheritance). Each :meth:`SceneView.tick` asks the frame provider for the newest
:class:`~mimucap.session.figure.FigureGeometry` and renders once, only when something
changed (new frame, tint, camera). Ticks come either from the view's own ``QTimer`` at
:attr:`SceneView.target_fps` (``start()``), or from the owner right after it has taken in new
data (``start(own_clock=False)``; the main window does so, which keeps the time from a
sample's arrival to the screen short). Mouse orbit/zoom is VTK's trackball camera style.
After :meth:`SceneView.shutdown` (called on close) nothing renders again.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable, Mapping

import numpy as np
from PyQt5 import QtCore, QtGui, QtWidgets
from vtkmodules.vtkCommonCore import vtkCommand
from vtkmodules.vtkRenderingCore import vtkRenderer

from mimucap.gui.scene.environment import Stage, scene_renderer
from mimucap.gui.scene.render_client import RenderClient
from mimucap.gui.scene.scene_state import FigureLayout, SceneState, capture_scene
from mimucap.gui.scene.skeleton_actor import SkeletonActor
from mimucap.gui.vtk_image_widget import OverlayLabel, VtkImageWidget
from mimucap.session.camera import CAMERA_PRESETS, camera_preset, follow_shift
from mimucap.session.figure import FigureBuilder, FigureGeometry, plain_world_matrix

log = logging.getLogger(__name__)

#: Environment variable: ``0`` has every 3D view draw in the GUI process instead of a render
#: process (e.g. where starting processes is not allowed).
RENDER_PROCESS_VARIABLE = "MIMUCAP_RENDER_PROCESS"


def render_process_wanted() -> bool:
    """Whether a new 3D view draws in a render process (the default; see
    :data:`RENDER_PROCESS_VARIABLE`)."""
    return os.environ.get(RENDER_PROCESS_VARIABLE, "1").strip() not in ("0", "no", "false", "off")


def drawing_moved_message(reason: str) -> str:
    """What a window's status bar says when its 3D view's render process failed (``reason``)."""
    return (f"The 3D view's render process stopped ({reason}); this window now draws the view itself, "
            "which takes more of the processor. Restart MimuCap to draw it apart again.")


#: How far beyond the focal point the far plane lies (m): the whole floor grid.
CLIPPING_FAR_M = 45.0

#: Called every tick; returns ``(frame_id, geometry)`` for the newest frame or ``None``.
FrameProvider = Callable[[], "tuple[object, FigureGeometry] | None"]


def world_to_display(renderer: vtkRenderer, points: np.ndarray) -> np.ndarray:
    """What ``renderer.WorldToDisplay()`` gives for each of ``points`` ``(n, 3)`` (scene frame,
    metres), in one product: ``(n, 3)`` display x, y (pixels from the window's bottom left)
    and depth (0 at the near plane, 1 at the far one; outside that range the point is not
    drawn). VTK's own call, three Python round trips per point, cost 0.1 ms a frame."""
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


class SceneView(QtWidgets.QWidget):
    """The skeleton's 3D view.

    The pictures are drawn by a render process (:mod:`mimucap.gui.scene.render_process`)
    holding a mirror of this scene, unless ``render_process`` is false (default:
    :func:`render_process_wanted`) or that process fails, in which case the view draws in
    this process and says why in :attr:`render_failure`. Either way the scene (camera,
    stage, figure) lives here.

    Attributes:
        frames_rendered: pictures shown so far.
        shown_frame_id: the frame id (from the frame provider) of the picture on screen.

    Signals:
        frame_rendered(float): emitted when a new picture is shown, with ``time.perf_counter()``.
        drawing_moved_here(str): the render process failed (the reason); the view now draws
            in this process.
    """

    frame_rendered = QtCore.pyqtSignal(float)
    drawing_moved_here = QtCore.pyqtSignal(str)

    def __init__(self, parent: QtWidgets.QWidget | None = None, target_fps: float = 60.0,
                 render_process: bool | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("sceneView")
        self.target_fps = float(target_fps)
        self.vtk_widget = VtkImageWidget(self)
        self.vtk_widget.setObjectName("vtkWidget")
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.vtk_widget)
        self.render_window = self.vtk_widget.render_window
        self.renderer = scene_renderer()
        self.render_window.AddRenderer(self.renderer)
        self.stage = Stage(self.renderer)
        self.vtk_widget.label_provider = self._axis_labels
        # Before every frame, whoever asks for it (the tick, the mouse), light the figure
        # from the camera.
        self.render_window.AddObserver(vtkCommand.StartEvent, self._light_figure)
        self.interactor = self.vtk_widget.interactor

        self._provider: FrameProvider | None = None
        self._tint_provider: Callable[[], Mapping[str, str]] | None = None
        self._builder: FigureBuilder | None = None
        self.skeleton: SkeletonActor | None = None
        self._last_frame_id: object = None
        self._last_geometry: FigureGeometry | None = None
        self._camera_preset = "front"
        self._camera_pending = True
        self._followed_root = None  # root (scene, m) the follow camera last moved to
        self._dirty = True
        self._alive = True
        self._initialized = False
        self._running = False
        self.frames_rendered = 0
        self.shown_frame_id: object = None
        self.render_times: list[float] = []  # perf_counter() of recent frames shown (bounded)
        self.render_failure: str | None = None
        self.render_client: RenderClient | None = None
        if render_process_wanted() if render_process is None else render_process:
            self.render_client = RenderClient(self.vtk_widget, self._scene_state)
            self.render_client.failed.connect(self._render_here)
            self.render_client.frame_shown.connect(self._frame_shown)
            self.vtk_widget.set_remote(self.render_client)

        self._timer = QtCore.QTimer(self)
        self._timer.setTimerType(QtCore.Qt.PreciseTimer)
        self._timer.setInterval(max(1, int(round(1000.0 / self.target_fps))))
        self._timer.timeout.connect(self.tick)

    # -- configuration -------------------------------------------------------------------
    def set_figure(self, builder: FigureBuilder) -> None:
        """Show the figure of ``builder``'s model (replaces any previous figure)."""
        if self.skeleton is not None:
            self.skeleton.remove()
        self._builder = builder
        self.skeleton = SkeletonActor(self.renderer, builder)
        if self.render_client is not None:
            self.render_client.set_figure(FigureLayout.of(builder))
        self._last_frame_id = None
        # Until the first frame, look at the floor where the subject will stand; the preset is
        # applied again around the figure's root when it arrives.
        self.stage.set_world_matrix(plain_world_matrix())
        self._apply_camera(np.zeros(3))
        self._camera_pending = True
        self._dirty = True

    def set_frame_provider(self, provider: FrameProvider | None) -> None:
        """Where each tick gets the newest frame (``None`` freezes the view)."""
        self._provider = provider
        self._last_frame_id = None
        self._dirty = True

    def set_tint_provider(self, provider: Callable[[], Mapping[str, str]] | None) -> None:
        """Where each tick gets segment → sensor state names for tinting."""
        self._tint_provider = provider
        self._dirty = True

    @property
    def camera_preset(self) -> str:
        return self._camera_preset

    def set_camera_preset(self, name: str) -> None:
        """Move the camera to preset ``name`` (one of ``CAMERA_PRESETS``)."""
        if name not in CAMERA_PRESETS:
            raise ValueError(f"camera preset must be one of {CAMERA_PRESETS}, got {name!r}")
        self._camera_preset = name
        self._camera_pending = True
        self._dirty = True

    def set_stage_visible(self, floor: bool, axes: bool) -> None:
        self.stage.set_visible(floor, axes)
        self._dirty = True

    @property
    def alive(self) -> bool:
        """False once :meth:`shutdown` ran (nothing renders any more)."""
        return self._alive

    @property
    def last_geometry(self) -> FigureGeometry | None:
        """The geometry currently shown (``None`` before the first frame)."""
        return self._last_geometry

    # -- render loop -----------------------------------------------------------------------
    def start(self, own_clock: bool = True) -> None:
        """Start rendering (idempotent): ticked by the view's own timer, or, with
        ``own_clock=False``, by the owner calling :meth:`tick` whenever new data came in."""
        if not self._alive:
            return
        if not self._initialized:
            self.vtk_widget.Initialize()
            self._initialized = True
        self._running = True
        if own_clock and not self._timer.isActive():
            self._timer.start()
        elif not own_clock:
            self._timer.stop()

    def stop(self) -> None:
        self._timer.stop()
        self._running = False

    @property
    def running(self) -> bool:
        return self._running

    def _set_clipping_range(self) -> None:
        """Near and far planes from the camera distance alone: from 2 % of it to the far edge of
        the 30 m floor. (VTK's reset computes every actor's bounds: 0.35 ms a frame on
        software OpenGL, for planes that hardly change.)"""
        camera = self.renderer.GetActiveCamera()
        distance = camera.GetDistance()
        camera.SetClippingRange(max(0.01, 0.02 * distance), distance + CLIPPING_FAR_M)

    def _scene_state(self) -> tuple[SceneState, object]:
        """The scene now, lit from the camera, for the render process, and the id of the frame
        it shows."""
        self._set_clipping_range()
        self._light_figure()
        return capture_scene(self.renderer, self.stage, self.skeleton), self._last_frame_id

    def _render_here(self, reason: str) -> None:
        """The render process failed (``reason``): draw in this process from now on."""
        self.render_failure = reason
        self.render_client = None
        self.vtk_widget.set_remote(None)
        self._dirty = True
        if self._running:
            self.render()
        self.drawing_moved_here.emit(reason)

    def _light_figure(self, _caller=None, _event=None) -> None:
        if self.skeleton is not None:
            self.skeleton.shade(-np.asarray(self.renderer.GetActiveCamera().GetDirectionOfProjection()))

    def _axis_labels(self) -> list[OverlayLabel]:
        """The world axes' names where the frame just rendered shows their anchors (none
        behind the camera or outside the picture)."""
        names, points = self.stage.axis_label_points()
        if not names:
            return []
        width, height = self.render_window.GetSize()
        labels = []
        for name, (x, y, depth) in zip(names, world_to_display(self.renderer, points).tolist()):
            if 0.0 < depth < 1.0 and 0.0 <= x < width and 0.0 <= y < height:
                labels.append(OverlayLabel(name, x, height - y))
        return labels

    def set_hint(self, text: str) -> None:
        """Say ``text`` in the middle of the view (``""``: nothing), e.g. why it shows no figure."""
        self.vtk_widget.set_hint(text)

    def _move_camera(self, shift) -> None:
        """Translate camera and focal point by ``shift`` (scene, m): the user's turn and zoom stay."""
        if not any(shift):
            return
        camera = self.renderer.GetActiveCamera()
        camera.SetFocalPoint(*(camera.GetFocalPoint() + shift))
        camera.SetPosition(*(camera.GetPosition() + shift))
        self._dirty = True

    def _apply_camera(self, root_scene) -> None:
        if self._builder is None:
            return
        pose = camera_preset(self._camera_preset, root_scene, self._builder.height_m)
        camera = self.renderer.GetActiveCamera()
        camera.SetFocalPoint(*pose.focal_point)
        camera.SetPosition(*pose.position)
        camera.SetViewUp(*pose.view_up)
        camera.SetViewAngle(30.0)
        self.renderer.ResetCameraClippingRange()

    def tick(self) -> None:
        """Take the newest frame, tints and camera; render if anything changed."""
        if not self._alive or not self._running or self.skeleton is None:
            return
        if self._provider is not None:
            frame = self._provider()
            if frame is not None:
                frame_id, geometry = frame
                if frame_id != self._last_frame_id:
                    self._last_frame_id = frame_id
                    self._last_geometry = geometry
                    self.skeleton.update(geometry)
                    self.stage.set_world_matrix(geometry.world_matrix, geometry.root_world_m)
                    self._dirty = True
        if self._tint_provider is not None and self.skeleton.set_tints(self._tint_provider()):
            self._dirty = True
        if self._last_geometry is not None:
            root = self._last_geometry.root_scene_m
            if self._camera_pending:
                self._apply_camera(root)
                self._camera_pending = False
                self._followed_root = root
            elif self._camera_preset == "follow" and self._followed_root is not None:
                self._move_camera(follow_shift(self._followed_root, root))
                self._followed_root = root
        if self._dirty:
            self.render()

    def render(self) -> None:
        """Draw one frame of the scene as it is now (does nothing after :meth:`shutdown` or
        before show). In this process the picture is shown on return; from the render process
        it follows (:attr:`frame_rendered`) while this returns at once."""
        if not self._alive or not self.isVisible():
            return
        self._dirty = False
        if self.render_client is not None:
            self.render_client.render()
        else:
            self._set_clipping_range()
            self.vtk_widget.render()
            self._frame_shown(self._last_frame_id)

    def _frame_shown(self, frame_id: object) -> None:
        self.frames_rendered += 1
        self.shown_frame_id = frame_id
        now = time.perf_counter()
        self.render_times.append(now)
        if len(self.render_times) > 600:
            del self.render_times[:300]
        self.frame_rendered.emit(now)

    def shutdown(self) -> None:
        """Stop rendering for good and release the OpenGL context."""
        if not self._alive:
            return
        self._timer.stop()
        self._alive = False
        self._provider = None
        self._tint_provider = None
        if self.render_client is not None:
            self.render_client.close()
            self.render_client = None
            self.vtk_widget.set_remote(None)
        self.vtk_widget.Finalize()

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802 (Qt API)
        self.shutdown()
        super().closeEvent(event)

    # -- capture ---------------------------------------------------------------------------
    def grab_image(self) -> QtGui.QImage:
        """The current 3D view as an RGB ``QImage`` (rendered now)."""
        if not self._alive:
            raise RuntimeError("the 3D view is closed")
        self.vtk_widget.render()
        return self.vtk_widget.image()
