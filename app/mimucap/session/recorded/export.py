"""Exports of a reviewed session: joint angles (CSV, OpenSim ``.mot``), per-sensor raw data and
orientations (CSV), a per-joint summary (min, max, range of motion) as CSV, and the motion as
C3D, BVH and an OpenSense orientation table (:func:`write_motion_file`). This module decides
what goes into which file (the range, the rows, the header notes); the files are written by
``io``: :mod:`mimucap.io.angles_export` (angles and their summary), :mod:`mimucap.io.sensor_csv`,
:mod:`mimucap.io.c3d_export`, :mod:`mimucap.io.bvh` and :mod:`mimucap.io.opensense`.

The time range is ``[t_from_s, t_to_s]`` in session seconds, or the span between two markers
(:func:`marker_range`). Joint angle files use :mod:`mimucap.io.angles_export` (their header
names the sequence, every column's meaning, unit and sign). :func:`run_export` reports its
progress as a fraction in [0, 1] and can run off the GUI thread.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mimucap.core import rotation
from mimucap.io import sensor_csv
from mimucap.io.angles_export import (
    SummaryRow, marker_lines, write_angles_csv, write_angles_mot, write_summary_csv,
)
from mimucap.io.session import Marker
from mimucap.session.recorded.review import ReviewData


def check_export_range(t_from_s: float, t_to_s: float) -> None:
    """``ValueError`` unless ``t_from_s`` .. ``t_to_s`` (s) is finite and ends after it starts."""
    if not (np.isfinite(t_from_s) and np.isfinite(t_to_s)) or t_to_s <= t_from_s:
        raise ValueError(f"export range must have its end after its start, got {t_from_s:.3f}..{t_to_s:.3f} s")


@dataclass(frozen=True)
class ExportRequest:
    """What to export.

    ``base_path``: files are ``<base>.csv``, ``<base>.mot``, ``<base>_summary.csv``,
    ``<base>_<sensor>.csv``; ``t_from_s``/``t_to_s`` the range (s); ``angles_csv``,
    ``angles_mot``, ``sensors_csv`` (raw acc m/s², gyr rad/s, mag µT and ``q_world_from_sensor``
    per sensor), ``summary_csv`` choose the files; ``opensim_mot`` (``<base>_opensim.mot``, joint
    angles named as OpenSim coordinates), ``c3d`` (``<base>.c3d``), ``bvh`` (``<base>.bvh``) and
    ``opensense_sto`` (``<base>_orientations.sto``) the motion files; ``events`` gait events
    ``(t_s, context, label)`` (context ``Left``, ``Right`` or ``General``) that go with them.
    """

    base_path: Path
    t_from_s: float
    t_to_s: float
    angles_csv: bool = True
    angles_mot: bool = True
    sensors_csv: bool = False
    summary_csv: bool = True
    opensim_mot: bool = False
    c3d: bool = False
    bvh: bool = False
    opensense_sto: bool = False
    events: tuple[tuple[float, str, str], ...] = ()

    def __post_init__(self) -> None:
        check_export_range(self.t_from_s, self.t_to_s)
        if not (self.angles_csv or self.angles_mot or self.sensors_csv or self.summary_csv or self.opensim_mot
                or self.c3d or self.bvh or self.opensense_sto):
            raise ValueError("choose at least one file to export")


@dataclass
class ExportResult:
    files: list[Path] = field(default_factory=list)
    summary: list[SummaryRow] = field(default_factory=list)
    rows: int = 0


def marker_at(markers: Sequence[Marker], index: int) -> Marker:
    """Marker ``index`` of ``markers``; ``ValueError`` when there is no such marker."""
    if not 0 <= index < len(markers):
        raise ValueError(f"marker {index} does not exist (the session has {len(markers)})")
    return markers[index]


def marker_range(markers: Sequence[Marker], first: int, second: int) -> tuple[float, float]:
    """The time span (s) between markers ``first`` and ``second`` (indices, either order);
    ``ValueError`` when one does not exist or both are at one time."""
    a, b = sorted((marker_at(markers, first).t_s, marker_at(markers, second).t_s))
    if b <= a:
        names = (f"'{markers[first].label}'" if first == second else
                 f"'{markers[first].label}' and '{markers[second].label}'")
        raise ValueError(f"choose two different markers: {names} "
                         f"{'is one marker' if first == second else 'are at the same time'} ({a:.2f} s)")
    return float(a), float(b)


def angles_in_range(data: ReviewData, t_from_s: float, t_to_s: float) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Pose times (s) and joint angle columns (deg) with ``t_from_s <= t <= t_to_s``."""
    keep = _in_range(data, t_from_s, t_to_s)
    return data.t_s[keep], {c: v[keep] for c, v in data.angles_deg.items()}


def doubt_in_range(data: ReviewData, t_from_s: float, t_to_s: float) -> dict[str, np.ndarray]:
    """Joint → the reasons (:mod:`mimucap.core.pipeline.doubt_reasons`) its angles may be wrong, at the poses of
    :func:`angles_in_range`."""
    keep = _in_range(data, t_from_s, t_to_s)
    return {joint: reasons[keep] for joint, reasons in data.joint_doubt.items()}


def recording_start_s(data: ReviewData) -> float:
    """Where an export of the whole recording starts (s): the recording's start, 0 s. The first
    poses may come a fraction of a second earlier (the samples of the poll that was running when
    Record was pressed); they are not offered, so that no range starts at a negative time. A
    recording whose poses all lie before 0 s starts at its first pose."""
    return max(data.start_s, 0.0) if data.end_s > 0.0 else data.start_s


def _in_range(data: ReviewData, t_from_s: float, t_to_s: float) -> np.ndarray:
    keep = (data.t_s >= t_from_s) & (data.t_s <= t_to_s)
    if not np.any(keep):
        raise ValueError(f"no poses between {t_from_s:.3f} and {t_to_s:.3f} s (the recording spans "
                         f"{data.start_s:.3f}..{data.end_s:.3f} s)")
    return keep


def markers_in_range(markers: Sequence[Marker], t_from_s: float, t_to_s: float) -> list[Marker]:
    """The markers with ``t_from_s <= t_s <= t_to_s`` (s), in time order: every exported
    file carries the markers of its range."""
    return sorted((m for m in markers if t_from_s <= m.t_s <= t_to_s), key=lambda m: m.t_s)


def summary_table(angles_deg: dict[str, np.ndarray],
                  joint_doubt: dict[str, np.ndarray] | None = None) -> list[SummaryRow]:
    """Min, max and range of motion of each column (deg), in column order, with the share of
    doubtful samples of its joint (``joint_doubt`` joint → reasons, on the same samples)."""
    rows = []
    for column, values in angles_deg.items():
        low, high = float(np.min(values)), float(np.max(values))
        reasons = next((r for joint, r in (joint_doubt or {}).items() if column.startswith(joint + "_")), None)
        doubtful = 0.0 if reasons is None or not len(reasons) else float(np.mean(np.asarray(reasons) != 0))
        rows.append(SummaryRow(column, low, high, high - low, doubtful))
    return rows


def write_sensor_csv(path: str | Path, data: ReviewData, sensor_id: str, t_from_s: float, t_to_s: float) -> Path:
    """One sensor's raw channels and orientation in the range (:func:`mimucap.io.sensor_csv.write_sensor_csv`);
    the header says what the result holds and lists the range's markers."""
    stream = data.session.sensors[sensor_id]
    keep = (stream.t_s >= t_from_s) & (stream.t_s <= t_to_s)
    q = data.q_world_from_sensor.get(sensor_id)
    notes = data.provenance.lines() + marker_lines(markers_in_range(data.markers, t_from_s, t_to_s))
    return sensor_csv.write_sensor_csv(path, stream.rows(keep), None if q is None else q[keep], notes)


#: What each exported file holds, said in its name: ``<session>_<name>`` (:func:`export_file`).
EXPORT_NAMES = {"csv": "joint_angles.csv", "mot": "joint_angles.mot", "summary": "joint_angle_summary.csv",
                "opensim_mot": "opensim_coordinates.mot", "c3d": "motion.c3d", "bvh": "skeleton.bvh",
                "sto": "orientations.sto"}


def export_file(base: str | Path, kind: str, sensor_id: str | None = None) -> Path:
    """The file of ``kind`` (a key of :data:`EXPORT_NAMES`, or ``"sensor"`` with ``sensor_id``)
    for the export named ``base`` (folder and session name): ``walk_joint_angles.csv``,
    ``walk_sensor_S01_raw.csv``."""
    base = Path(base)
    if kind == "sensor":
        return base.with_name(f"{base.name}_sensor_{sensor_id}_raw.csv")
    return base.with_name(f"{base.name}_{EXPORT_NAMES[kind]}")


def export_folder(session_path: str | Path) -> Path:
    """Where a session's exports go unless the user picks another folder: a folder of their
    own beside the session (``walk.h5`` → ``walk_exports/``), never the library folder itself."""
    session_path = Path(session_path)
    return session_path.with_name(f"{session_path.stem}_exports")


def run_export(data: ReviewData, request: ExportRequest,
               progress: Callable[[float], None] | None = None) -> ExportResult:
    """Write the files of ``request``; ``progress(fraction)`` after each file."""
    report = progress or (lambda fraction: None)
    t, angles = angles_in_range(data, request.t_from_s, request.t_to_s)
    doubt = doubt_in_range(data, request.t_from_s, request.t_to_s)
    result = ExportResult(rows=len(t), summary=summary_table(angles, doubt))
    base = Path(request.base_path)
    base.parent.mkdir(parents=True, exist_ok=True)
    notes = export_notes(data, request.t_from_s, request.t_to_s)
    markers = markers_in_range(data.markers, request.t_from_s, request.t_to_s)
    jobs: list[tuple[str, Callable[[], Path]]] = []
    if request.angles_csv:
        jobs.append(("csv", lambda: _written(export_file(base, "csv"), lambda p: write_angles_csv(
            p, t, angles, notes=notes, markers=markers, joint_doubt=doubt))))
    if request.angles_mot:
        jobs.append(("mot", lambda: _written(export_file(base, "mot"), lambda p: write_angles_mot(
            p, t, angles, notes=notes, markers=markers, joint_doubt=doubt))))
    if request.summary_csv:
        jobs.append(("summary", lambda: write_summary_csv(export_file(base, "summary"), result.summary,
                                                          request.t_from_s, request.t_to_s, markers,
                                                          data.provenance.lines())))
    for wanted, fmt in ((request.opensim_mot, "opensim_mot"), (request.c3d, "c3d"), (request.bvh, "bvh"),
                        (request.opensense_sto, "sto")):
        if wanted:
            jobs.append((fmt, lambda f=fmt: write_motion_file(data, f, export_file(base, f), request.t_from_s,
                                                              request.t_to_s, events=request.events)))
    if request.sensors_csv:
        for sensor_id in data.session.sensors:
            jobs.append((sensor_id, lambda s=sensor_id: write_sensor_csv(export_file(base, "sensor", s), data, s,
                                                                        request.t_from_s, request.t_to_s)))
    report(0.0)
    for done, (_name, job) in enumerate(jobs, start=1):
        written = job()
        result.files.extend(written if isinstance(written, list) else [written])
        report(done / len(jobs))
    return result


def export_notes(data: ReviewData, t_from_s: float, t_to_s: float) -> list[str]:
    """The header lines of an exported file: the session and range, where the poses come
    from, what the result holds (:attr:`ReviewData.provenance`) and what the recording lacks."""
    notes = [f"Session {data.path.name}; {t_from_s:.3f}..{t_to_s:.3f} s",
             f"Result: {data.result_label}; pose from {data.pose_source}; computed from the sensors"]
    notes += data.provenance.lines()[1:]  # the result is said above
    return notes + [f"Note: {text}" for text in data.missing]


def _segment_sensors(data: ReviewData) -> dict[str, str]:
    """Segment → the sensor id the pipeline took its orientation from: the body calibration's
    assignment where there is one, else each sensor's recorded segment (the first per segment)."""
    if data.body_calibration is not None:
        return dict(data.body_calibration.sensors)
    result: dict[str, str] = {}
    for sensor_id, stream in data.session.sensors.items():
        if stream.segment and stream.segment not in result:
            result[stream.segment] = sensor_id
    return result


def calibration_pose_table(data: ReviewData, raw_sensors: bool = False
                           ) -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
    """The N-pose the body calibration measured, as OpenSense's calibration table: ``(t_s (1,),
    <body>_imu → (1, 4))`` (None without a body calibration). Every segment frame is parallel
    to the body frame in the calibrated N-pose, so each virtual sensor is ``q_world_from_body``;
    a raw sensor is ``q_world_from_body ⊗ q_segment_from_sensor`` (its orientation then). Its
    time is 0: the N-pose may lie outside the recording (made live before it)."""
    from mimucap.io import opensense

    body = data.body_calibration
    if body is None:
        return None
    segments = [s for s in data.model.segment_names if s in opensense.OPENSIM_BODIES]
    if raw_sensors:
        q = {s: rotation.multiply(body.q_world_from_body, body.q_segment_from_sensor[s]) for s in segments
             if s in body.q_segment_from_sensor}
    else:
        q = {s: body.q_world_from_body for s in segments if s in data.q_world_from_segment}
    return np.zeros(1), {opensense.imu_label(s): np.asarray(v, dtype=np.float64)[None] for s, v in q.items()}


def write_motion_file(data: ReviewData, fmt: str, path: Path, t_from_s: float | None = None,
                      t_to_s: float | None = None, opensim_names: bool = False, raw_sensors: bool = False,
                      events: Sequence[tuple[float, str, str]] = ()) -> list[Path]:
    """Write the motion of ``data`` from ``t_from_s`` to ``t_to_s`` (s; None: the recording's
    start or end) as ``fmt`` to ``path``.

    ``fmt``: ``"c3d"``, ``"bvh"``, ``"sto"`` (OpenSense orientations; ``raw_sensors`` for the
    sensors' own instead of segment-aligned virtual sensors), ``"mot"`` (``opensim_names``: OpenSim
    coordinates), ``"opensim_mot"`` (the same as ``"mot"`` with ``opensim_names``) or ``"csv"``.
    The markers in the range go with it (C3D events; header lines of ``.mot``/``.csv``/``.sto``;
    the sidecar ``<name>_markers.csv`` beside a BVH file, which has no place for them), and so do
    the gait ``events`` ``(t_s, context, label)``. What the result holds
    (:attr:`ReviewData.provenance`) goes into every file: C3D parameters (group ``MIMUCAP``),
    header lines, the BVH sidecar's ``#`` lines. An OpenSense table comes with
    ``<name>_calibration.sto``, the N-pose of the body calibration for ``IMUPlacer``
    (:func:`calibration_pose_table`). Returns the files written.
    """
    from mimucap.io import opensense
    from mimucap.io.angles_export import write_angles

    path = Path(path)
    t_from = recording_start_s(data) if t_from_s is None else t_from_s
    t_to = data.end_s if t_to_s is None else t_to_s
    check_export_range(t_from, t_to)
    keep = (data.t_s >= t_from) & (data.t_s <= t_to)
    if np.count_nonzero(keep) < 2:
        raise ValueError(f"fewer than two poses between {t_from:.3f} and {t_to:.3f} s (the recording spans "
                         f"{data.start_s:.3f}..{data.end_s:.3f} s)")
    t = data.t_s[keep]
    q_segments = {s: q[keep] for s, q in data.q_world_from_segment.items()}
    angles = {c: v[keep] for c, v in data.angles_deg.items()}
    doubt = {joint: reasons[keep] for joint, reasons in data.joint_doubt.items()}
    root = None if data.root_position_m is None else data.root_position_m[keep]
    in_range = markers_in_range(data.markers, t_from, t_to)
    markers = [(m.t_s, m.label) for m in in_range]
    events = [e for e in events if t_from <= e[0] <= t_to]
    notes = export_notes(data, t_from, t_to)
    notes += [f"event at {time:.3f} s: {context} {label}" for time, context, label in events]
    subject = (data.session.metadata.get("subject") or {}).get("id", "")
    if fmt == "c3d":
        from mimucap.io.c3d_export import write_c3d

        return [write_c3d(path, data.model, data.height_m, t, q_segments, angles, root, markers, events, subject,
                          provenance=data.provenance.parameters())]
    if fmt == "bvh":
        from mimucap.io.bvh import write_bvh, write_bvh_markers

        written = [write_bvh(path, data.model, data.height_m, t, q_segments, root)]
        written.append(write_bvh_markers(path, float(t[0]), markers, events, notes))
        return written
    if fmt == "sto":
        if raw_sensors:
            sensors = _segment_sensors(data)
            stream_t = {sid: data.session.sensors[sid].t_s for sid in sensors.values() if sid in data.session.sensors}
            table = opensense.raw_sensor_table(t, sensors, stream_t, data.q_world_from_sensor)
            header = opensense.RAW_SENSOR_NOTES
        else:
            table = opensense.virtual_sensor_table(q_segments)
            header = opensense.VIRTUAL_SENSOR_NOTES
        written = []
        pose = calibration_pose_table(data, raw_sensors)
        if pose is not None:
            pose_path = path.with_name(path.stem + opensense.CALIBRATION_SUFFIX)
            t_pose, pose_table = pose
            written.append(opensense.write_orientation_sto(
                pose_path, t_pose, pose_table, [opensense.CALIBRATION_TABLE_NOTE.format(table=path.name)] + notes))
            header = (opensense.placer_note(pose_path.name),) + tuple(header)
        else:
            header = (opensense.NO_CALIBRATION_TABLE_NOTE,) + tuple(header)
        table_path = opensense.write_orientation_sto(path, t, table, list(header) + notes + marker_lines(in_range))
        return [table_path] + written
    if fmt in ("mot", "opensim_mot", "csv"):
        write_angles(path, t, angles, notes=notes, opensim_names=opensim_names or fmt == "opensim_mot",
                     markers=in_range, joint_doubt=doubt)
        return [path]
    raise ValueError(f"unknown export format {fmt!r}; use c3d, bvh, sto, mot or csv")


def _written(path: Path, write: Callable[[Path], None]) -> Path:
    write(path)
    return path
