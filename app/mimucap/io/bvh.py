"""BVH export of the skeleton's motion (Biovision Hierarchy: Blender, MotionBuilder, game engines).

Layout (Meredith & Maddock, "Motion Capture File Formats Explained", University of Sheffield,
2001): a ``HIERARCHY`` of joints with ``OFFSET`` (position of a joint in its parent's frame in the
rest pose) and ``CHANNELS``, then ``MOTION`` with ``Frames``, ``Frame Time`` and one line of
channel values per frame.

* **Hierarchy**: one BVH joint per segment of the skeleton model, at the segment's proximal
  joint, parents as in the model (the root is the pelvis); leaf segments end in an ``End Site``
  at their distal end. Offsets come from the model's ratios times the subject's height, in
  **centimetres** (import in Blender with scale 0.01).
* **Rest pose**: the calibrated N-pose, the subject facing BVH +z with y up (so the subject's
  right is BVH −x); every joint frame is then parallel to the BVH axes, as BVH requires.
* **Channels**: the root has ``Xposition Yposition Zposition Zrotation Xrotation Yrotation``,
  every other joint ``Zrotation Xrotation Yrotation``: a joint's rotation relative to its parent
  is ``Rz(a)·Rx(b)·Ry(c)`` in the channel order (intrinsic Z-X'-Y''), degrees.
* **World**: BVH x = east, y = up, z = south (the ENU world turned so that y is up, as the 3D view
  does); ``R_bvh_from_world = [[1,0,0],[0,0,1],[0,-1,0]]``. A BVH joint's global rotation is
  ``G = R_bvh_from_world · R_world_from_segment · R_rest⁻¹`` with ``R_rest`` the N-pose segment
  frame in BVH axes (segment x anterior → +z, y up → +y, z right → −x).
* **Root translation**: the pipeline's root position where it knows one, else the model's
  standing height over the origin.

BVH has no place for text: the markers and events of the motion go into a sidecar CSV
(:func:`write_bvh_markers`, ``<name>_markers.csv``: ``t_s`` seconds from the first frame,
``context``, ``label``), headed by ``#`` lines saying what the motion holds.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from mimucap.core import rotation, skeleton
from mimucap.io.motion_grid import sample_orientations, sample_series, uniform_grid

R_BVH_FROM_WORLD = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
#: A segment frame in the rest pose expressed in BVH axes (columns: segment x, y, z).
R_BVH_FROM_SEGMENT_REST = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
Q_BVH_FROM_WORLD = rotation.from_matrix(R_BVH_FROM_WORLD)
Q_REST = rotation.from_matrix(R_BVH_FROM_SEGMENT_REST)
#: BVH length unit per metre.
CENTIMETRES = 100.0
ROTATION_CHANNELS = "Zrotation Xrotation Yrotation"


def bvh_global_rotation(q_world_from_segment: np.ndarray) -> np.ndarray:
    """BVH global joint rotation (..., 4) of a segment orientation (see the module doc)."""
    return rotation.multiply(rotation.multiply(Q_BVH_FROM_WORLD, q_world_from_segment), rotation.conjugate(Q_REST))


def segment_from_bvh_global(q_bvh_global: np.ndarray) -> np.ndarray:
    """Inverse of :func:`bvh_global_rotation`: ``q_world_from_segment`` (..., 4)."""
    return rotation.multiply(rotation.multiply(rotation.conjugate(Q_BVH_FROM_WORLD), q_bvh_global), Q_REST)


def _vector(v_segment: np.ndarray, scale: float) -> str:
    x, y, z = R_BVH_FROM_SEGMENT_REST @ np.asarray(v_segment, dtype=np.float64) * scale
    return f"{x + 0.0:.6f} {y + 0.0:.6f} {z + 0.0:.6f}"


def write_bvh(
    path: str | Path,
    model: skeleton.SkeletonModel,
    height_m: float,
    t_s: np.ndarray,
    q_world_from_segment: Mapping[str, np.ndarray],
    root_position_m: np.ndarray | None = None,
) -> Path:
    """Write the motion as BVH (layout in the module doc).

    ``t_s`` (T,) s pose times (resampled onto a uniform grid, :mod:`mimucap.io.motion_grid`);
    ``q_world_from_segment`` segment → (T, 4) world ENU, w first, every segment of ``model``;
    ``root_position_m`` (T, 3) world ENU metres or ``None``.
    """
    path = Path(path)
    if path.suffix.lower() != ".bvh":
        raise ValueError(f"{path}: a BVH file must end in .bvh")
    skeleton._check_height(height_m)
    missing = [s for s in model.segment_names if s not in q_world_from_segment]
    if missing:
        raise ValueError(f"{path}: no orientation for segment(s) {', '.join(missing)}")
    t = np.asarray(t_s, dtype=np.float64)
    frames_t, rate = uniform_grid(t)
    names = model.segment_names
    q = np.stack([sample_orientations(t, q_world_from_segment[s], frames_t) for s in names])
    if root_position_m is None:
        root = np.broadcast_to([0.0, 0.0, model.root_height_ratio * height_m], (len(frames_t), 3))
    else:
        root = sample_series(t, root_position_m, frames_t)
    root_bvh = root @ R_BVH_FROM_WORLD.T * CENTIMETRES
    index = {name: i for i, name in enumerate(names)}
    global_q = bvh_global_rotation(q)                         # (S, F, 4)
    local = np.empty_like(global_q)
    for i, segment in enumerate(model.segments):
        if segment.parent is None:
            local[i] = global_q[i]
        else:
            local[i] = rotation.multiply(rotation.conjugate(global_q[index[segment.parent]]), global_q[i])
    euler_deg = np.degrees(rotation.to_euler(local, "ZXY"))  # (S, F, 3)

    children: dict[str | None, list[skeleton.Segment]] = {}
    for segment in model.segments:
        children.setdefault(segment.parent, []).append(segment)
    lines = ["HIERARCHY"]
    order: list[int] = []

    def emit(segment: skeleton.Segment, depth: int) -> None:
        pad = "\t" * depth
        order.append(index[segment.name])
        if segment.parent is None:
            lines.append(f"ROOT {segment.name}")
            lines.append(f"{pad}{{")
            lines.append(f"{pad}\tOFFSET 0.000000 0.000000 0.000000")
            lines.append(f"{pad}\tCHANNELS 6 Xposition Yposition Zposition {ROTATION_CHANNELS}")
        else:
            lines.append(f"{pad}JOINT {segment.name}")
            lines.append(f"{pad}{{")
            lines.append(f"{pad}\tOFFSET {_vector(segment.attach_ratio, height_m * CENTIMETRES)}")
            lines.append(f"{pad}\tCHANNELS 3 {ROTATION_CHANNELS}")
        kids = children.get(segment.name, [])
        for child in kids:
            emit(child, depth + 1)
        if not kids:
            distal = np.asarray(segment.direction) * segment.length_ratio
            lines.append(f"{pad}\tEnd Site")
            lines.append(f"{pad}\t{{")
            lines.append(f"{pad}\t\tOFFSET {_vector(distal, height_m * CENTIMETRES)}")
            lines.append(f"{pad}\t}}")
        lines.append(f"{pad}}}")

    emit(model.segments[0], 0)
    lines += ["MOTION", f"Frames: {len(frames_t)}", f"Frame Time: {1.0 / rate:.6f}"]
    columns = [root_bvh] + [euler_deg[i] for i in order]
    table = np.concatenate(columns, axis=1) + 0.0
    with path.open("w", encoding="utf-8", newline="\n") as handle:
        handle.write("\n".join(lines) + "\n")
        np.savetxt(handle, table, fmt="%.6f", delimiter=" ")
    return path


def bvh_markers_path(bvh_path: str | Path) -> Path:
    """The markers sidecar of ``NAME.bvh``: ``NAME_markers.csv`` beside it."""
    path = Path(bvh_path)
    return path.with_name(path.stem + "_markers.csv")


def write_bvh_markers(bvh_path: str | Path, first_frame_s: float, markers: Sequence[tuple[float, str]],
                      events: Sequence[tuple[float, str, str]] = (), notes: Sequence[str] = ()) -> Path:
    """Write the markers sidecar of the BVH file ``bvh_path`` (:func:`bvh_markers_path`):
    ``markers`` ``(t_s, label)`` (context "General") and gait ``events`` ``(t_s, context,
    label)``, their times (s, the recording's clock) counted from the first frame at
    ``first_frame_s``; ``notes`` as ``#`` lines. Returns the sidecar's path."""
    side = bvh_markers_path(bvh_path)
    with side.open("w", encoding="utf-8", newline="") as handle:
        handle.write(f"# markers and events of {Path(bvh_path).name}; t_s seconds from the first BVH frame\n")
        for note in notes:
            handle.write(f"# {note}\n")
        writer = csv.writer(handle)
        writer.writerow(["t_s", "context", "label"])
        for time, label in markers:
            writer.writerow([f"{time - first_frame_s:.6f}", "General", label])
        for time, context, label in events:
            writer.writerow([f"{time - first_frame_s:.6f}", context, label])
    return side
