"""The live session's pose part: the newest pose of the figure, where it stands, its picture and
the joint-angle history (no Qt).

:class:`LivePose` takes each pose the pipeline makes (:meth:`LivePose.take`: session time ``t_s``
and ``q_world_from_segment``, world ENU, scalar first, one per segment of the skeleton model),
follows where the figure stands on the floor (:class:`~mimucap.core.root_position.RootTracker`, from
its feet's contact), builds the figure's :class:`~mimucap.session.views.skeleton_figure.FigureGeometry` when
asked (:meth:`LivePose.frame`, once per pose and display mode) and keeps the joint angles (deg)
of the last :data:`~mimucap.session.live.plot_history.MAX_WINDOW_S` seconds, computed in one vectorised
batch when they are read (poses arrive at up to 100 Hz, the plots read at 30 Hz).

Before a body calibration the pose is no measured pose: each assigned sensor's axes stand in for
its segment's (``take(..., segment_of_sensor=...)``). The figure is then the neutral outline with
the sensors on it (:meth:`~mimucap.session.views.skeleton_figure.FigureBuilder.build_outline`),
no root is tracked and no joint angles are kept: angles between two sensors' axes are not joint
angles, and a plot of them (or an error against the truth) would say nothing but "not calibrated".

Interface: ``take(t_s, q_world_from_segment, segment_of_sensor=None)``, ``reset()`` (a new body
calibration: where the figure stands is found again), ``set_height(height_m)``, ``set_display_mode(mode)``,
``frame(heading_ref_rad)``, ``figure_of(q_world_from_segment, frame_id, heading_ref_rad)``
(another pose standing where this one stands: the simulator's truth), ``joint_series(joint,
window_s)``, and the properties ``time_s``, ``q_world_from_segment``, ``frame_id``,
``joint_names``, ``joint_columns(joint)``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mimucap.core import rotation, skeleton
from mimucap.core.root_position import RootTracker
from mimucap.session.views.skeleton_figure import FigureBuilder, FigureGeometry
from mimucap.session.live.ring_buffer import RingBuffer


def joint_column_groups(model: skeleton.SkeletonModel) -> dict[str, tuple[str, str, str]]:
    """Joint → its three angle columns (meaning and ``_deg`` unit in the names), in the model's
    joint order, for the joints that have three."""
    columns = skeleton.joint_angle_columns(model)
    grouped = {joint: [c for c in columns if c.startswith(joint + "_")][:3] for joint in model.joint_names}
    return {joint: tuple(c) for joint, c in grouped.items() if len(c) == 3}


class LivePose:
    """The newest pose of ``model``'s figure for a subject of ``height_m`` (m), and the joint
    angles of the last ``window_s`` seconds at up to ``rate_hz`` poses a second (see the module
    doc)."""

    def __init__(self, model: skeleton.SkeletonModel, height_m: float, window_s: float, rate_hz: float) -> None:
        self.model = model
        self.height_m = float(height_m)
        self.builder = FigureBuilder(model, self.height_m)
        self.display_mode = "world"
        #: where the figure stands, from its feet's contact with the floor
        self._root_tracker = RootTracker(model, self.height_m)
        self._columns = joint_column_groups(model)
        #: joint → its row in :func:`skeleton.joint_angles_deg_stacked` output (model joint order)
        self._joint_row = {joint: model.joint_names.index(joint) for joint in self._columns}
        capacity = int(window_s * rate_hz)
        self._angles = {joint: RingBuffer(capacity, (3,)) for joint in self._columns}
        self._angle_capacity = capacity
        #: poses since the last joint-angle update: (t_s, (S, 4) orientations in model order)
        self._pending: list[tuple[float, np.ndarray]] = []
        self._q: dict[str, np.ndarray] | None = None
        self._q_stacked: np.ndarray | None = None   # the same (S, 4), segments in model order
        self._root_m: np.ndarray | None = None
        self._t_s = float("nan")
        #: sensor id → segment while the pose is not calibrated (the outline), else None
        self._uncalibrated: dict[str, str] | None = None
        self._frame_id = 0
        self._geometry: tuple[object, FigureGeometry] | None = None

    # -- the newest pose -----------------------------------------------------------------------
    def take(self, t_s: float, q_world_from_segment: Mapping[str, np.ndarray],
             segment_of_sensor: Mapping[str, str] | None = None) -> None:
        """A new pose at session time ``t_s`` (s): segment → ``q_world_from_segment`` (4,);
        ``ValueError`` naming the segments of the model it lacks.

        ``segment_of_sensor`` (sensor id → segment) says the pose is not calibrated: each of
        those segments carries its sensor's ``q_world_from_sensor``. The figure is then the
        outline with the sensors on it, and neither the root nor joint angles are kept; the
        angles kept before are dropped whenever the pose changes between calibrated and not."""
        missing = [name for name in self.model.segment_names if name not in q_world_from_segment]
        if missing:
            raise ValueError(f"the pose lacks segments of the {self.model.name} model: {', '.join(missing)}; "
                             "choose the model the source was made for")
        q_stacked = np.array([q_world_from_segment[name] for name in self.model.segment_names], dtype=float)
        uncalibrated = None if segment_of_sensor is None else dict(segment_of_sensor)
        if (uncalibrated is None) != (self._uncalibrated is None):
            self._drop_angles()
        self._uncalibrated = uncalibrated
        self._q = dict(q_world_from_segment)
        self._q_stacked = q_stacked
        self._t_s = float(t_s)
        if uncalibrated is None:
            self._root_m = self._root_tracker.update(q_stacked)
            self._pending.append((self._t_s, q_stacked))
            if len(self._pending) > self._angle_capacity:
                del self._pending[: len(self._pending) - self._angle_capacity]
        else:
            self._root_m = None
        self.new_frame()

    def _drop_angles(self) -> None:
        """Forget the joint angles kept (they belong to a pose that is no longer shown)."""
        self._pending = []
        for buffer in self._angles.values():
            buffer.clear()

    def new_frame(self) -> None:
        """The figure changes (a new pose, display mode or height): a new :attr:`frame_id`."""
        self._frame_id += 1
        self._geometry = None

    def reset(self) -> None:
        """Find where the figure stands again (a new body calibration turns the figure)."""
        self._root_tracker.reset()
        self._geometry = None

    @property
    def time_s(self) -> float:
        """Session time (s) of the newest pose (NaN before the first)."""
        return self._t_s

    @property
    def q_world_from_segment(self) -> dict[str, np.ndarray] | None:
        """Newest segment orientations, segment → ``(4,)`` (world ENU, scalar first)."""
        return self._q

    @property
    def root_m(self) -> np.ndarray | None:
        """Where the figure's root stands (3,) (world ENU, m), ``None`` before the first pose."""
        return self._root_m

    @property
    def frame_id(self) -> int:
        """Changes with every new pose, display mode and height."""
        return self._frame_id

    # -- the figure ----------------------------------------------------------------------------
    def set_display_mode(self, mode: str) -> None:
        """``"world"`` or ``"body"`` (see :mod:`mimucap.session.views.skeleton_figure`)."""
        self.builder.display_alpha(mode, rotation.identity(), 0.0)  # validates
        self.display_mode = mode
        self.new_frame()

    def set_height(self, height_m: float) -> None:
        """The subject's height (m): rescales the figure."""
        builder = FigureBuilder(self.model, float(height_m))  # validates
        self.height_m = float(height_m)
        self.builder = builder
        self._root_tracker = RootTracker(self.model, self.height_m)
        self.new_frame()

    def frame(self, heading_ref_rad: float | None = None) -> tuple[object, FigureGeometry] | None:
        """``(frame_id, geometry)`` of the newest pose (``heading_ref_rad``: the heading the body
        display mode turns to face the camera), or ``None`` before the first pose."""
        if self._q_stacked is None:
            return None
        frame_id = (self._frame_id, self.display_mode)
        if self._geometry is None or self._geometry[0] != frame_id:
            if self._uncalibrated is not None:
                q_sensors = {sensor: self._q[segment] for sensor, segment in self._uncalibrated.items()
                             if segment in self._q}
                geometry = self.builder.build_outline(q_sensors, self._uncalibrated)
            else:
                geometry = self._build(self._q_stacked, heading_ref_rad)
            self._geometry = (frame_id, geometry)
        return self._geometry

    def figure_of(self, q_world_from_segment: Mapping[str, np.ndarray],
                  heading_ref_rad: float | None = None) -> FigureGeometry | None:
        """The figure of another pose (segment → (4,)) standing where the newest pose stands, in
        the same display mode (the simulator's truth beside the estimate); ``None`` before the
        first pose, before a body calibration (there is no estimated pose to compare) or when it
        lacks a segment of the model."""
        if self._q_stacked is None or self._uncalibrated is not None:
            return None
        if any(name not in q_world_from_segment for name in self.model.segment_names):
            return None
        q = np.array([q_world_from_segment[name] for name in self.model.segment_names], dtype=float)
        return self._build(q, heading_ref_rad)

    def _build(self, q_stacked: np.ndarray, heading_ref_rad: float | None) -> FigureGeometry:
        proximal, distal = skeleton.forward_kinematics_stacked(self.model, q_stacked, self.height_m, self._root_m)
        return self.builder.build_arrays(proximal, distal, q_stacked, mode=self.display_mode,
                                         heading_ref_rad=heading_ref_rad)

    # -- joint angles --------------------------------------------------------------------------
    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(self._columns)

    def joint_columns(self, joint: str) -> tuple[str, str, str]:
        """The three angle column names of ``joint`` (meaning and ``_deg`` unit in the name)."""
        return self._columns[joint]

    def joint_series(self, joint: str, window_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Last ``window_s`` seconds of ``joint``'s angles: ``t_s`` (N,), ``angles_deg`` (N,3)
        in the order of :meth:`joint_columns`."""
        self._flush_angles()
        buffer = self._angles[joint]
        if not len(buffer):
            return np.zeros(0), np.zeros((0, 3))
        return buffer.since(buffer.latest()[0] - window_s)

    def _flush_angles(self) -> None:
        """Joint angles of the poses since the last call, computed in one vectorised batch."""
        if not self._pending:
            return
        pending, self._pending = self._pending, []
        t = np.array([p[0] for p in pending])
        q = np.array([p[1] for p in pending]).transpose(1, 0, 2)  # (S, P, 4), segments in model order
        angles = skeleton.joint_angles_deg_stacked(self.model, q)  # (J, P, 3) in column order
        for joint, row in self._joint_row.items():
            self._angles[joint].append(t, angles[row])
