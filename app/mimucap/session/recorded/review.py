"""Review of a recorded session: poses and joint angles on a timeline, and a play head (no Qt).

:func:`load_review` opens a session file (recovering an interrupted recording first, via
:func:`mimucap.session.live.recorder.open_session`) and runs it, once, through the one processing
path (:func:`mimucap.session.recorded.reprocessing.process_session`) with the calibrations the recording
stores, or a body calibration file given in place of its own
(:func:`mimucap.session.recorded.calibration_choice.applied_calibrations`, the choice every consumer makes). Two results exist: *as seen live* (:data:`~mimucap.core.pipeline.settings.RESULT_LIVE`, the
forward filter continuing from the state the live view had, which reproduces what was shown)
and *reprocessed* (:data:`~mimucap.core.pipeline.settings.RESULT_REPROCESSED`, smoothed with past and
future data; the default). The review holds:

* segment orientations ``q_world_from_segment`` (T, 4) (world ENU, scalar first) on the pose
  instants ``t_s`` (T,) (seconds since the recording started);
* joint angles (deg) of every joint, :func:`mimucap.core.skeleton.joint_angles_deg`, and
  where each may be wrong (:mod:`mimucap.core.pipeline.doubt_reasons`).

A simulated recording's ground truth is kept beside them (``truth``) for the on-screen
comparison only; it never replaces the estimate.

:class:`ReviewPlayer` holds the play head (``cursor_s``), play/pause, speed and the display
mode; it offers the same plot-source methods and events (``data``, ``frame``, ``truth_frame``)
as the live session, with windows that end at the play head.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mimucap.core import bodycal, rotation, skeleton
from mimucap.core.clinical_names import joint_name
from mimucap.core.pipeline import doubt_reasons
from mimucap.core.pipeline.segments import assignment_of
from mimucap.core.pipeline.recording import POSE_BODY_CALIBRATION, POSE_SENSOR_AXES
from mimucap.core.pipeline.settings import RESULT_LABELS, RESULT_REPROCESSED
from mimucap.core.root_position import root_positions
from mimucap.io.session import Marker, Session, SessionTruth
from mimucap.session.recorded.calibration_choice import AppliedCalibrations, applied_calibrations
from mimucap.session.angle_accuracy import angle_errors
from mimucap.session.events import EmitterGroup
from mimucap.core.heading_modes import MODE_COUPLED
from mimucap.session.views.skeleton_figure import FigureBuilder, FigureGeometry, bodycal_heading, emit_pose_figures
from mimucap.session.views.live_pose import joint_column_groups
from mimucap.session.recorded.reprocessing import process_session
from mimucap.session.recorded.stored_processing import recorded_processing, session_model
from mimucap.session.recorded.provenance import Provenance, heading_lines, provenance
from mimucap.session.live.recorder import open_session

__all__ = ["POSE_BODY_CALIBRATION", "POSE_SENSOR_AXES", "ReviewData", "ReviewPlayer", "SPEEDS", "build_review",
           "require_body_calibration",
           "load_review"]

#: Playback speeds offered (× real time).
SPEEDS = (0.25, 0.5, 1.0, 2.0, 4.0)


@dataclass
class ReviewData:
    """Everything the review shows, computed once (see the module doc).

    ``result`` is :data:`~mimucap.core.pipeline.settings.RESULT_LIVE` or
    :data:`~mimucap.core.pipeline.settings.RESULT_REPROCESSED`; ``missing`` says what an older recording
    does not store; ``truth`` is the simulator's ground truth (evaluation only) or None.
    """

    path: Path
    session: Session
    model: skeleton.SkeletonModel
    height_m: float
    t_s: np.ndarray                                  #: (T,) pose times, s
    q_world_from_segment: dict[str, np.ndarray]      #: segment → (T, 4)
    root_position_m: np.ndarray | None               #: (T, 3) world, from the feet's contact (core.root_position)
    angles_deg: dict[str, np.ndarray]                #: column → (T,)
    pose_source: str
    heading_ref_rad: float | None
    q_world_from_sensor: dict[str, np.ndarray]       #: sensor → (N, 4) on that sensor's t_s
    result: str = RESULT_REPROCESSED
    calibrations: AppliedCalibrations = field(default_factory=AppliedCalibrations)
    missing: list[str] = field(default_factory=list)
    #: joint → (T,) the reasons its angles may be wrong (``uint16`` bits of :mod:`mimucap.core.pipeline.doubt_reasons`)
    joint_doubt: dict[str, np.ndarray] = field(default_factory=dict)
    #: where the headings came from: the mode and sensor → (T,) the source at each pose
    #: (:mod:`mimucap.core.heading_sources`)
    heading_mode: str = MODE_COUPLED
    heading_source: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def body_calibration(self) -> bodycal.BodyCalibration | None:
        """The body calibration the processing applied, or None."""
        return self.calibrations.body

    @property
    def provenance(self) -> Provenance:
        """What this result holds, as every output says it (:mod:`mimucap.session.recorded.provenance`)."""
        return provenance(source_file=self.path.name, result=self.result, calibrations=self.calibrations,
                          model=self.model, height_m=self.height_m, metadata=self.session.metadata,
                          headings=heading_lines(self.heading_mode, self.heading_source))

    @property
    def result_label(self) -> str:
        return RESULT_LABELS[self.result]

    @property
    def truth(self) -> SessionTruth | None:
        return self.session.truth

    def truth_errors(self) -> dict[str, float]:
        """RMS error (deg) of each joint-angle column against the simulator's truth over the
        whole recording (empty without truth): the review's accuracy check."""
        truth = self.truth
        if truth is None or not len(self.t_s):
            return {}
        found = angle_errors(self.t_s, self.angles_deg, truth.t_s, truth.joint_angles_deg)
        return {column: error.rms_deg for column, error in found.items()}

    @property
    def markers(self) -> list[Marker]:
        return list(self.session.markers)

    @property
    def start_s(self) -> float:
        return float(self.t_s[0]) if len(self.t_s) else 0.0

    @property
    def end_s(self) -> float:
        return float(self.t_s[-1]) if len(self.t_s) else 0.0


def build_review(path: str | Path, session: Session, progress: Callable[[float], None] | None = None,
                 result: str = RESULT_REPROCESSED, calibrations: AppliedCalibrations | None = None,
                 heading: str | None = None) -> ReviewData:
    """Compute the review of ``session`` (read from ``path``) as ``result`` with
    ``calibrations`` (the session's own choice,
    :func:`mimucap.session.recorded.calibration_choice.applied_calibrations`, when None) and the heading mode
    ``heading`` (:data:`~mimucap.core.heading_modes.MODES`; the recording's when None);
    ``progress(fraction)`` is called as the work advances."""
    report = progress or (lambda fraction: None)
    model, height = session_model(session)
    report(0.1)
    recorded = recorded_processing(session, origin=str(path))
    if calibrations is None:
        calibrations = applied_calibrations(session, origin=str(path))
    output = process_session(session, result=result, calibrations=calibrations, recorded=recorded, model=model,
                             heading=heading)
    report(0.9)
    if not len(output.t_s):
        reasons = "; ".join(output.problems) or "no sensor is assigned to a segment and none is calibrated"
        raise ValueError(f"{path}: nothing to review ({reasons})")
    body = calibrations.body
    heading_ref = None if body is None else bodycal_heading(body)
    report(1.0)
    q_stacked = np.stack([output.q_world_from_segment[name] for name in model.segment_names])
    root = root_positions(model, height, q_stacked)
    return ReviewData(Path(path), session, model, height, output.t_s, output.q_world_from_segment, root,
                      output.angles_deg, output.pose_source, heading_ref, output.q_world_from_sensor,
                      result=output.result, calibrations=calibrations,
                      missing=list(recorded.missing) + list(calibrations.notes) + list(output.problems),
                      joint_doubt=output.joint_doubt, heading_mode=output.heading_mode,
                      heading_source=output.heading_source)


def load_review(path: str | Path, progress: Callable[[float], None] | None = None,
                result: str = RESULT_REPROCESSED, calibration_file: str | Path | None = None,
                mag_files: Sequence[str | Path] = (), heading: str | None = None) -> ReviewData:
    """Open session file ``path`` (recovering it first if needed) and build its review, with
    the body calibration of ``calibration_file`` (a ``CAL.json`` of ``mimucap bodycal``) in
    place of the stored one when given, the magnetometer calibration files ``mag_files`` and
    the heading mode ``heading`` (the recording's when None)."""
    session = open_session(path)
    body = None
    if calibration_file is not None:
        from mimucap.io.body_calibration_file import read_body_calibration

        body, _document = read_body_calibration(calibration_file)
    calibrations = applied_calibrations(session, body=body, body_origin=str(calibration_file or ""),
                                        mag_files=mag_files, origin=str(path))
    return build_review(path, session, progress, result, calibrations, heading)


def require_body_calibration(review: ReviewData, what: str) -> None:
    """``ValueError`` naming ``--calibration`` when ``review`` has no body calibration: without
    one the sensors' axes stand for the segments, and ``what`` (e.g. "a report") would be
    computed from numbers that mean nothing."""
    if review.body_calibration is None:
        raise ValueError(f"{review.path}: the session stores no body calibration, and {what} needs one (joint "
                         "angles, range of motion, turns and stride length mean nothing without it): give "
                         "--calibration CAL.json (made by mimucap bodycal)")


class ReviewPlayer:
    """Play head over a :class:`ReviewData` (see the module doc).

    Events (``self.events``), emitted by whoever moves the play head (:meth:`seek`,
    :meth:`advance` from the review's play clock, :meth:`set_display_mode`):
    ``data(cursor_s)`` the play head moved (s of the recording; the plots' windows end there);
    ``frame(frame_id, geometry)`` the pose shown changed (another pose instant or display mode;
    built only while someone listens; the last event of a move); ``truth_frame(frame_id,
    geometry_or_None)`` just before each ``frame`` while someone listens, the simulator's true
    pose there (evaluation only).
    """

    def __init__(self, data: ReviewData) -> None:
        self.data = data
        self.events = EmitterGroup("data", "frame", "truth_frame")
        self._shown_frame_id: object = None
        self.model = data.model
        self.height_m = data.height_m
        self.builder = FigureBuilder(data.model, data.height_m)
        self.display_mode = "world"
        self.speed = 1.0
        self.playing = False
        self._cursor = data.start_s
        self._geometry: tuple[object, FigureGeometry] | None = None
        self._truth_geometry: tuple[object, FigureGeometry] | None = None
        self._columns = {joint: cols for joint, cols in joint_column_groups(self.model).items()
                         if all(c in data.angles_deg for c in cols)}
        self._doubt_spans: dict[str, list[tuple[float, float, int]]] = {}  # joint → spans, found once
        # without a body calibration each sensor's axes stand in for its segment's (the outline)
        self._worn = assignment_of(None, data.session.sensor_segments()) if data.body_calibration is None else {}

    # -- play head ---------------------------------------------------------------------------
    @property
    def cursor_s(self) -> float:
        return self._cursor

    @property
    def pose_source(self) -> str:
        return self.data.pose_source

    def seek(self, t_s: float) -> float:
        """Move the play head to ``t_s`` (clamped to the recording); returns where it is."""
        self._cursor = float(min(max(t_s, self.data.start_s), self.data.end_s))
        self._moved()
        return self._cursor

    def _moved(self) -> None:
        """Tell the listeners the play head moved, and the new pose when it changed."""
        self.events.data.emit(self._cursor)
        if not len(self.data.t_s):
            return
        frame_id = (self.index(), self.display_mode)
        if frame_id == self._shown_frame_id:
            return
        self._shown_frame_id = frame_id
        emit_pose_figures(self)

    def publish(self) -> None:
        """Emit the events for the play head where it is (for listeners that just subscribed)."""
        self._shown_frame_id = None
        self._moved()

    def seek_marker(self, index: int) -> float:
        """Move the play head to marker ``index`` (in the session's order)."""
        markers = self.data.markers
        if not 0 <= index < len(markers):
            raise ValueError(f"marker {index} does not exist (the session has {len(markers)})")
        return self.seek(markers[index].t_s)

    def set_speed(self, speed: float) -> None:
        if not speed > 0:
            raise ValueError(f"playback speed must be positive, got {speed}")
        self.speed = float(speed)

    def play(self) -> None:
        if self._cursor >= self.data.end_s:
            self.seek(self.data.start_s)
        self.playing = True

    def pause(self) -> None:
        self.playing = False

    def advance(self, wall_s: float) -> float:
        """Move the play head by ``wall_s × speed`` while playing (stops at the end)."""
        if self.playing:
            self.seek(self._cursor + wall_s * self.speed)
            if self._cursor >= self.data.end_s:
                self.playing = False
        return self._cursor

    def index(self) -> int:
        """Pose index shown at the play head."""
        t = self.data.t_s
        return int(np.clip(np.searchsorted(t, self._cursor, side="right") - 1, 0, len(t) - 1))

    def set_display_mode(self, mode: str) -> None:
        self.builder.display_alpha(mode, rotation.identity(), 0.0)
        self.display_mode = mode
        self._geometry = None
        self._moved()

    def frame(self) -> tuple[object, FigureGeometry] | None:
        if not len(self.data.t_s):
            return None
        i = self.index()
        frame_id = (i, self.display_mode)
        if self._geometry is None or self._geometry[0] != frame_id:
            q = {s: v[i] for s, v in self.data.q_world_from_segment.items()}
            if self.data.body_calibration is None:
                geometry = self.builder.build_outline({sensor: q[segment] for sensor, segment in self._worn.items()
                                                       if segment in q}, self._worn)
            else:
                root = None if self.data.root_position_m is None else self.data.root_position_m[i]
                poses = skeleton.forward_kinematics(self.model, q, self.height_m, root)
                geometry = self.builder.build(poses, mode=self.display_mode, heading_ref_rad=self.data.heading_ref_rad)
            self._geometry = (frame_id, geometry)
        return self._geometry

    def truth_frame(self) -> tuple[object, FigureGeometry] | None:
        """``(frame_id, geometry)`` of the simulator's true pose at the play head, standing
        where the estimate stands (the ghost figure); ``None`` without truth, or without a body
        calibration (the outline is no estimated pose to compare). Evaluation only."""
        truth = self.data.truth
        if truth is None or not len(self.data.t_s) or not len(truth.t_s) or self.data.body_calibration is None:
            return None
        if any(name not in truth.q_world_from_segment for name in self.model.segment_names):
            return None
        i = self.index()
        t = self.data.t_s[i]
        k = int(np.clip(np.searchsorted(truth.t_s, t - 1e-9), 0, len(truth.t_s) - 1))
        frame_id = ("truth", i, self.display_mode)
        if self._truth_geometry is None or self._truth_geometry[0] != frame_id:
            q = {s: np.asarray(truth.q_world_from_segment[s][k], dtype=float) for s in self.model.segment_names}
            root = None if self.data.root_position_m is None else self.data.root_position_m[i]
            poses = skeleton.forward_kinematics(self.model, q, self.height_m, root)
            geometry = self.builder.build(poses, mode=self.display_mode, heading_ref_rad=self.data.heading_ref_rad)
            self._truth_geometry = (frame_id, geometry)
        return self._truth_geometry

    def truth_joint_series(self, joint: str, window_s: float):
        """The simulator's true angles of ``joint`` over the window ending at the play head (as
        :meth:`joint_series`; empty without truth). Evaluation only."""
        truth = self.data.truth
        columns = self._columns.get(joint)
        if truth is None or columns is None or any(c not in truth.joint_angles_deg for c in columns):
            return np.zeros(0), np.zeros((0, 3))
        t = np.asarray(truth.t_s)
        a, b = np.searchsorted(t, [self._cursor - window_s, self._cursor], side="right")
        return t[a:b], np.stack([np.asarray(truth.joint_angles_deg[c])[a:b] for c in columns], axis=-1)

    # -- plot source -------------------------------------------------------------------------
    @property
    def sensor_ids(self) -> tuple[str, ...]:
        return tuple(self.data.session.sensors)

    @property
    def sensor_segments(self) -> dict[str, str]:
        """Sensor id → the segment it was worn on in the recording."""
        return {sid: s.segment for sid, s in self.data.session.sensors.items() if s.segment}

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(self._columns)

    def joint_columns(self, joint: str) -> tuple[str, str, str]:
        return self._columns[joint]

    def series(self, sensor_id: str, window_s: float):
        stream = self.data.session.sensors[sensor_id]
        t = stream.t_s
        a, b = np.searchsorted(t, [self._cursor - window_s, self._cursor], side="right")
        empty = np.full((b - a, 3), np.nan)
        pick = (lambda v: empty if v is None else v[a:b])
        return t[a:b], pick(stream.acc), pick(stream.gyr), pick(stream.mag_uT)

    def joint_series(self, joint: str, window_s: float):
        t = self.data.t_s
        a, b = np.searchsorted(t, [self._cursor - window_s, self._cursor], side="right")
        columns = self._columns[joint]
        return t[a:b], np.stack([self.data.angles_deg[c][a:b] for c in columns], axis=-1)

    def doubt_spans(self, joint: str, window_s: float) -> list[tuple[float, float]]:
        """The spans ``(start_s, end_s)`` in the window ending at the play head where
        ``joint``'s angles are doubtful (:mod:`mimucap.core.pipeline.doubt_reasons`): the plots shade them."""
        return [(max(a, self._cursor - window_s), min(b, self._cursor))
                for a, b, _r in self._spans(joint) if b >= self._cursor - window_s and a <= self._cursor]

    def _spans(self, joint: str) -> list[tuple[float, float, int]]:
        if joint not in self._doubt_spans:
            reasons = self.data.joint_doubt.get(joint)
            self._doubt_spans[joint] = [] if reasons is None else doubt_reasons.spans(self.data.t_s, reasons, join_s=0.0)
        return self._doubt_spans[joint]

    def doubtful_spans(self) -> list[tuple[float, float]]:
        """The spans ``(start_s, end_s)`` of the whole recording where any joint's angles are
        doubtful (the timeline shades them)."""
        if not self.data.joint_doubt or not len(self.data.t_s):
            return []
        any_joint = np.logical_or.reduce([np.asarray(r) != 0 for r in self.data.joint_doubt.values()])
        return [(a, b) for a, b, _r in doubt_reasons.spans(self.data.t_s, any_joint.astype(np.uint16), join_s=0.0)]

    def doubt_here(self) -> str:
        """Which joints' angles are doubtful at the play head, and why, in words ("" when none)."""
        if not len(self.data.t_s):
            return ""
        i = self.index()
        by_reason: dict[int, list[str]] = {}
        for joint, reasons in self.data.joint_doubt.items():
            if reasons[i]:
                by_reason.setdefault(int(reasons[i]), []).append(joint_name(joint))
        return "; ".join(f"{', '.join(joints)}: {doubt_reasons.describe(bits)}" for bits, joints in by_reason.items())
