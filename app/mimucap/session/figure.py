"""What the 3D view draws: the skeleton as capsules, joints and markers, in scene coordinates.

Input is one frame of :func:`mimucap.core.skeleton.forward_kinematics` output (segment
poses in the **world** frame, ENU, metres) and the skeleton model. Output is a
:class:`FigureGeometry`: for every drawn piece a 4×4 matrix that places a *unit* primitive
in the **scene** frame (VTK/OpenGL: y up, z towards the viewer,
``R_scene_from_world = [[1,0,0],[0,0,1],[0,-1,0]]``, conventions.md), so the GUI only hands
matrices to VTK actors and does no geometry itself.

Unit primitives: a cylinder of radius 1 and height 1 along the scene y axis, centred at the
origin (``vtkCylinderSource`` defaults with radius 1); a sphere of radius 1 at the origin.

Display modes (conventions.md, seed section 4.3), applied as a rotation about the world
vertical by ``alpha`` before the scene mapping:

* ``"world"``: ``alpha = pi - heading_ref``: the figure faces the camera (which looks north)
  in its reference (calibrated N-pose) heading and turns on screen when the person turns;
  the figure moves over the floor when the root moves. Without a reference heading
  (``heading_ref_rad=None``: no body calibration yet) ``alpha = 0``: the plain world as the
  default camera sees it, east to the right and north away from the viewer.
* ``"body"``: ``alpha = pi - heading_pelvis(t)`` and the root stays above the origin: the
  figure always faces the camera.

Headings are radians, counter-clockwise seen from above, 0 = the segment's x axis (anterior)
pointing north, as in :func:`mimucap.core.skeleton.q_world_from_body_facing`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mimucap.core import rotation

DISPLAY_MODES = ("world", "body")

#: R_scene_from_world (conventions.md, seed equation 4.1).
R_SCENE_FROM_WORLD = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])

#: Shortest connector drawn between a joint and its parent's long axis, metres.
MIN_CONNECTOR_M = 1e-3
#: Radius of a connector ("clavicle", "hip bone") relative to the parent's radius.
CONNECTOR_RADIUS_FACTOR = 0.45
#: Radius of a joint sphere relative to the larger radius of the segments it joins.
JOINT_RADIUS_FACTOR = 1.15
#: Radius of the anterior marker sphere relative to its segment's radius.
MARKER_RADIUS_FACTOR = 0.35


@dataclass(frozen=True)
class FigureGeometry:
    """One frame of the figure, ready for the scene.

    Attributes:
        segment_names: names of the segment capsules, in model order.
        segment_matrices: ``(S, 4, 4)`` placing the unit cylinder of each segment (scene frame).
        connector_names: ``"<parent>-><child>"`` for each connector drawn.
        connector_matrices: ``(C, 4, 4)`` for the connectors' unit cylinders.
        joint_names: names of the spheres: ``"root"``, the model's joints, then
            ``"<segment>_end"`` caps on distal ends where no child joint sits.
        joint_matrices: ``(J, 4, 4)`` placing the unit sphere of each joint.
        marker_matrices: ``(S, 4, 4)`` unit spheres on the anterior face of each segment (shows
            axial rotation), same order as ``segment_names``.
        root_scene_m: ``(3,)`` scene position of the root (pelvis proximal point), metres.
        world_matrix: ``(4, 4)`` mapping world coordinates (ENU, metres) to the scene with
            this frame's display rotation and shift: the floor and world axes use it.
        heading_alpha_rad: the display rotation about the vertical that was applied.
    """

    segment_names: tuple[str, ...]
    segment_matrices: NDArray[np.float64]
    connector_names: tuple[str, ...]
    connector_matrices: NDArray[np.float64]
    joint_names: tuple[str, ...]
    joint_matrices: NDArray[np.float64]
    marker_matrices: NDArray[np.float64]
    root_scene_m: NDArray[np.float64]
    world_matrix: NDArray[np.float64]
    heading_alpha_rad: float


def heading_rad(q_world_from_segment: NDArray[np.float64]) -> float:
    """Heading of a segment's anterior (x) axis, radians CCW from north (see module doc).

    Args:
        q_world_from_segment: ``(4,)`` scalar-first unit quaternion.
    """
    x_world = rotation.rotate(q_world_from_segment, np.array([1.0, 0.0, 0.0]))
    if np.hypot(x_world[0], x_world[1]) < 1e-9:
        return 0.0
    return float(np.arctan2(-x_world[0], x_world[1]))


def _rz(angle: float) -> NDArray[np.float64]:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _placement(
    p0: NDArray[np.float64], p1: NDArray[np.float64], x_hint: NDArray[np.float64], radius: float
) -> NDArray[np.float64]:
    """4×4 matrix mapping the unit cylinder onto the capsule body from ``p0`` to ``p1``.

    The cylinder's y axis follows ``p1 - p0``; its x axis follows ``x_hint`` made orthogonal
    (so the segment's twist is kept); scaled by ``radius`` across and the length along.
    """
    axis = p1 - p0
    length = float(np.linalg.norm(axis))
    y = axis / length if length > 0 else np.array([0.0, 1.0, 0.0])
    x = x_hint - np.dot(x_hint, y) * y
    norm = np.linalg.norm(x)
    if norm < 1e-9:
        helper = np.array([1.0, 0.0, 0.0]) if abs(y[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
        x = helper - np.dot(helper, y) * y
        norm = np.linalg.norm(x)
    x = x / norm
    z = np.cross(x, y)
    matrix = np.eye(4)
    matrix[:3, 0] = x * radius
    matrix[:3, 1] = y * length
    matrix[:3, 2] = z * radius
    matrix[:3, 3] = 0.5 * (p0 + p1)
    return matrix


def _sphere(center: NDArray[np.float64], radius: float) -> NDArray[np.float64]:
    matrix = np.eye(4)
    matrix[:3, :3] *= radius
    matrix[:3, 3] = center
    return matrix


class FigureBuilder:
    """Turns segment poses into :class:`FigureGeometry` for one skeleton model and height.

    Args:
        model: a ``SkeletonModel`` (``mimucap.core.skeleton``).
        height_m: the subject's height, metres (segment radii scale with it).
    """

    def __init__(self, model, height_m: float) -> None:
        if not (0.5 <= float(height_m) <= 2.5):
            raise ValueError(f"subject height must be between 0.5 and 2.5 m, got {height_m}")
        self.model = model
        self.height_m = float(height_m)
        self.segment_names = tuple(model.segment_names)
        self._radius = {s.name: float(s.radius_ratio) * self.height_m for s in model.segments}
        connectors = []
        at_distal = set()  # segments whose distal end carries a child joint
        for seg in model.segments:
            if seg.parent is None:
                continue
            parent = model.segment(seg.parent)
            attach = np.asarray(seg.attach_ratio, dtype=float)
            direction = np.asarray(parent.direction, dtype=float)
            along = float(np.dot(attach, direction))
            lateral = attach - along * direction
            if np.linalg.norm(lateral) * self.height_m >= MIN_CONNECTOR_M:
                fraction = along / float(parent.length_ratio)
                connectors.append((seg.parent, seg.name, fraction))
            elif abs(along - float(parent.length_ratio)) * self.height_m < MIN_CONNECTOR_M:
                at_distal.add(seg.parent)
        self._connectors = tuple(connectors)
        self.connector_names = tuple(f"{p}->{c}" for p, c, _ in connectors)
        joint_names = ["root"]
        joint_radius = {"root": self._radius[self.segment_names[0]] * 0.8}
        for seg in model.segments:
            if seg.joint is None:
                continue
            joint_names.append(seg.joint)
            joint_radius[seg.joint] = JOINT_RADIUS_FACTOR * min(
                self._radius[seg.name], self._radius[seg.parent]
            )
        # Round end caps where no child joint sits on a segment's distal end.
        self._end_caps = tuple(s.name for s in model.segments if s.name not in at_distal)
        for name in self._end_caps:
            joint_names.append(f"{name}_end")
            joint_radius[f"{name}_end"] = self._radius[name]
        self.joint_names = tuple(joint_names)
        self._joint_radius = joint_radius

    def display_alpha(self, mode: str, q_world_from_pelvis, heading_ref_rad: float | None) -> float:
        """The display rotation about the vertical for ``mode`` (see the module doc), radians."""
        if mode not in DISPLAY_MODES:
            raise ValueError(f"display mode must be one of {DISPLAY_MODES}, got {mode!r}")
        if mode == "body":
            return float(np.pi - heading_rad(np.asarray(q_world_from_pelvis, dtype=float)))
        if heading_ref_rad is None:
            return 0.0
        return float(np.pi - heading_ref_rad)

    def build(
        self,
        poses: Mapping[str, object],
        mode: str = "world",
        heading_ref_rad: float | None = None,
        origin_world_m=(0.0, 0.0),
    ) -> FigureGeometry:
        """Place every piece of the figure for one frame.

        Args:
            poses: segment name → ``SegmentPose`` with ``proximal_m``/``distal_m`` ``(3,)``
                (world, metres) and ``q_world_from_segment`` ``(4,)``.
            mode: ``"world"`` or ``"body"``.
            heading_ref_rad: the reference heading for world mode (see module doc); None
                shows the plain world (alpha = 0).
            origin_world_m: ``(2,)`` world east/north point shown at the scene origin in
                world mode (body mode always centres the root).
        """
        root = poses[self.segment_names[0]]
        alpha = self.display_alpha(mode, root.q_world_from_segment, heading_ref_rad)
        root_world = np.asarray(root.proximal_m, dtype=float)
        if mode == "body":
            shift = np.array([root_world[0], root_world[1], 0.0])
        else:
            shift = np.array([float(origin_world_m[0]), float(origin_world_m[1]), 0.0])
        r_scene_from_world_display = R_SCENE_FROM_WORLD @ _rz(alpha)

        def to_scene(p_world) -> NDArray[np.float64]:
            return r_scene_from_world_display @ (np.asarray(p_world, dtype=float) - shift)

        prox, dist, x_axis = {}, {}, {}
        for name in self.segment_names:
            pose = poses[name]
            prox[name] = to_scene(pose.proximal_m)
            dist[name] = to_scene(pose.distal_m)
            x_world = rotation.rotate(np.asarray(pose.q_world_from_segment, dtype=float), [1.0, 0.0, 0.0])
            x_axis[name] = r_scene_from_world_display @ x_world

        seg_matrices = np.empty((len(self.segment_names), 4, 4))
        marker_matrices = np.empty((len(self.segment_names), 4, 4))
        for i, name in enumerate(self.segment_names):
            radius = self._radius[name]
            seg_matrices[i] = _placement(prox[name], dist[name], x_axis[name], radius)
            middle = 0.5 * (prox[name] + dist[name])
            front = seg_matrices[i][:3, 0] / radius
            marker_matrices[i] = _sphere(middle + front * radius, MARKER_RADIUS_FACTOR * radius)

        con_matrices = np.empty((len(self._connectors), 4, 4))
        for i, (parent, child, fraction) in enumerate(self._connectors):
            anchor = prox[parent] + fraction * (dist[parent] - prox[parent])
            radius = CONNECTOR_RADIUS_FACTOR * self._radius[parent]
            con_matrices[i] = _placement(anchor, prox[child], x_axis[parent], radius)

        joint_matrices = np.empty((len(self.joint_names), 4, 4))
        joint_matrices[0] = _sphere(prox[self.segment_names[0]], self._joint_radius["root"])
        i = 1
        for seg in self.model.segments:
            if seg.joint is None:
                continue
            joint_matrices[i] = _sphere(prox[seg.name], self._joint_radius[seg.joint])
            i += 1
        for name in self._end_caps:
            joint_matrices[i] = _sphere(dist[name], self._joint_radius[f"{name}_end"])
            i += 1

        world_matrix = np.eye(4)
        world_matrix[:3, :3] = r_scene_from_world_display
        world_matrix[:3, 3] = -r_scene_from_world_display @ shift
        return FigureGeometry(
            segment_names=self.segment_names,
            segment_matrices=seg_matrices,
            connector_names=self.connector_names,
            connector_matrices=con_matrices,
            joint_names=self.joint_names,
            joint_matrices=joint_matrices,
            marker_matrices=marker_matrices,
            root_scene_m=prox[self.segment_names[0]].copy(),
            world_matrix=world_matrix,
            heading_alpha_rad=alpha,
        )
