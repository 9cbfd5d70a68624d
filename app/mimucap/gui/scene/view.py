"""The 3D view widget: a VTK render window in the GUI process, and a frame clock.

The widget *has* a :class:`~mimucap.gui.vtk_widget.VtkWidget` (VTK's Qt render window
interactor; no double inheritance). Each :meth:`SceneView.tick` asks the frame provider for
the newest :class:`~mimucap.session.figure.FigureGeometry` and renders once, only when
something changed (new frame, tint, camera, hint). Ticks come either from the view's own
``QTimer`` at :attr:`SceneView.target_fps` (``start()``), or from the owner right after it has
taken in new data (``start(own_clock=False)``; the main window does so, which keeps the time
from a sample's arrival to the screen short: one render per data tick). Mouse orbit/zoom is
VTK's trackball camera style. The camera follows the subject along the floor in every preset
(:mod:`mimucap.session.camera`). After :meth:`SceneView.shutdown` (called on close) nothing
renders again.
"""

from __future__ import annotations

import textwrap
import time
from collections.abc import Callable, Mapping

import numpy as np
from PyQt5 import QtCore, QtGui, QtWidgets
from vtkmodules.vtkCommonCore import vtkCommand
from vtkmodules.vtkRenderingCore import vtkTextActor

from mimucap.gui.scene.environment import Stage, scene_renderer
from mimucap.gui.scene.skeleton_actor import SkeletonActor
from mimucap.gui.vtk_widget import VtkWidget
from mimucap.session.camera import CAMERA_PRESETS, camera_preset, follow_shift
from mimucap.session.figure import FigureBuilder, FigureGeometry, plain_world_matrix

#: How far beyond the focal point the far plane lies (m): the whole floor grid.
CLIPPING_FAR_M = 45.0
#: The hint's text: size (points at 72 dots per inch), characters per line at most.
HINT_FONT_SIZE, HINT_LINE_CHARACTERS = 15, 52

#: Called every tick; returns ``(frame_id, geometry)`` for the newest frame or ``None``.
FrameProvider = Callable[[], "tuple[object, FigureGeometry] | None"]


def _hint_actor() -> vtkTextActor:
    """A hidden text actor centred in the view: white text on a dark translucent box."""
    actor = vtkTextActor()
    actor.GetPositionCoordinate().SetCoordinateSystemToNormalizedViewport()
    actor.GetPositionCoordinate().SetValue(0.5, 0.5)
    text = actor.GetTextProperty()
    text.SetFontSize(HINT_FONT_SIZE)
    text.SetColor(1.0, 1.0, 1.0)
    text.SetJustificationToCentered()
    text.SetVerticalJustificationToCentered()
    text.SetBackgroundColor(20 / 255, 24 / 255, 32 / 255)
    text.SetBackgroundOpacity(0.8)
    text.SetLineSpacing(1.2)
    actor.VisibilityOff()
    actor.PickableOff()
    return actor


class SceneView(QtWidgets.QWidget):
    """The skeleton's 3D view, drawn in this process by its :class:`VtkWidget`.

    Attributes:
        frames_rendered: frames drawn by :meth:`render` so far.
        shown_frame_id: the frame id (from the frame provider) of the picture on screen.
        hint: the text said in the middle of the view (``""``: none; :meth:`set_hint`).

    Signals:
        frame_rendered(float): emitted when a new picture is shown, with ``time.perf_counter()``.
    """

    frame_rendered = QtCore.pyqtSignal(float)

    def __init__(self, parent: QtWidgets.QWidget | None = None, target_fps: float = 60.0) -> None:
        super().__init__(parent)
        self.setObjectName("sceneView")
        self.target_fps = float(target_fps)
        self.vtk_widget = VtkWidget(self)
        self.vtk_widget.setObjectName("vtkWidget")
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.vtk_widget)
        self.render_window = self.vtk_widget.render_window
        self.renderer = scene_renderer()
        self.render_window.AddRenderer(self.renderer)
        self.stage = Stage(self.renderer)
        self.hint = ""
        self._hint_actor = _hint_actor()
        self.renderer.AddViewProp(self._hint_actor)
        # Every frame, whoever asks for it (the tick, the mouse, a repaint), gets near and far
        # planes from the camera distance.
        self.render_window.AddObserver(vtkCommand.StartEvent, self._set_clipping_range)
        self.interactor = self.vtk_widget.interactor

        self._provider: FrameProvider | None = None
        self._tint_provider: Callable[[], Mapping[str, str]] | None = None
        self._ghost_provider: FrameProvider | None = None
        self._ghost_frame_id: object = None
        self._builder: FigureBuilder | None = None
        self.skeleton: SkeletonActor | None = None
        #: the simulator's truth as a translucent figure beside the estimate (evaluation only)
        self.ghost: SkeletonActor | None = None
        self._last_frame_id: object = None
        self._last_geometry: FigureGeometry | None = None
        self._camera_preset = CAMERA_PRESETS[0]
        self._camera_pending = True
        self._followed_root = None  # root (scene, m) the camera last moved with
        self._dirty = True
        self._alive = True
        self._running = False
        self.frames_rendered = 0
        self.shown_frame_id: object = None
        self.render_times: list[float] = []  # perf_counter() of recent frames shown (bounded)

        self._timer = QtCore.QTimer(self)
        self._timer.setTimerType(QtCore.Qt.PreciseTimer)
        self._timer.setInterval(max(1, int(round(1000.0 / self.target_fps))))
        self._timer.timeout.connect(self.tick)

    # -- configuration -------------------------------------------------------------------
    def set_figure(self, builder: FigureBuilder) -> None:
        """Show the figure of ``builder``'s model (replaces any previous figure)."""
        if self.skeleton is not None:
            self.skeleton.remove()
        if self.ghost is not None:
            self.ghost.remove()
        self._builder = builder
        self.skeleton = SkeletonActor(self.renderer, builder)
        self.ghost = SkeletonActor(self.renderer, builder)
        self.ghost.make_ghost()
        self._ghost_frame_id = None
        self._last_frame_id = None
        self._last_geometry = None
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

    def set_ghost_provider(self, provider: FrameProvider | None) -> None:
        """Where each tick gets the ghost figure's frame (the simulator's truth, drawn
        translucent beside the estimate); ``None`` (or a provider giving ``None``) hides it."""
        self._ghost_provider = provider
        self._ghost_frame_id = None
        if provider is None and self.ghost is not None and self.ghost.visible:
            self.ghost.hide()
        self._dirty = True

    def set_tint_provider(self, provider: Callable[[], Mapping[str, str]] | None) -> None:
        """Where each tick gets segment → sensor state names for tinting."""
        self._tint_provider = provider
        self._dirty = True

    @property
    def camera_preset(self) -> str:
        return self._camera_preset

    def set_camera_preset(self, name: str) -> None:
        """Move the camera to preset ``name`` (one of ``CAMERA_PRESETS``) around the figure;
        it then follows the figure along the floor."""
        if name not in CAMERA_PRESETS:
            raise ValueError(f"camera preset must be one of {CAMERA_PRESETS}, got {name!r}")
        self._camera_preset = name
        self._camera_pending = True
        self._dirty = True

    def set_stage_visible(self, floor: bool, axes: bool) -> None:
        self.stage.set_visible(floor, axes)
        self._dirty = True

    def set_hint(self, text: str) -> None:
        """Say ``text`` in the middle of the view (``""``: nothing), e.g. why it shows no figure;
        drawn with the next frame."""
        if text == self.hint:
            return
        self.hint = text
        # VTK's built-in font has no arrow: menu paths read "Calibrate > Body…" in the view.
        shown = text.replace(" → ", " > ")
        lines = [wrapped for paragraph in shown.split("\n")
                 for wrapped in (textwrap.wrap(paragraph, HINT_LINE_CHARACTERS) or [""])]
        # A space either side of each line keeps the text off the box's edges.
        self._hint_actor.SetInput("\n".join(f" {line} " for line in lines))
        self._hint_actor.SetVisibility(bool(text))
        self._dirty = True
        if self._running and not self._timer.isActive():
            self.render()  # ticked by its owner, who may have nothing new to show for a while

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

    def _set_clipping_range(self, _caller=None, _event=None) -> None:
        """Near and far planes from the camera distance alone: from 2 % of it to the far edge of
        the 30 m floor. (VTK's reset computes every actor's bounds for planes that hardly
        change.)"""
        camera = self.renderer.GetActiveCamera()
        distance = camera.GetDistance()
        camera.SetClippingRange(max(0.01, 0.02 * distance), distance + CLIPPING_FAR_M)

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
        width, height = self.render_window.GetSize()
        aspect = width / height if width > 0 and height > 0 else 1.0
        pose = camera_preset(self._camera_preset, root_scene, self._builder.height_m, aspect)
        camera = self.renderer.GetActiveCamera()
        camera.SetFocalPoint(*pose.focal_point)
        camera.SetPosition(*pose.position)
        camera.SetViewUp(*pose.view_up)
        camera.SetViewAngle(pose.view_angle_deg)

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
        if self._ghost_provider is not None and self.ghost is not None:
            ghost = self._ghost_provider()
            if ghost is None:
                if self.ghost.visible:
                    self.ghost.hide()
                    self._dirty = True
            elif ghost[0] != self._ghost_frame_id:
                self._ghost_frame_id = ghost[0]
                self.ghost.update(ghost[1])
                self._dirty = True
        if self._tint_provider is not None and self.skeleton.set_tints(self._tint_provider()):
            self._dirty = True
        if self._last_geometry is not None:
            root = self._last_geometry.root_scene_m
            if self._camera_pending:
                self._apply_camera(root)
                self._camera_pending = False
                self._followed_root = root
                self._dirty = True
            elif self._followed_root is not None:
                self._move_camera(follow_shift(self._followed_root, root))
                self._followed_root = root
        if self._dirty:
            self.render()

    def render(self) -> None:
        """Draw one frame of the scene as it is now and show it (nothing after
        :meth:`shutdown`, nor while hidden)."""
        if not self._alive or not self.isVisible():
            return
        self._dirty = False
        self.vtk_widget.render()
        self.frames_rendered += 1
        self.shown_frame_id = self._last_frame_id
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
        self._running = False
        self._provider = None
        self._tint_provider = None
        self.vtk_widget.Finalize()

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802 (Qt API)
        self.shutdown()
        super().closeEvent(event)

    # -- capture ---------------------------------------------------------------------------
    def grab_image(self) -> QtGui.QImage:
        """The current 3D view as an RGB ``QImage`` (rendered now)."""
        if not self._alive:
            raise RuntimeError("the 3D view is closed")
        return self.vtk_widget.image()
