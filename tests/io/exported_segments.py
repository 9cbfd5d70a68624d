"""Segment orientations read back from exported files by other programs' readers (C3D by the
``c3d`` package, BVH by ``bvhio``'s forward kinematics, an OpenSense table as plain text), and
their heading error against the simulator's true segments; OpenSim's own inverse kinematics of
an OpenSense table (:func:`opensense_knee_errors`).

The time of each file's first frame comes from the file itself: its events (C3D) or marker
sidecar (BVH) name a marker of the session at a time from the first frame, and the session
says when that marker was set; an OpenSense table carries its times.
"""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np

from mimucap.core import rotation as rot


def heading_error_deg(q_estimate: np.ndarray, q_true: np.ndarray) -> np.ndarray:
    """The turn about the world's vertical (ENU z) of each estimated segment from the true one
    (deg, (N,)): the twist about z of ``q_estimate ⊗ q_true⁻¹`` (swing-twist decomposition), the
    heading part of the error whatever the segment's inclination."""
    relative = rot.multiply(q_estimate, rot.conjugate(q_true))
    yaw = np.degrees(2.0 * np.arctan2(relative[..., 3], relative[..., 0]))
    return (yaw + 180.0) % 360.0 - 180.0


def truth_at(truth, segment: str, t_s: np.ndarray) -> np.ndarray:
    """The simulator's true ``q_world_from_segment`` at the instants ``t_s`` (nearest sample)."""
    index = np.clip(np.searchsorted(truth.t_s, np.asarray(t_s) - 1e-9), 0, len(truth.t_s) - 1)
    return np.asarray(truth.q_world_from_segment[segment])[index]


def c3d_segments(path: Path, markers) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """``(t_s, segment → q_world_from_segment)`` of a C3D file's ``<Segment>Orientation`` points
    (rotation vectors in degrees), read by the ``c3d`` package; ``markers`` the session's
    markers (for the file's time base)."""
    import c3d

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "no analog data"
        with path.open("rb") as handle:
            reader = c3d.Reader(handle)
            labels = [label.strip() for label in reader.point_labels]
            frames = np.stack([points[:, :3] for _i, points, _analog in reader.read_frames()])
            event = reader.get("EVENT")
            names = [s.strip() for s in event.get("LABELS").string_array]
            times = np.asarray(event.get("TIMES").float_array).reshape(-1, 2)[:, 1]
            rate = reader.point_rate
    start = _start_from_markers(list(zip(names, times)), markers, path)
    t = start + np.arange(frames.shape[0]) / rate
    segments = {}
    for index, label in enumerate(labels):
        if label.endswith("Orientation"):
            segments[_snake(label[: -len("Orientation")])] = rot.from_rotvec(np.radians(frames[:, index]))
    return t, segments


def bvh_segments(path: Path, markers, step: int = 5) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """``(t_s, segment → q_world_from_segment)`` of every ``step``-th frame of a BVH file by
    ``bvhio``'s forward kinematics (each joint's world rotation with its rest turn taken out, in
    our world frame)."""
    import bvhio

    from mimucap.io.bvh import segment_from_bvh_global

    root = bvhio.readAsHierarchy(str(path))
    root.loadRestPose()
    rest = {j.Name: _wxyz(j.RotationWorld) for j, _i, _d in root.layout()}
    text = path.read_text()
    frame_time = float(text.split("Frame Time:")[1].split()[0])
    n_frames = int(text.split("Frames:")[1].split()[0])
    found: dict[str, list[np.ndarray]] = {name: [] for name in rest}
    frames = range(0, n_frames, step)
    for frame in frames:
        root.loadPose(frame)
        for joint, _index, _depth in root.layout():
            world = rot.multiply(_wxyz(joint.RotationWorld), rot.conjugate(rest[joint.Name]))
            found[joint.Name].append(segment_from_bvh_global(world))
    sidecar = path.with_name(path.stem + "_markers.csv")
    in_file = []
    for line in sidecar.read_text(encoding="utf-8").splitlines():
        if line.startswith("#") or line.startswith("t_s,") or not line.strip():
            continue
        time, _context, label = line.split(",", 2)
        in_file.append((label, float(time)))
    start = _start_from_markers(in_file, markers, path)
    return start + np.asarray(frames) * frame_time, {name: np.array(q) for name, q in found.items()}


def sto_segments(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """``(t_s, segment → q_world_from_segment)`` of an OpenSense table of virtual sensors, read
    as the text it is (``endheader``, then a tab-separated table of ``w,x,y,z`` cells)."""
    from mimucap.io.opensense import segment_of_label

    lines = path.read_text(encoding="utf-8").splitlines()
    end = lines.index("endheader")
    columns = lines[end + 1].split("\t")
    rows = [line.split("\t") for line in lines[end + 2:] if line.strip()]
    t = np.array([float(row[0]) for row in rows])
    segments = {}
    for index, label in enumerate(columns[1:], start=1):
        segments[segment_of_label(label)] = np.array([[float(v) for v in row[index].split(",")] for row in rows])
    return t, segments


def _start_from_markers(in_file: list[tuple[str, float]], markers, path: Path) -> float:
    """The session time of a file's first frame: a marker label found once in the file and once
    in the session, its session time minus its time in the file."""
    labels = [label for label, _t in in_file]
    session_labels = [m.label for m in markers]
    for label, time in in_file:
        if labels.count(label) == 1 and session_labels.count(label) == 1:
            return next(m.t_s for m in markers if m.label == label) - float(time)
    raise AssertionError(f"{path}: no marker found once in the file and in the session among {labels}")


def _snake(camel: str) -> str:
    """``ThighR`` → ``thigh_r``, ``UpperArmL`` → ``upper_arm_l``."""
    out = ""
    for char in camel:
        out += ("_" + char.lower()) if char.isupper() and out else char.lower()
    return out


def _wxyz(q) -> np.ndarray:
    return np.array([q.w, q.x, q.y, q.z])


def heading_figures(t_s: np.ndarray, segments: dict[str, np.ndarray], truth,
                    still: list[tuple[float, float]], moving: list[tuple[float, float]]) -> dict[str, tuple[float, float]]:
    """Segment → (largest |mean heading error| over the ``still`` windows, largest RMS heading
    error over the ``moving`` windows), degrees; windows in s."""
    figures = {}
    for segment, q in segments.items():
        error = heading_error_deg(q, truth_at(truth, segment, t_s))
        means = [abs(float(np.mean(error[(t_s >= a) & (t_s <= b)]))) for a, b in still]
        rms = [float(np.sqrt(np.mean(np.square(error[(t_s >= a) & (t_s <= b)])))) for a, b in moving]
        figures[segment] = (max(means), max(rms))
    return figures


def opensense_knee_errors(table: Path, calibration: Path, model: Path, out: Path, truth_of) -> dict[str, float]:
    """OpenSim 4.6 (IMUPlacer on ``calibration``, IMU inverse kinematics on ``table``, in a
    subprocess): RMS difference (deg) of its knee_angle_r/l from ``truth_of(t_s, column)``."""
    from mimucap.io.angles_export import read_angles_mot

    runner = Path(__file__).resolve().parent / "opensense_runner.py"
    run = subprocess.run([sys.executable, str(runner), str(model), str(table), str(out), str(calibration)],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    ik = read_angles_mot(out / f"ik_{table.stem}.mot")
    return {theirs: float(np.sqrt(np.mean(np.square(ik.angles_deg[theirs] - truth_of(ik.t_s, ours)))))
            for ours, theirs in (("knee_r_flexion_deg", "knee_angle_r"), ("knee_l_flexion_deg", "knee_angle_l"))}
