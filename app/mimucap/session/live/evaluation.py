"""The live session's evaluation against the simulator's truth (no Qt): evaluation only, it never
drives the figure, the plots' estimate, a recording's numbers or a calibration.

The simulated suit knows its subject's true pose and joint angles (``feed.last_truth``, a
:class:`~mimucap.core.simulate.truth.SuitTruth`); a source of real sensors knows none.
:class:`LiveEvaluation` takes each new block of that truth (:meth:`LiveEvaluation.take`) and
offers it beside the estimate: the true pose as a ghost figure standing where the estimate
stands (:meth:`LiveEvaluation.truth_frame`), the true joint angles as dashed curves (kept in the
plot history), and the running error of the estimated joint angles against them
(:meth:`LiveEvaluation.truth_errors`, :mod:`mimucap.session.angle_accuracy`).

Events (``events``, :class:`~mimucap.session.events.EmitterGroup`):

* ``available(bool)``: the source's truth became known (:attr:`LiveEvaluation.has_truth`);
* ``truth_frame(frame_id, geometry_or_None)``: the ghost figure, with each new pose while
  someone listens, just before the pose part's ``frame``;
* ``errors(column → RMS deg)``: the running flexion error over :data:`TRUTH_ERROR_WINDOW_S`,
  at the status rate while someone listens (sources with truth).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from mimucap.core.simulate.truth import SuitTruth
from mimucap.session.angle_accuracy import FLEXION_COLUMNS, angle_errors
from mimucap.session.events import EmitterGroup
from mimucap.session.live.plot_history import PlotHistory
from mimucap.session.views.live_pose import LivePose
from mimucap.session.views.skeleton_figure import FigureGeometry

#: Where a recording's ground truth came from (stored with it, for evaluation).
TRUTH_NOTE = "simulated suit shown live in mimucap gui"
#: Window (s) of the running error against the simulator's truth (the on-screen accuracy check).
TRUTH_ERROR_WINDOW_S = 5.0


class LiveEvaluation:
    """The simulator's truth beside the estimate of ``pose`` (the figure) and ``history`` (the
    joint angles) (see the module doc); ``heading_ref_rad()``: the heading the body display mode
    turns to face the camera (the body calibration's N-pose), which the ghost shares.
    ``truth_columns``: the joint-angle columns of the running error (flexion: the accuracy
    check the status bar shows)."""

    def __init__(self, pose: LivePose, history: PlotHistory, heading_ref_rad: Callable[[], float | None],
                 truth_columns=FLEXION_COLUMNS) -> None:
        self._pose = pose
        self._heading_ref_rad = heading_ref_rad
        self._history = history
        self.truth_columns = tuple(truth_columns)
        self.events = EmitterGroup("available", "truth_frame", "errors")
        self._last: SuitTruth | None = None     # the truth block last taken
        #: newest pose of the simulator's truth (segment → (4,))
        self._truth_pose: dict[str, np.ndarray] | None = None
        self._geometry: tuple[object, FigureGeometry] | None = None

    def take(self, truth: SuitTruth | None, t_s: np.ndarray | None) -> bool:
        """The source's newest truth block (``None``: none) at session times ``t_s``; returns
        whether it is new."""
        if truth is None or truth is self._last:
            return False
        first = self._truth_pose is None
        self._truth_pose = {name: q[-1] for name, q in truth.q_world_from_segment.items()}
        self._last = truth
        if first:
            self.events.available.emit(True)
        self._history.take_truth(t_s, truth.joint_angles_deg)
        return True

    @property
    def has_truth(self) -> bool:
        """Whether the source knows the true pose (the simulated suit)."""
        return self._truth_pose is not None

    def truth_pose(self) -> dict[str, np.ndarray] | None:
        """The simulated subject's true segment orientations now (segment → (4,)), or ``None``
        for a source without truth. For evaluation: shown beside the estimate, never as it."""
        return self._truth_pose

    def truth_frame(self) -> tuple[object, FigureGeometry] | None:
        """``(frame_id, geometry)`` of the simulator's true pose, standing where the estimate
        stands (the ghost figure); ``None`` for a source without truth or before the first
        estimated pose."""
        truth = self._truth_pose
        if truth is None:
            return None
        frame_id = ("truth", self._pose.frame_id, self._pose.display_mode)
        if self._geometry is None or self._geometry[0] != frame_id:
            geometry = self._pose.figure_of(truth, self._heading_ref_rad())
            if geometry is None:
                return None
            self._geometry = (frame_id, geometry)
        return self._geometry

    def forget_figure(self) -> None:
        """The figure changed (a new pose, display mode or height): the ghost is built anew."""
        self._geometry = None

    def truth_errors(self, window_s: float = TRUTH_ERROR_WINDOW_S, columns=None) -> dict[str, float]:
        """RMS error (deg) of each joint-angle column (or only of ``columns``) against the
        simulator's truth over the last ``window_s`` seconds (empty for a source without truth)."""
        errors: dict[str, float] = {}
        if not self.has_truth:
            return errors
        wanted = None if columns is None else set(columns)
        for joint in self._history.joint_names:
            joint_columns = self._history.joint_columns(joint)
            if wanted is not None and wanted.isdisjoint(joint_columns):
                continue
            t, estimate = self._history.joint_series(joint, window_s)
            t_true, true = self._history.truth_joint_series(joint, window_s + 1.0)
            if not len(t) or len(t_true) < 2:
                continue
            found = angle_errors(t, dict(zip(joint_columns, estimate.T)), t_true, dict(zip(joint_columns, true.T)))
            errors.update({column: error.rms_deg for column, error in found.items()})
        return errors

    def publish_errors(self) -> None:
        """Emit ``errors`` when the source has truth and someone listens (the status rate)."""
        if self.has_truth and self.events.errors.callbacks:
            self.events.errors.emit(self.truth_errors(TRUTH_ERROR_WINDOW_S, self.truth_columns))
