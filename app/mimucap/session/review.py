"""Review of a recorded session: poses and joint angles on a timeline, and a play head (no Qt).

:func:`load_review` opens a session file (recovering an interrupted recording first, via
:func:`mimucap.session.recording.open_session`) and computes, once, what the review shows:

* segment orientations ``q_world_from_segment`` (T, 4) (world ENU, scalar first) on the pose
  time grid ``t_s`` (T,) (seconds since the recording started), from, in this order of
  preference: the simulator's truth stored in the file (``"simulator truth"``); the body
  calibration stored with the recording applied to each sensor's orientation (on-board, or
  fused offline with :func:`mimucap.core.fusion.fuse`) (``"body calibration"``); each
  assigned sensor's orientation as its segment's (``"sensor axes (no body calibration)"``);
* joint angles (deg) of every joint, :func:`mimucap.core.skeleton.joint_angles_deg`.

:class:`ReviewPlayer` holds the play head (``cursor_s``), play/pause, speed and the display
mode; it offers the same plot-source methods as the live session, with windows that end
at the play head.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mimucap.core import bodycal, rotation, skeleton
from mimucap.core.fusion import fuse
from mimucap.io.session import Marker, Session
from mimucap.session.figure import FigureBuilder, FigureGeometry, heading_rad
from mimucap.session.recording import open_session

POSE_SIMULATOR_TRUTH = "simulator truth"
POSE_BODY_CALIBRATION = "body calibration"
POSE_SENSOR_AXES = "sensor axes (no body calibration)"
#: Playback speeds offered (× real time).
SPEEDS = (0.25, 0.5, 1.0, 2.0, 4.0)


@dataclass
class ReviewData:
    """Everything the review shows, computed once (see the module doc)."""

    path: Path
    session: Session
    model: skeleton.SkeletonModel
    height_m: float
    t_s: np.ndarray                                  #: (T,) pose times, s
    q_world_from_segment: dict[str, np.ndarray]      #: segment → (T, 4)
    root_position_m: np.ndarray | None               #: (T, 3) world, or None (model default)
    angles_deg: dict[str, np.ndarray]                #: column → (T,)
    pose_source: str
    heading_ref_rad: float | None
    q_world_from_sensor: dict[str, np.ndarray]       #: sensor → (N, 4) on that sensor's t_s

    @property
    def markers(self) -> list[Marker]:
        return list(self.session.markers)

    @property
    def start_s(self) -> float:
        return float(self.t_s[0]) if len(self.t_s) else 0.0

    @property
    def end_s(self) -> float:
        return float(self.t_s[-1]) if len(self.t_s) else 0.0


def _sensor_orientations(session: Session) -> dict[str, np.ndarray]:
    result = {}
    for sensor_id, stream in session.sensors.items():
        if len(stream.t_s) == 0:
            continue
        if stream.q_world_from_sensor is not None:
            result[sensor_id] = np.asarray(stream.q_world_from_sensor, dtype=float)
        elif stream.gyr is not None:
            result[sensor_id] = fuse(stream.t_s, stream.gyr, stream.acc, stream.mag_uT).q_world_from_sensor
    return result


def _nearest(t_from: np.ndarray, values: np.ndarray, t_to: np.ndarray) -> np.ndarray:
    """``values`` sampled at ``t_from`` picked at the nearest earlier-or-equal time of ``t_to``."""
    index = np.clip(np.searchsorted(t_from, t_to, side="right") - 1, 0, len(t_from) - 1)
    return values[index]


def _body_calibration(session: Session) -> bodycal.BodyCalibration | None:
    data = session.calibrations.get("body") or session.metadata.get("body_calibration")
    if not data:
        return None
    return bodycal.BodyCalibration.from_dict(data, origin="the session's body calibration")


def build_review(path: str | Path, session: Session, progress: Callable[[float], None] | None = None) -> ReviewData:
    """Compute the review of ``session`` (read from ``path``); ``progress(fraction)`` is
    called as the work advances."""
    report = progress or (lambda fraction: None)
    meta = session.metadata
    model = skeleton.load_model(str(meta.get("skeleton_model") or "ten_segment"))
    subject = meta.get("subject") or {}
    height = float(meta.get("height_m") or subject.get("height_m") or 1.75)
    report(0.1)
    q_sensor = _sensor_orientations(session)
    report(0.6)
    order = [(s.name, s.parent) for s in model.segments]
    root = None
    heading_ref = None
    truth = session.truth
    calibration = _body_calibration(session)
    if truth is not None and all(s in truth.q_world_from_segment for s in model.segment_names):
        t = np.asarray(truth.t_s, dtype=float)
        q_segments = {s: np.asarray(truth.q_world_from_segment[s], dtype=float) for s in model.segment_names}
        root_data = truth.extra.get("root_position_m")
        root = None if root_data is None else np.asarray(root_data, dtype=float)
        source = POSE_SIMULATOR_TRUTH
    else:
        streams = {sid: s for sid, s in session.sensors.items() if sid in q_sensor}
        if not streams:
            raise ValueError(f"{path}: no sensor orientations to review (no gyroscope or orientation data)")
        if calibration is not None:
            mapping = dict(calibration.sensors)
            source = POSE_BODY_CALIBRATION
            heading_ref = heading_rad(np.asarray(calibration.q_world_from_body, dtype=float))
        else:
            mapping = {stream.segment: sid for sid, stream in streams.items() if stream.segment}
            source = POSE_SENSOR_AXES
        root_sensor = mapping.get(model.root)
        grid_sensor = root_sensor if root_sensor in streams else next(iter(streams))
        t = np.asarray(streams[grid_sensor].t_s, dtype=float)
        picked = {sid: _nearest(streams[sid].t_s, q_sensor[sid], t) for sid in mapping.values() if sid in streams}
        if calibration is not None:
            found = bodycal.segment_orientations(calibration, picked, require_all=False)
        else:
            found = {seg: picked[sid] for seg, sid in mapping.items() if sid in picked}
        valid = np.all(np.isfinite(np.stack([q for q in found.values()], axis=0)), axis=(0, 2)) if found else None
        if found:
            t = t[valid]
            found = {k: v[valid] for k, v in found.items()}
        if model.root not in found:
            found[model.root] = np.broadcast_to(skeleton.q_world_from_body_facing(0.0), (len(t), 4)).copy()
        q_segments = bodycal.fill_missing_segments(found, order)
    report(0.8)
    angles = skeleton.joint_angles_deg(model, q_segments) if len(t) else {}
    report(1.0)
    return ReviewData(Path(path), session, model, height, t, q_segments, root, angles, source, heading_ref, q_sensor)


def load_review(path: str | Path, progress: Callable[[float], None] | None = None) -> ReviewData:
    """Open session file ``path`` (recovering it first if needed) and build its review."""
    session = open_session(path)
    return build_review(path, session, progress)


class ReviewPlayer:
    """Play head over a :class:`ReviewData` (see the module doc)."""

    def __init__(self, data: ReviewData) -> None:
        self.data = data
        self.model = data.model
        self.height_m = data.height_m
        self.builder = FigureBuilder(data.model, data.height_m)
        self.display_mode = "world"
        self.speed = 1.0
        self.playing = False
        self._cursor = data.start_s
        self._geometry: tuple[object, FigureGeometry] | None = None
        self._columns = {}
        columns = skeleton.joint_angle_columns(self.model)
        for joint in self.model.joint_names:
            cols = tuple(c for c in columns if c.startswith(joint + "_"))[:3]
            if len(cols) == 3 and all(c in data.angles_deg for c in cols):
                self._columns[joint] = cols

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
        return self._cursor

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
            self._cursor = self.data.start_s
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

    def frame(self) -> tuple[object, FigureGeometry] | None:
        if not len(self.data.t_s):
            return None
        i = self.index()
        frame_id = (i, self.display_mode)
        if self._geometry is None or self._geometry[0] != frame_id:
            q = {s: v[i] for s, v in self.data.q_world_from_segment.items()}
            root = None if self.data.root_position_m is None else self.data.root_position_m[i]
            poses = skeleton.forward_kinematics(self.model, q, self.height_m, root)
            geometry = self.builder.build(poses, mode=self.display_mode, heading_ref_rad=self.data.heading_ref_rad)
            self._geometry = (frame_id, geometry)
        return self._geometry

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
