"""Exports of a reviewed session: joint angles (CSV, OpenSim ``.mot``), per-sensor raw data and
orientations (CSV), a per-joint summary (min, max, range of motion) as CSV, and the motion as
C3D, BVH and an OpenSense orientation table (:func:`write_motion_file`; the formats are
described in :mod:`mimucap.io.c3d_export`, :mod:`mimucap.io.bvh` and :mod:`mimucap.io.opensense`).

The time range is ``[t_from_s, t_to_s]`` in session seconds, or the span between two markers
(:func:`marker_range`). Joint angle files use :mod:`mimucap.io.angles_export` (their header
names the sequence, every column's meaning, unit and sign). :func:`run_export` reports its
progress as a fraction in [0, 1] and can run off the GUI thread.
"""

from __future__ import annotations

import csv
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mimucap.core import rotation
from mimucap.core.clinical_names import angle_label
from mimucap.io.angles_export import marker_lines, write_angles_csv, write_angles_mot
from mimucap.io.session import Marker
from mimucap.session.review import ReviewData


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


@dataclass(frozen=True)
class SummaryRow:
    """One joint-angle column over the exported range: ``minimum_deg``, ``maximum_deg``,
    ``rom_deg`` (range of motion = max − min), all degrees; ``doubtful_fraction`` the share of
    its samples where the joint's angles are doubtful (:mod:`mimucap.core.doubt`)."""

    column: str
    minimum_deg: float
    maximum_deg: float
    rom_deg: float
    doubtful_fraction: float = 0.0


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
    """Joint → the reasons (:mod:`mimucap.core.doubt`) its angles may be wrong, at the poses of
    :func:`angles_in_range`."""
    keep = _in_range(data, t_from_s, t_to_s)
    return {joint: reasons[keep] for joint, reasons in data.joint_doubt.items()}


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


def write_summary_csv(path: str | Path, rows: Sequence[SummaryRow], t_from_s: float, t_to_s: float,
                      markers: Sequence[Marker] = (), notes: Sequence[str] = ()) -> Path:
    """The summary as CSV: machine column name, readable label, min, max, range (deg); the
    header names the range, says what the result holds (``notes``, e.g.
    :meth:`~mimucap.session.provenance.Provenance.lines`) and lists ``markers``."""
    path = Path(path)
    with path.open("w", encoding="utf-8", newline="") as handle:
        handle.write(f"# MimuCap joint angle summary from {t_from_s:.3f} s to {t_to_s:.3f} s; degrees\n")
        for line in list(notes) + marker_lines(markers):
            handle.write(f"# {line}\n")
        handle.write("# doubtful_pct: share of the range's samples where the joint's angles may be wrong "
                     "(see the joint-angle file's <joint>_ok column); min, max and range include them\n")
        writer = csv.writer(handle)
        writer.writerow(["column", "label", "min_deg", "max_deg", "rom_deg", "doubtful_pct"])
        for row in rows:
            writer.writerow([row.column, angle_label(row.column), f"{row.minimum_deg:.3f}", f"{row.maximum_deg:.3f}",
                             f"{row.rom_deg:.3f}", f"{100.0 * row.doubtful_fraction:.1f}"])
    return path


def write_sensor_csv(path: str | Path, data: ReviewData, sensor_id: str, t_from_s: float, t_to_s: float) -> Path:
    """One sensor's raw channels and orientation in the range (absent channels are left out);
    the header lists the range's markers."""
    stream = data.session.sensors[sensor_id]
    keep = (stream.t_s >= t_from_s) & (stream.t_s <= t_to_s)
    columns: list[tuple[str, np.ndarray]] = [("t_s", stream.t_s[keep])]
    for name, unit, values in (("acc", "m_s2", stream.acc), ("gyr", "rad_s", stream.gyr), ("mag", "uT", stream.mag_uT)):
        if values is not None:
            columns += [(f"{name}_{axis}_{unit}", values[keep, i]) for i, axis in enumerate("xyz")]
    q = data.q_world_from_sensor.get(sensor_id)
    if q is not None:
        columns += [(f"q_world_from_sensor_{c}", q[keep, i]) for i, c in enumerate("wxyz")]
    path = Path(path)
    with path.open("w", encoding="utf-8", newline="") as handle:
        handle.write(f"# MimuCap sensor {sensor_id} (segment {stream.segment or 'none'}); sensor frame; "
                     "q_world_from_sensor scalar first, world ENU\n")
        for line in data.provenance.lines() + marker_lines(markers_in_range(data.markers, t_from_s, t_to_s)):
            handle.write(f"# {line}\n")
        handle.write(",".join(name for name, _ in columns) + "\n")
        table = np.column_stack([v for _, v in columns])
        np.savetxt(handle, table, delimiter=",", fmt="%.6f")
    return path


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
        jobs.append(("csv", lambda: _written(base.with_suffix(".csv"), lambda p: write_angles_csv(
            p, t, angles, notes=notes, markers=markers, joint_doubt=doubt))))
    if request.angles_mot:
        jobs.append(("mot", lambda: _written(base.with_suffix(".mot"), lambda p: write_angles_mot(
            p, t, angles, notes=notes, markers=markers, joint_doubt=doubt))))
    if request.summary_csv:
        jobs.append(("summary", lambda: write_summary_csv(base.with_name(base.name + "_summary.csv"), result.summary,
                                                          request.t_from_s, request.t_to_s, markers,
                                                          data.provenance.lines())))
    motion_files = ((request.opensim_mot, "opensim_mot", base.with_name(base.name + "_opensim.mot")),
                    (request.c3d, "c3d", base.with_suffix(".c3d")), (request.bvh, "bvh", base.with_suffix(".bvh")),
                    (request.opensense_sto, "sto", base.with_name(base.name + "_orientations.sto")))
    for wanted, fmt, path in motion_files:
        if wanted:
            jobs.append((fmt, lambda f=fmt, p=path: write_motion_file(data, f, p, request.t_from_s, request.t_to_s,
                                                                      events=request.events)))
    if request.sensors_csv:
        for sensor_id in data.session.sensors:
            jobs.append((sensor_id, lambda s=sensor_id: write_sensor_csv(base.with_name(f"{base.name}_{s}.csv"), data, s,
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
    t_from = data.start_s if t_from_s is None else t_from_s
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
        from mimucap.io.bvh import write_bvh

        written = [write_bvh(path, data.model, data.height_m, t, q_segments, root)]
        side = path.with_name(path.stem + "_markers.csv")  # BVH has no place for text
        with side.open("w", encoding="utf-8", newline="") as handle:
            handle.write(f"# markers and events of {path.name}; t_s seconds from the first BVH frame\n")
            for note in notes:
                handle.write(f"# {note}\n")
            writer = csv.writer(handle)
            writer.writerow(["t_s", "context", "label"])
            for time, label in markers:
                writer.writerow([f"{time - t[0]:.6f}", "General", label])
            for time, context, label in events:
                writer.writerow([f"{time - t[0]:.6f}", context, label])
        written.append(side)
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
