"""The 3D view widget: a VTK render window in the GUI process that draws the poses it is told of.

The widget *has* a :class:`~mimucap.gui.vtk_widget.VtkWidget` (VTK's Qt render window
interactor; no double inheritance). It subscribes to a model's events (:meth:`SceneView.set_model`:
the live session or the review player, ``frame(frame_id, geometry)`` with the newest
:class:`~mimucap.session.views.skeleton_figure.FigureGeometry`, ``truth_frame`` for the ghost figure,
``status`` for the segments' tints) and keeps no copy of the model's data. Whatever changes
(a tint, the camera, the hint) marks the picture dirty and asks for one render when the event
loop is free again; a new frame (a model's last event of a step) is drawn at once with all that
came before it: the events of one pipeline step give one picture. At most one picture is drawn
per frame interval (:attr:`SceneView.target_fps`, less :data:`FRAME_INTERVAL_SLACK` for the
timers' jitter): what arrives sooner waits for a single-shot timer, and frames that arrive
faster are coalesced.
Mouse orbit/zoom is VTK's trackball camera style. The camera follows the subject along the
floor in every preset (:mod:`mimucap.session.views.camera`). After :meth:`SceneView.shutdown`
(called on close) nothing renders again.
"""

from __future__ import annotations

import textwrap
import time
from collections.abc import Mapping

import numpy as np
from PyQt5 import QtCore, QtGui, QtWidgets
from vtkmodules.vtkCommonCore import vtkCommand
from vtkmodules.vtkRenderingCore import vtkTextActor

from mimucap.gui.scene.environment import Stage, scene_renderer
from mimucap.gui.scene.sensor_glyph_actor import SensorGlyphActor
from mimucap.gui.scene.skeleton_actor import SkeletonActor
from mimucap.gui.throttle import RepaintThrottle
from mimucap.gui.vtk_widget import VtkWidget
from mimucap.session.views.camera import CAMERA_PRESETS, camera_preset, follow_shift
from mimucap.session.views.skeleton_figure import FigureBuilder, FigureGeometry, plain_world_matrix

#: How far beyond the focal point the far plane lies (m): the whole floor grid.
CLIPPING_FAR_M = 45.0
#: The hint's text: size (points at 72 dots per inch), characters per line at most.
HINT_FONT_SIZE, HINT_LINE_CHARACTERS = 15, 52
#: Where the hint's top edge sits once a figure is shown (share of the view's height).
HINT_TOP = 0.97

#: Share of the frame interval (1 / ``target_fps``) two renders may come closer than: the data
#: clock (62.5 Hz) and Qt's millisecond timers jitter around a 60 Hz interval, and holding a
#: frame back for a fraction of a millisecond would add a whole interval of delay now and then.
FRAME_INTERVAL_SLACK = 0.1
#: The event a view posts itself to render when the event loop is free.
_RENDER_EVENT = QtCore.QEvent.Type(QtCore.QEvent.registerEventType())


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
        shown_frame_id: the frame id (of the model's ``frame`` event) of the picture on screen.
        hint: the text said in the middle of the view (``""``: none; :meth:`set_hint`).
        target_fps: most pictures a second (the screen's rate).

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

        self._model = None
        self._ghost_wanted = False
        self._pending_frame: tuple[object, FigureGeometry] | None = None
        self._pending_ghost: tuple[object, FigureGeometry | None] | None = None
        self._pending_tints: Mapping[str, str] | None = None
        self._tints: Mapping[str, str] = {}  # the last tints asked for (a new figure takes them)
        self._ghost_frame_id: object = None
        self._builder: FigureBuilder | None = None
        self.skeleton: SkeletonActor | None = None
        #: the sensors on the outline before a body calibration
        self.sensor_glyphs = SensorGlyphActor(self.renderer)
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
        self._throttle = RepaintThrottle(self.target_fps, FRAME_INTERVAL_SLACK)

        # One render when the event loop is free again (a posted event of high priority: before
        # the plots' repaints queued meanwhile), or, within a frame interval of the last one,
        # when the interval is over (a timer): what changed meanwhile is drawn in one picture.
        self._render_posted = False
        self._render_timer = QtCore.QTimer(self)
        self._render_timer.setSingleShot(True)
        self._render_timer.setTimerType(QtCore.Qt.PreciseTimer)
        self._render_timer.timeout.connect(self.render_pending)

    # -- configuration -------------------------------------------------------------------
    def set_figure(self, builder: FigureBuilder) -> None:
        """Show the figure of ``builder``'s model (replaces any previous figure)."""
        if self.skeleton is not None:
            self.skeleton.remove()
        if self.ghost is not None:
            self.ghost.remove()
        self.sensor_glyphs.hide()
        self._builder = builder
        self.skeleton = SkeletonActor(self.renderer, builder)
        self.ghost = SkeletonActor(self.renderer, builder)
        self.ghost.make_ghost()
        self._ghost_frame_id = None
        self._last_frame_id = None
        self._last_geometry = None
        self._pending_tints = self._tints
        self._place_hint(above_figure=False)
        # Until the first frame, look at the floor where the subject will stand; the preset is
        # applied again around the figure's root when it arrives.
        self.stage.set_world_matrix(plain_world_matrix())
        self._apply_camera(np.zeros(3))
        self._camera_pending = True
        self._dirty = True
        self._schedule()

    # -- the model's events -------------------------------------------------------------
    @property
    def model(self):
        """The model whose events the view follows (``None``: none)."""
        return self._model

    def set_model(self, model) -> None:
        """Follow ``model`` (the live session or a review player: ``events.frame``, its
        ``frame()`` now; ``events.status`` for the tints when it has one), or nothing
        (``None``); the previous model is let go (unsubscribed). The ghost figure follows the
        new model when :meth:`set_ghost_visible` asked for it."""
        previous, self._model = self._model, None
        if previous is not None:
            previous.events.frame.disconnect(self.show_frame)
            previous.events.truth_frame.disconnect(self.show_ghost)
            if "status" in previous.events.names:
                previous.events.status.disconnect(self._status_changed)
        self._last_frame_id = None
        self._pending_frame = None
        self._pending_ghost = None
        if model is None:
            return
        self._model = model
        model.events.frame.connect(self.show_frame)
        if "status" in model.events.names:
            model.events.status.connect(self._status_changed)
        frame = model.frame()
        if frame is not None:
            self.show_frame(*frame)
        self.set_ghost_visible(self._ghost_wanted)

    def set_ghost_visible(self, on: bool) -> None:
        """Draw the model's ``truth_frame`` (the simulator's truth) as a translucent ghost
        figure beside the estimate, or not (a second figure doubles the drawing without a GPU,
        so the view subscribes to it only while asked)."""
        self._ghost_wanted = bool(on)
        model = self._model
        if not on:
            if model is not None:
                model.events.truth_frame.disconnect(self.show_ghost)
            self._pending_ghost = None
            self._ghost_frame_id = None
            if self.ghost is not None and self.ghost.visible:
                self.ghost.hide()  # at once (the picture follows with the next render)
                self._dirty = True
                self._schedule()
        elif model is not None:
            model.events.truth_frame.connect(self.show_ghost)
            truth = model.truth_frame()
            self.show_ghost(*(truth if truth is not None else (None, None)))

    def show_frame(self, frame_id: object, geometry: FigureGeometry) -> None:
        """Show the figure's pose ``geometry``: drawn at once, with whatever else arrived since the
        last picture, when a frame interval has passed since it (a model emits ``frame`` last
        among the events of a change, which keeps the time from a sample to the screen short);
        else when the interval is over, replaced by any frame that arrives meanwhile."""
        self._pending_frame = (frame_id, geometry)
        if self._wait_s() > 0:
            self._schedule()
        else:
            self.render_pending()

    def show_ghost(self, frame_id: object, geometry: FigureGeometry | None) -> None:
        """Show the ghost figure at ``geometry`` (``None`` hides it), with the next render."""
        self._pending_ghost = (frame_id, geometry)
        self._schedule()

    def set_tints(self, tints: Mapping[str, str]) -> None:
        """Tint each segment by its sensor's state (segment → ``ok``, ``mag_uncalibrated``,
        ``stale``), with the next render."""
        self._tints = self._pending_tints = dict(tints)
        self._schedule()

    def _status_changed(self, rows) -> None:
        self.set_tints({row.segment: row.state for row in rows if row.segment is not None})

    def _schedule(self) -> None:
        """Ask for one render when the event loop is free, a frame interval after the last one."""
        if not self._alive or not self._running or self._render_posted or self._render_timer.isActive():
            return
        wait_s = self._wait_s()
        if wait_s > 0:
            self._render_timer.start(RepaintThrottle.timer_ms(wait_s))
        else:
            self._render_posted = True
            QtCore.QCoreApplication.postEvent(self, QtCore.QEvent(_RENDER_EVENT), QtCore.Qt.HighEventPriority)

    def _wait_s(self) -> float:
        """How long (s) until the next picture is due (≤ 0: now)."""
        if self._throttle.rate_hz != self.target_fps:
            self._throttle = RepaintThrottle(self.target_fps, FRAME_INTERVAL_SLACK)
        return self._throttle.wait_s(time.perf_counter())

    def customEvent(self, event: QtCore.QEvent) -> None:  # noqa: N802 (Qt API)
        if event.type() == _RENDER_EVENT:
            self._render_posted = False
            self.render_pending()
        else:
            super().customEvent(event)

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
        self._schedule()

    def set_stage_visible(self, floor: bool, axes: bool) -> None:
        self.stage.set_visible(floor, axes)
        self._dirty = True
        self._schedule()

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
        self._schedule()

    def _place_hint(self, above_figure: bool) -> None:
        """The hint in the middle of an empty view; above the figure once one is shown (the
        outline with its sensors must stay in sight under it)."""
        coordinate = self._hint_actor.GetPositionCoordinate()
        text = self._hint_actor.GetTextProperty()
        if above_figure:
            coordinate.SetValue(0.5, HINT_TOP)
            text.SetVerticalJustificationToTop()
        else:
            coordinate.SetValue(0.5, 0.5)
            text.SetVerticalJustificationToCentered()

    @property
    def alive(self) -> bool:
        """False once :meth:`shutdown` ran (nothing renders any more)."""
        return self._alive

    @property
    def last_geometry(self) -> FigureGeometry | None:
        """The geometry currently shown (``None`` before the first frame)."""
        return self._last_geometry

    # -- rendering -------------------------------------------------------------------------
    def start(self) -> None:
        """Render from now on whenever something changes (idempotent; the first picture at once)."""
        if not self._alive:
            return
        self._running = True
        self._dirty = True
        self._schedule()

    def stop(self) -> None:
        """Render no more until :meth:`start` (what changes meanwhile is drawn then)."""
        self._render_timer.stop()
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

    def render_pending(self) -> None:
        """Apply what arrived since the last picture (the newest frame, ghost, tints; the camera
        following the figure) and render if anything changed. The render timer calls it; a
        caller that needs the picture now (a screenshot, a test) may too."""
        self._render_timer.stop()
        if not self._alive or not self._running:
            return
        if self.skeleton is None:  # no figure yet: the floor and the hint only
            if self._dirty:
                self.render()
            return
        frame, self._pending_frame = self._pending_frame, None
        if frame is not None and frame[0] != self._last_frame_id:
            frame_id, geometry = frame
            first = self._last_geometry is None
            self._last_frame_id = frame_id
            self._last_geometry = geometry
            self.skeleton.set_outline(geometry.outline)
            self.skeleton.update(geometry)
            if geometry.sensor_glyphs is not None:
                self.sensor_glyphs.update(geometry.sensor_glyphs, self._tints)
            else:
                self.sensor_glyphs.hide()
            self.stage.set_world_matrix(geometry.world_matrix, geometry.root_world_m)
            if first:
                self._place_hint(above_figure=True)
            self._dirty = True
        ghost, self._pending_ghost = self._pending_ghost, None
        if ghost is not None and self.ghost is not None:
            ghost_id, geometry = ghost
            if geometry is None:
                self._ghost_frame_id = None
                if self.ghost.visible:
                    self.ghost.hide()
                    self._dirty = True
            elif ghost_id != self._ghost_frame_id:
                self._ghost_frame_id = ghost_id
                self.ghost.update(geometry)
                self._dirty = True
        tints, self._pending_tints = self._pending_tints, None
        if tints is not None and self.skeleton.set_tints(tints):
            self._dirty = True
        if tints is not None and self.sensor_glyphs.visible:
            self.sensor_glyphs.set_states(tints)
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
        # the schedule counts from a render's start: a slow frame (a software rasteriser) must
        # not lengthen the next interval by its own duration
        self._throttle.painted(time.perf_counter())
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
        self._render_timer.stop()
        self._alive = False
        self._running = False
        self.set_model(None)
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
