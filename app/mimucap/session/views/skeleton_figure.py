"""What the 3D view draws: the skeleton as capsules, joints and markers, in scene coordinates.

Input is one frame of :func:`mimucap.core.skeleton.forward_kinematics` output (segment
poses in the **world** frame, ENU, metres) and the skeleton model, or the same as stacked
arrays (:meth:`FigureBuilder.build_arrays`, what the live view uses: every piece of the
figure is placed in a few vectorised steps with index arrays prepared once). Output is a
:class:`FigureGeometry`: for every drawn piece a 4×4 matrix that places a *unit* primitive
in the **scene** frame (VTK/OpenGL: y up, z towards the viewer,
``R_scene_from_world = [[1,0,0],[0,0,1],[0,-1,0]]``, conventions.md), so the GUI only hands
matrices to VTK actors and does no geometry itself.

Unit primitives: a cylinder of radius 1 and height 1 along the scene y axis, centred at the
origin (``vtkCylinderSource`` defaults with radius 1); a sphere of radius 1 at the origin; a
sensor glyph: a cube of side 1 centred at the origin, its edges along the sensor's x, y and z
axes (:class:`SensorGlyphs`).

Before a body calibration the segments' orientations are not known: a sensor's axes are not its
segment's, and a figure drawn from them is a tangle. :meth:`FigureBuilder.build_outline` then
draws the body as a neutral outline standing in the N-pose and facing the viewer (it never
moves), with each assigned sensor as a glyph on the segment it is worn on, turned by its
measured ``q_world_from_sensor`` (the filter's output, heading included) into the same scene.

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
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from mimucap.core import rotation, skeleton

DISPLAY_MODES = ("world", "body")

#: R_scene_from_world (docs/conventions.md; Podoprosvetov et al., "Calibration algorithm for MIMU sensors group", equation 4.1).
R_SCENE_FROM_WORLD = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])

#: Shortest connector drawn between a joint and its parent's long axis, metres.
MIN_CONNECTOR_M = 1e-3
#: Radius of a connector ("clavicle", "hip bone") relative to the parent's radius.
CONNECTOR_RADIUS_FACTOR = 0.45
#: Radius of a joint sphere relative to the smaller radius of the two segments it joins.
JOINT_RADIUS_FACTOR = 1.15
#: Radius of a round end cap (a segment end with no joint on it) relative to its segment's
#: radius. Wider than the capsule: a sphere exactly as wide meets the faceted capsule
#: tangentially, and their seam then zigzags with the facets; at 1.1 it crosses them at 25°.
END_CAP_RADIUS_FACTOR = 1.1
#: Radius of the anterior marker sphere relative to its segment's radius.
MARKER_RADIUS_FACTOR = 0.35
#: Side of a sensor glyph relative to the subject's height (a 1.75 m subject: 7 cm, a little
#: larger than a sensor, to be seen at figure size on screen).
GLYPH_SIZE_RATIO = 0.04
#: The outline's heading (rad, CCW from north): facing south, towards the default camera, which
#: looks north (world mode without a reference heading shows the plain world).
OUTLINE_HEADING_RAD = np.pi


@dataclass(frozen=True)
class SensorGlyphs:
    """The sensors drawn on the outline before a body calibration.

    Attributes:
        sensor_ids: the sensors, one per glyph.
        segments: the segment each is worn on (same order).
        matrices: ``(K, 4, 4)`` placing the unit glyph cube (scene frame): columns 0-2 are the
            sensor's x, y and z axes in the scene times the glyph's side (m), column 3 its
            centre, on the front of its segment on the outline.
    """

    sensor_ids: tuple[str, ...]
    segments: tuple[str, ...]
    matrices: NDArray[np.float64]


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
        root_world_m: ``(3,)`` the same point in the world (ENU, metres).
        world_matrix: ``(4, 4)`` mapping world coordinates (ENU, metres) to the scene with
            this frame's display rotation and shift: the floor and world axes use it.
        heading_alpha_rad: the display rotation about the vertical that was applied.
        outline: True for the neutral outline drawn before a body calibration (the segments'
            poses are not measured; :meth:`FigureBuilder.build_outline`).
        sensor_glyphs: the sensors on the outline (``None`` for the figure of a pose).
    """

    segment_names: tuple[str, ...]
    segment_matrices: NDArray[np.float64]
    connector_names: tuple[str, ...]
    connector_matrices: NDArray[np.float64]
    joint_names: tuple[str, ...]
    joint_matrices: NDArray[np.float64]
    marker_matrices: NDArray[np.float64]
    root_scene_m: NDArray[np.float64]
    root_world_m: NDArray[np.float64]
    world_matrix: NDArray[np.float64]
    heading_alpha_rad: float
    outline: bool = False
    sensor_glyphs: SensorGlyphs | None = None


def plain_world_matrix() -> NDArray[np.float64]:
    """The ``(4, 4)`` world → scene matrix of world mode without a heading reference and with
    the world origin at the scene origin: what the stage shows before the first frame."""
    matrix = np.eye(4)
    matrix[:3, :3] = R_SCENE_FROM_WORLD
    return matrix


def _rz(angle: float) -> NDArray[np.float64]:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


#: Column orders turning row-wise ``a × b`` into two products of permuted columns.
_NEXT = np.array([1, 2, 0])
_PREV = np.array([2, 0, 1])


def _rows_dot(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Row-wise dot products of ``(K, 3)`` arrays: ``(K,)``."""
    return np.einsum("ki,ki->k", a, b)


def _anterior_axes(q_world_from_segment: NDArray[np.float64]) -> NDArray[np.float64]:
    """Segment x axes in the world frame, ``(S, 3)``, of unit quaternions ``(S, 4)``: the first
    column of ``R_world_from_segment`` (:func:`mimucap.core.rotation.rotate` of ``[1, 0, 0]``,
    written out for that vector)."""
    w, x, y, z = q_world_from_segment.T
    axes = np.empty((len(q_world_from_segment), 3))
    axes[:, 0] = 1.0 - 2.0 * (y * y + z * z)
    axes[:, 1] = 2.0 * (x * y + w * z)
    axes[:, 2] = 2.0 * (x * z - w * y)
    return axes


def _placements(
    p0: NDArray[np.float64], p1: NDArray[np.float64], x_hint: NDArray[np.float64], radius: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``(K, 4, 4)`` matrices mapping the unit cylinder onto ``K`` capsule bodies at once.

    Capsule ``k`` runs from ``p0[k]`` to ``p1[k]`` (``(K, 3)``, scene frame, metres): the
    cylinder's y axis follows ``p1 - p0`` (scene y when the two points coincide); its x axis
    follows ``x_hint[k]`` made orthogonal to it (so the segment's twist is kept; a fixed
    helper axis when the hint is parallel); scaled by ``radius[k]`` (``(K,)``, m) across and
    by the length along, centred between the two points.
    """
    axis = p1 - p0
    length = np.sqrt(_rows_dot(axis, axis))
    has_length = length > 0
    y = axis / np.where(has_length, length, 1.0)[:, None]
    if not np.all(has_length):
        y[~has_length] = (0.0, 1.0, 0.0)
    x = x_hint - _rows_dot(x_hint, y)[:, None] * y
    norm = np.sqrt(_rows_dot(x, x))
    parallel = norm < 1e-9
    if np.any(parallel):
        helper = np.where((np.abs(y[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
        fallback = helper - _rows_dot(helper, y)[:, None] * y
        x[parallel] = fallback[parallel]
        norm[parallel] = np.sqrt(_rows_dot(fallback, fallback))[parallel]
    x = x / norm[:, None]
    z = x.take(_NEXT, axis=1) * y.take(_PREV, axis=1) - x.take(_PREV, axis=1) * y.take(_NEXT, axis=1)  # x × y
    matrices = np.zeros((len(axis), 4, 4))
    matrices[:, :3, 0] = x * radius[:, None]
    matrices[:, :3, 1] = y * length[:, None]
    matrices[:, :3, 2] = z * radius[:, None]
    matrices[:, :3, 3] = 0.5 * (p0 + p1)
    matrices[:, 3, 3] = 1.0
    return matrices


def _spheres(centers: NDArray[np.float64], radius: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(K, 4, 4)`` matrices placing the unit sphere at ``centers`` (``(K, 3)``, scene, m)
    scaled by ``radius`` (``(K,)``, m)."""
    matrices = np.zeros((len(centers), 4, 4))
    diagonal = np.arange(3)
    matrices[:, diagonal, diagonal] = radius[:, None]
    matrices[:, :3, 3] = centers
    matrices[:, 3, 3] = 1.0
    return matrices


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
            joint_radius[f"{name}_end"] = END_CAP_RADIUS_FACTOR * self._radius[name]
        self.joint_names = tuple(joint_names)
        self._joint_radius = joint_radius
        # Index arrays for build_arrays (segment indices in model order).
        index = {name: i for i, name in enumerate(self.segment_names)}
        n = len(self.segment_names)
        self._segment_radius = np.array([self._radius[name] for name in self.segment_names], dtype=float)
        self._connector_parent = np.array([index[p] for p, _c, _f in connectors], dtype=np.intp)
        self._connector_child = np.array([index[c] for _p, c, _f in connectors], dtype=np.intp)
        self._connector_fraction = np.array([f for _p, _c, f in connectors], dtype=float)
        connector_radius = CONNECTOR_RADIUS_FACTOR * self._segment_radius[self._connector_parent]
        self._capsule_radius = np.concatenate((self._segment_radius, connector_radius))  # segments, connectors
        # Joint spheres sit on proximal points (index i) or distal ends (index n + i) of the
        # stacked (proximal, distal) points, in joint_names order.
        centers = [0] + [index[s.name] for s in model.segments if s.joint is not None]
        centers += [n + index[name] for name in self._end_caps]
        self._joint_point_index = np.array(centers, dtype=np.intp)
        self._joint_sphere_radius = np.array([joint_radius[name] for name in self.joint_names], dtype=float)

    def display_alpha(self, mode: str, q_world_from_pelvis, heading_ref_rad: float | None) -> float:
        """The display rotation about the vertical for ``mode`` (see the module doc), radians."""
        if mode not in DISPLAY_MODES:
            raise ValueError(f"display mode must be one of {DISPLAY_MODES}, got {mode!r}")
        if mode == "body":
            return float(np.pi - rotation.heading_rad(np.asarray(q_world_from_pelvis, dtype=float)))
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
        chosen = [poses[name] for name in self.segment_names]
        return self.build_arrays(
            np.array([p.proximal_m for p in chosen], dtype=float),
            np.array([p.distal_m for p in chosen], dtype=float),
            np.array([p.q_world_from_segment for p in chosen], dtype=float),
            mode=mode, heading_ref_rad=heading_ref_rad, origin_world_m=origin_world_m)

    def build_arrays(
        self,
        proximal_m: NDArray[np.float64],
        distal_m: NDArray[np.float64],
        q_world_from_segment: NDArray[np.float64],
        mode: str = "world",
        heading_ref_rad: float | None = None,
        origin_world_m=(0.0, 0.0),
    ) -> FigureGeometry:
        """:meth:`build` from stacked arrays, segments in model order (vectorised over pieces).

        Args:
            proximal_m: ``(S, 3)`` proximal joint of each segment (world ENU, metres), as
                :func:`mimucap.core.skeleton.forward_kinematics_stacked` returns it.
            distal_m: ``(S, 3)`` distal end of each segment (world, metres).
            q_world_from_segment: ``(S, 4)`` scalar-first unit quaternions.
            mode, heading_ref_rad, origin_world_m: as for :meth:`build`.
        """
        n = len(self.segment_names)
        proximal_m = np.asarray(proximal_m, dtype=float)
        distal_m = np.asarray(distal_m, dtype=float)
        q = np.asarray(q_world_from_segment, dtype=float)
        if proximal_m.shape != (n, 3) or distal_m.shape != (n, 3) or q.shape != (n, 4):
            raise ValueError(f"the figure needs ({n}, 3) proximal and distal points and ({n}, 4) orientations "
                             f"in model order, got {proximal_m.shape}, {distal_m.shape} and {q.shape}")
        alpha = self.display_alpha(mode, q[0], heading_ref_rad)
        root_world = proximal_m[0]
        if mode == "body":
            shift = np.array([root_world[0], root_world[1], 0.0])
        else:
            shift = np.array([float(origin_world_m[0]), float(origin_world_m[1]), 0.0])
        r_scene_from_world_display = R_SCENE_FROM_WORLD @ _rz(alpha)
        r_transposed = r_scene_from_world_display.T  # row vectors: v_scene = v_world @ R.T

        # Proximal points (rows 0..S-1) then distal ends (rows S..2S-1), scene frame.
        points = (np.concatenate((proximal_m, distal_m)) - shift) @ r_transposed
        prox, dist = points[:n], points[n:]
        x_axis = _anterior_axes(q) @ r_transposed  # scene frame

        # Segments and connectors in one batch of capsules.
        parent, child = self._connector_parent, self._connector_child
        parent_prox = prox.take(parent, axis=0)
        anchor = parent_prox + self._connector_fraction[:, None] * (dist.take(parent, axis=0) - parent_prox)
        capsules = _placements(
            np.concatenate((prox, anchor)), np.concatenate((dist, prox.take(child, axis=0))),
            np.concatenate((x_axis, x_axis.take(parent, axis=0))), self._capsule_radius)
        seg_matrices, con_matrices = capsules[:n], capsules[n:]

        radius = self._segment_radius[:, None]
        front = seg_matrices[:, :3, 0] / radius
        marker_matrices = _spheres(0.5 * (prox + dist) + front * radius, MARKER_RADIUS_FACTOR * self._segment_radius)
        joint_matrices = _spheres(points.take(self._joint_point_index, axis=0), self._joint_sphere_radius)

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
            root_scene_m=prox[0].copy(),
            root_world_m=root_world.copy(),
            world_matrix=world_matrix,
            heading_alpha_rad=alpha,
        )


    def outline_pose(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The neutral outline's ``(proximal_m (S, 3), distal_m (S, 3), q_world_from_segment
        (S, 4))``: every segment in the body frame (the N-pose), facing
        :data:`OUTLINE_HEADING_RAD`, the root above the world origin (world ENU, metres)."""
        q = np.broadcast_to(skeleton.q_world_from_body_facing(OUTLINE_HEADING_RAD), (len(self.segment_names), 4))
        proximal, distal = skeleton.forward_kinematics_stacked(self.model, q, self.height_m)
        return proximal, distal, np.array(q)

    def build_outline(self, q_world_from_sensor: Mapping[str, NDArray[np.float64]],
                      segment_of_sensor: Mapping[str, str]) -> FigureGeometry:
        """The figure before a body calibration: the neutral outline (:meth:`outline_pose`, in
        the plain world, ``alpha = 0``, whatever the display mode) with a glyph for each sensor
        of ``segment_of_sensor`` (sensor id → segment) that has an orientation in
        ``q_world_from_sensor`` (sensor id → ``(4,)``, world ENU, scalar first), on the front of
        its segment halfway along, turned as the sensor is in the world. The outline has no
        anterior markers (zero radius): it shows no rotation of its own."""
        proximal, distal, q = self.outline_pose()
        geometry = self.build_arrays(proximal, distal, q)
        index = {name: i for i, name in enumerate(self.segment_names)}
        worn = [(sensor, segment) for sensor, segment in segment_of_sensor.items()
                if segment in index and sensor in q_world_from_sensor]
        matrices = np.zeros((len(worn), 4, 4))
        side = GLYPH_SIZE_RATIO * self.height_m
        for k, (sensor, segment) in enumerate(worn):
            i = index[segment]
            marker = geometry.marker_matrices[i]
            front = marker[:3, 3] - geometry.segment_matrices[i][:3, 3]   # centre → anterior face
            r_world_from_sensor = rotation.to_matrix(np.asarray(q_world_from_sensor[sensor], dtype=float))
            matrices[k, :3, :3] = R_SCENE_FROM_WORLD @ r_world_from_sensor * side
            matrices[k, :3, 3] = marker[:3, 3] + front / max(np.linalg.norm(front), 1e-12) * 0.5 * side
            matrices[k, 3, 3] = 1.0
        glyphs = SensorGlyphs(tuple(s for s, _ in worn), tuple(g for _, g in worn), matrices)
        markers = geometry.marker_matrices.copy()
        markers[:, :3, :3] = 0.0
        return replace(geometry, marker_matrices=markers, outline=True, sensor_glyphs=glyphs)


def emit_pose_figures(source) -> None:
    """Emit ``source``'s ``truth_frame`` (``(None, None)`` without a true pose) and then its
    ``frame`` event, each built only when someone listens; the live and review sessions share it
    so both keep the same order and the same empty truth."""
    events = source.events
    if events.truth_frame.callbacks:
        truth = source.truth_frame()
        events.truth_frame.emit(*(truth if truth is not None else (None, None)))
    if events.frame.callbacks:
        events.frame.emit(*source.frame())


def bodycal_heading(calibration) -> float:
    """Heading (rad, CCW from north) the subject faced in a body calibration's N-pose
    (:class:`~mimucap.core.bodycal.BodyCalibration`): the ``heading_ref_rad`` the body display
    mode turns to face the camera, live and in review alike."""
    return float(rotation.heading_rad(np.asarray(calibration.q_world_from_body, dtype=float)))
