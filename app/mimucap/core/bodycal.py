"""Body calibration: sensor-to-segment rotations from an N-pose (and a T-pose), live mapping.

Frames (``docs/conventions.md``): ``world`` is the frame the sensors' orientations are
expressed in (ENU for MimuCap; any frame works if its **up** unit vector ``up_world`` is
given); ``body`` has x forward, y up, z right (``z = x × y``); every ``segment`` frame is
parallel to ``body`` in the N-pose. Quaternions are scalar-first Hamilton ``(..., 4)``;
``q_A_from_B`` maps coordinates in B to coordinates in A.

Two ways to find the body's forward axis (Podoprosvetov, Aliseychik, Orlov, Rebrik,
"Calibration algorithm for MIMU sensors group", equations 3.1–3.7):

* **N-pose / T-pose.** The arm sensor's orientation change from the N-pose,
  ``q_delta(t) = q_world_from_arm(t) ⊗ q_world_from_arm(N)⁻¹``, is a rotation expressed in the
  world frame. Raising an arm sideways turns its long axis from down (−y_body) to the side
  (right arm: +z_body; left arm: −z_body). A rotation about +x_body takes +y to +z, hence −y
  to −z: the **left** arm turns by +90° about forward and the **right** arm by −90°.
  Two estimators use the whole N→T movement (see :class:`ArmAxisFit`):
  the *rotation axis* of Podoprosvetov et al. (principal axis of the rotation vectors ``log(q_delta(t))``,
  least squares through the origin; forward is ``+axis`` for the left arm and ``−axis`` for
  the right; its vertical component removed) and, by default, the *swing* of the arm's long
  axis ``d(t) = q_delta(t) · (−up)``, whose principal horizontal direction is the arm's side
  (right: ``z_body``, left: ``−z_body``; forward = ``up × right``). The arm hangs vertically in
  the N-pose, so any rotation taking it to the T-pose is a swing about a horizontal axis
  composed with a turn about the arm's own axis; the tilt of the rotation axis from horizontal
  measures only that turn, and removing the vertical component does not remove its effect on
  the heading (30° of humeral rotation during the raise turn the projected axis by about
  14°), while the swing ignores it. Both arms' horizontal estimates are averaged when both
  were raised (a raise plane turned forward cancels). ``y_body`` = up, ``z_body = x × y``.
* **Heading from a named sensor axis** (as OpenSense's ``base_heading_axis``): one sensor
  axis (e.g. the pelvis sensor's +z) points forward in the calibration pose; its horizontal
  projection is ``x_body``.

Then, per segment (Podoprosvetov et al., 3.8–3.10), with the N-pose averaged over its window:
``q_segment_from_sensor = q_segment_from_body(N) ⊗ q_body_from_world ⊗ q_world_from_sensor(N)``,
where ``q_segment_from_body(N)`` is the identity for a true N-pose. ``q_world_from_sensor(N)``
may be given per sensor (``npose_orientations``) instead of the mean of the filter's estimate:
:func:`static_alignment` of the still window's mean specific force and calibrated magnetic field
is what the orientation filter converges to, whereas its estimate at that moment may still carry
a transient (a filter that learns the heading after a new magnetometer calibration settles over
tens of seconds to a fraction of a degree; an error left in ``q_world_from_sensor(N)`` stays in
the segment's rotation about its long axis for the whole recording). Live (3.11):
``q_world_from_segment(t) = q_world_from_sensor(t) ⊗ q_sensor_from_segment``.

The display modes of seed section 4.3 (equations 4.2–4.3) are drawn by
:mod:`mimucap.session.views.skeleton_figure`, from the calibration's ``q_world_from_body``.

Checks: each pose window must be still (every sample within ``stillness_limit_deg`` of the
window's mean orientation), or the calibration is refused naming the sensor that moved; the
quality figures (arm raise and rotation angles, tilt of the raw rotation axis from horizontal, left/right
disagreement, stillness, fit residual) give a verdict ``good``, ``acceptable`` or
``poor`` with the reasons. One arm raised *forward* instead of sideways cannot be told from
a sideways raise by a subject turned 90° (the arm's motion is the same); with both arms
raised it shows as a left/right disagreement near 180° and is refused.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mimucap.core import rotation as rot

FloatArray = NDArray[np.float64]

VERDICTS = ("good", "acceptable", "poor")

#: Sensors tried, in order, as the moving arm sensor of each side.
ARM_SEGMENTS = {
    "right": ("upper_arm_r", "forearm_r", "hand_r"),
    "left": ("upper_arm_l", "forearm_l", "hand_l"),
}


class CalibrationRefused(ValueError):
    """The poses cannot give a calibration; ``reason`` says why, ``figures`` what was measured."""

    def __init__(self, reason: str, figures: Mapping[str, object] | None = None) -> None:
        super().__init__(reason)
        self.reason = reason
        self.figures = dict(figures or {})


@dataclass(frozen=True)
class BodyCalSettings:
    """Limits of the body calibration (angles in degrees).

    ``stillness_limit_deg`` (3.0): a pose window is refused when any sample of a used sensor
    deviates more than this from the window's mean orientation; ``stillness_good_deg`` (1.5):
    above it the verdict is at most acceptable. ``min_arm_angle_deg`` (30): an arm that rose
    less than this from N to T was not raised (its axis is undefined). Arm rotation angle: good
    within ``arm_angle_good_deg`` (20) of ``arm_angle_expected_deg`` (90), acceptable within
    ``arm_angle_acceptable_deg`` (35) (the raise angle with the swing estimator, the rotation
    angle with the rotation-axis one). Left/right disagreement of the horizontal forward
    estimates: good ≤ 10, acceptable ≤ 20, refused above ``lr_refuse_deg`` (45: such axes
    cannot be averaged). ``forward_from`` (``"swing"``): which estimator of
    :class:`ArmAxisFit` gives the forward axis, ``"swing"`` (the arm's long axis; default) or
    ``"rotation_axis"`` (Podoprosvetov et al.'s). Residual of the estimator in use (swing: the arm's RMS
    angle from its raise plane; rotation axis: RMS distance of the rotation vectors from the
    axis): good ≤ 5, acceptable ≤ 10. Raw rotation-axis tilt from horizontal (the arm turned
    about its own long axis while raised): good ≤ 15; above, acceptable with the swing
    estimator (which that rotation does not affect) and, with the rotation-axis estimator,
    acceptable ≤ 30 and poor above. ``movement_min_deg`` (5): movement samples turned less than
    this are left out of the rotation-axis fit (their direction is noise). Heading mode: the
    named axis' tilt from horizontal is good ≤ 30, acceptable ≤ 60, refused above
    ``heading_tilt_refuse_deg`` (80).
    """

    stillness_limit_deg: float = 3.0
    stillness_good_deg: float = 1.5
    min_arm_angle_deg: float = 30.0
    arm_angle_expected_deg: float = 90.0
    arm_angle_good_deg: float = 20.0
    arm_angle_acceptable_deg: float = 35.0
    axis_tilt_good_deg: float = 15.0
    axis_tilt_acceptable_deg: float = 30.0
    lr_good_deg: float = 10.0
    lr_acceptable_deg: float = 20.0
    lr_refuse_deg: float = 45.0
    axis_residual_good_deg: float = 5.0
    axis_residual_acceptable_deg: float = 10.0
    movement_min_deg: float = 5.0
    heading_tilt_good_deg: float = 30.0
    heading_tilt_acceptable_deg: float = 60.0
    heading_tilt_refuse_deg: float = 80.0
    forward_from: str = "swing"

    def __post_init__(self) -> None:
        check_settings(self, "forward_from", ("swing", "rotation_axis"))


def check_settings(settings: object, choice: str, options: Sequence[str]) -> None:
    """``ValueError`` naming the field of a settings dataclass whose ``choice`` field is not one
    of ``options`` or whose other fields (angles, limits) are not finite and non-negative."""
    kind = type(settings).__name__
    if getattr(settings, choice) not in options:
        raise ValueError(f"{kind}.{choice} must be one of {', '.join(options)}, got {getattr(settings, choice)!r}")
    for name, value in settings.__dict__.items():
        if name != choice and (not np.isfinite(value) or value < 0.0):
            raise ValueError(f"{kind}.{name} must be a finite non-negative number, got {value}")


DEFAULT_SETTINGS = BodyCalSettings()


@dataclass(frozen=True)
class PoseStillness:
    """How still one sensor was in one pose window (deg from the window's mean orientation)."""

    pose: str
    sensor: str
    max_deviation_deg: float
    rms_deviation_deg: float
    n_samples: int


@dataclass(frozen=True)
class ArmAxisFit:
    """The forward axis from one arm's N→T movement, by two estimators.

    *Swing*: the direction of the arm's long axis (hanging, −up, in the N-pose) carried along
    the movement, ``d(t) = q_delta(t) · (−up)``; its horizontal part swings out to the side of
    the body; the principal horizontal direction of these vectors is the lateral axis, and
    forward is perpendicular to it. Turning the arm about its own long axis does not move
    ``d``, so this estimate ignores humeral rotation (palms turned forward or down).
    *Rotation axis* (Podoprosvetov et al.'s): principal axis of the rotation vectors ``log(q_delta(t))``,
    vertical part removed. An arm turned about its own axis while raised tilts this axis and
    turns its horizontal part (30° of such rotation: about 14°).

    ``forward_world`` (3,) the horizontal unit forward estimate in use (``settings.forward_from``);
    ``swing_forward_world`` and ``axis_forward_world`` both estimates; ``raw_forward_world`` the
    signed rotation axis before its vertical part is removed; ``rotation_angle_deg`` the angle
    between the mean N-pose and T-pose orientations (raise and turn about the arm's own axis);
    ``raise_angle_deg`` the angle the long axis rose from hanging down; ``axis_tilt_deg`` the raw axis' angle from
    horizontal; ``axis_residual_deg`` RMS distance of the rotation vectors from the fitted axis;
    ``swing_residual_deg`` RMS angle of the arm's direction from its fitted vertical raise plane;
    ``axis_vs_swing_deg`` the angle between the two horizontal estimates; ``n_samples`` samples.
    """

    side: str
    sensor: str
    forward_world: FloatArray
    swing_forward_world: FloatArray
    axis_forward_world: FloatArray
    raw_forward_world: FloatArray
    rotation_angle_deg: float
    raise_angle_deg: float
    axis_tilt_deg: float
    axis_residual_deg: float
    swing_residual_deg: float
    axis_vs_swing_deg: float
    n_samples: int


@dataclass(frozen=True)
class CalibrationQuality:
    """Quality figures and the verdict (``good``, ``acceptable`` or ``poor``) with reasons.

    ``doubtful_sensors``: the sensors whose orientation was doubtful during the poses
    (:mod:`mimucap.core.pipeline.doubt_reasons`; :func:`with_doubtful_sensors`).
    """

    method: str
    stillness: tuple[PoseStillness, ...]
    arms: tuple[ArmAxisFit, ...] = ()
    left_right_disagreement_deg: float | None = None
    heading_axis_tilt_deg: float | None = None
    verdict: str = "good"
    problems: tuple[str, ...] = ()
    doubtful_sensors: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        """JSON-ready figures (degrees, plain lists)."""
        return {
            "method": self.method,
            "verdict": self.verdict,
            "problems": list(self.problems),
            "doubtful_sensors": list(self.doubtful_sensors),
            "stillness": [
                {"pose": s.pose, "sensor": s.sensor, "max_deviation_deg": s.max_deviation_deg,
                 "rms_deviation_deg": s.rms_deviation_deg, "n_samples": s.n_samples}
                for s in self.stillness
            ],
            "arms": [
                {"side": a.side, "sensor": a.sensor, "rotation_angle_deg": a.rotation_angle_deg,
                 "raise_angle_deg": a.raise_angle_deg,
                 "axis_tilt_deg": a.axis_tilt_deg, "axis_residual_deg": a.axis_residual_deg,
                 "swing_residual_deg": a.swing_residual_deg, "axis_vs_swing_deg": a.axis_vs_swing_deg,
                 "n_samples": a.n_samples, "forward_world": a.forward_world.tolist(),
                 "swing_forward_world": a.swing_forward_world.tolist(),
                 "axis_forward_world": a.axis_forward_world.tolist(),
                 "raw_forward_world": a.raw_forward_world.tolist()}
                for a in self.arms
            ],
            "left_right_disagreement_deg": self.left_right_disagreement_deg,
            "heading_axis_tilt_deg": self.heading_axis_tilt_deg,
        }


@dataclass(frozen=True)
class BodyCalibration:
    """A body calibration.

    ``q_world_from_body`` (4,); ``up_world`` (3,) the world's up unit vector;
    ``sensors`` segment → sensor id; ``q_segment_from_sensor`` segment → (4,); ``details``
    further JSON-ready entries written beside them (pose windows, where and when it was made,
    the magnetometer calibrations its N-pose orientations were computed with), kept on reading.
    """

    q_world_from_body: FloatArray
    up_world: FloatArray
    sensors: Mapping[str, str]
    q_segment_from_sensor: Mapping[str, FloatArray]
    quality: CalibrationQuality
    details: Mapping[str, object] = field(default_factory=dict)

    @property
    def segments(self) -> tuple[str, ...]:
        return tuple(self.sensors)

    def to_dict(self) -> dict:
        """The calibration as JSON-ready data (quaternions as ``[w, x, y, z]`` lists)."""
        return {
            "format": "mimucap-body-calibration",
            "format_version": 1,
            "method": self.quality.method,
            "q_world_from_body": self.q_world_from_body.tolist(),
            "up_world": self.up_world.tolist(),
            "segments": {
                seg: {"sensor": self.sensors[seg],
                      "q_segment_from_sensor": self.q_segment_from_sensor[seg].tolist()}
                for seg in self.sensors
            },
            "quality": self.quality.to_dict(),
            "verdict": self.quality.verdict,
            **self.details,
        }

    @classmethod
    def from_dict(cls, data: Mapping, origin: str = "calibration") -> "BodyCalibration":
        """Inverse of :meth:`to_dict` (quality figures are kept as the verdict and problems;
        every other entry as ``details``)."""
        if not isinstance(data, Mapping) or data.get("format") != "mimucap-body-calibration":
            raise ValueError(f"{origin}: not a MimuCap body calibration (format 'mimucap-body-calibration')")
        if data.get("format_version") != 1:
            raise ValueError(f"{origin}: unsupported body calibration version {data.get('format_version')!r}")
        try:
            q_body = unit_quaternion(data["q_world_from_body"], f"{origin}: q_world_from_body")
            up = np.asarray(data["up_world"], dtype=np.float64)
            if up.shape != (3,) or not np.isclose(np.linalg.norm(up), 1.0, atol=1e-6):
                raise ValueError(f"{origin}: up_world must be a unit 3-vector")
            sensors, q_seg = {}, {}
            for seg, entry in data["segments"].items():
                sensors[seg] = str(entry["sensor"])
                q_seg[seg] = unit_quaternion(entry["q_segment_from_sensor"], f"{origin}: segment {seg}")
            quality_data = data.get("quality", {})
            quality = CalibrationQuality(
                method=str(data.get("method", quality_data.get("method", ""))),
                stillness=(),
                verdict=str(data.get("verdict", quality_data.get("verdict", "good"))),
                problems=tuple(quality_data.get("problems", ())),
                doubtful_sensors=tuple(str(sensor) for sensor in quality_data.get("doubtful_sensors", ())),
            )
        except (KeyError, TypeError, AttributeError) as error:
            raise ValueError(f"{origin}: malformed body calibration ({error!r})") from None
        if not sensors:
            raise ValueError(f"{origin}: the calibration has no segments")
        details = {key: value for key, value in data.items() if key not in _DOCUMENT_KEYS}
        return cls(q_body, up, sensors, q_seg, quality, details)


#: The entries :meth:`BodyCalibration.to_dict` writes itself (the others are ``details``).
_DOCUMENT_KEYS = ("format", "format_version", "method", "q_world_from_body", "up_world", "segments", "quality",
                  "verdict")


def with_doubtful_sensors(calibration: BodyCalibration, reasons: Mapping[str, str]) -> BodyCalibration:
    """``calibration`` made from orientations that were doubtful during its poses (``reasons``
    sensor → why, in words; :mod:`mimucap.core.pipeline.doubt_reasons`): the sensors are recorded, the reason
    joins the problems and a good verdict becomes acceptable (every joint angle computed with
    it is then doubtful). Unchanged when ``reasons`` is empty."""
    if not reasons:
        return calibration
    quality = calibration.quality
    by_reason: dict[str, list[str]] = {}
    for sensor, why in sorted(reasons.items()):
        by_reason.setdefault(why, []).append(sensor)
    problem = ("orientations doubtful during the poses: "
               + "; ".join(f"{', '.join(sensors)} ({why})" for why, sensors in by_reason.items()))
    verdict = "acceptable" if quality.verdict == "good" else quality.verdict
    quality = replace(quality, verdict=verdict, problems=quality.problems + (problem,),
                      doubtful_sensors=tuple(sorted(reasons)))
    return replace(calibration, quality=quality)


def unit_quaternion(value: object, what: str) -> FloatArray:
    """``value`` as a unit quaternion (4,); ``ValueError`` naming ``what`` unless it is four
    finite numbers of norm 1 (within 1e-3)."""
    q = np.asarray(value, dtype=np.float64)
    if q.shape != (4,) or not np.all(np.isfinite(q)) or abs(np.linalg.norm(q) - 1.0) > 1e-3:
        raise ValueError(f"{what}: expected a unit quaternion [w, x, y, z], got {value!r}")
    return q / np.linalg.norm(q)


# --------------------------------------------------------------------------------------------
# Building blocks
# --------------------------------------------------------------------------------------------

def unit_vector(v: ArrayLike, what: str) -> FloatArray:
    """``v`` (3,) normalised; ``ValueError`` naming ``what`` for a zero or non-finite vector."""
    v = np.asarray(v, dtype=np.float64)
    n = np.linalg.norm(v)
    if v.shape != (3,) or not np.isfinite(n) or n < 1e-12:
        raise ValueError(f"{what} must be a non-zero 3-vector, got {v}")
    return v / n


def horizontal(v_world: ArrayLike, up_world: ArrayLike) -> FloatArray:
    """``v`` without its component along ``up`` (``(..., 3)``), not normalised."""
    v = np.asarray(v_world, dtype=np.float64)
    up = np.asarray(up_world, dtype=np.float64)
    return v - np.sum(v * up, axis=-1, keepdims=True) * up


def tilt_from_horizontal_deg(v_world: ArrayLike, up_world: ArrayLike) -> FloatArray:
    """Angle (deg, 0..90) between the direction ``v`` and the horizontal plane."""
    v = np.asarray(v_world, dtype=np.float64)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    return np.degrees(np.arcsin(np.clip(np.abs(np.sum(v * up_world, axis=-1)), 0.0, 1.0)))


def static_alignment(acc_m_s2: ArrayLike, mag_uT: ArrayLike, declination_rad: float = 0.0,
                     field_uT: float | None = None, field_tolerance: float = 0.15) -> FloatArray:
    """``q_world_from_sensor`` (4,) of a sensor at rest (world ENU: y magnetic north, or true
    north turned by ``declination_rad``, positive when magnetic north lies east of true north,
    as the orientation filter uses it) from its samples over a still window: ``acc_m_s2``
    (K, 3) specific force (its mean points up) and ``mag_uT`` (K, 3) calibrated magnetic field,
    both in the sensor frame. East is ``m × up``, north ``up × east`` (the TRIAD construction).
    ``ValueError`` when the window is empty or not finite, the field is (nearly) vertical, or,
    given the undisturbed ``field_uT`` (µT, e.g. the magnetometer calibration's), the mean
    field's magnitude differs from it by more than the fraction ``field_tolerance`` (a local
    disturbance, which the orientation filter would reject as well)."""
    acc = np.asarray(acc_m_s2, dtype=np.float64)
    mag = np.asarray(mag_uT, dtype=np.float64)
    if acc.ndim != 2 or acc.shape[1] != 3 or mag.shape != acc.shape or acc.shape[0] == 0:
        raise ValueError(f"static alignment needs (K, 3) accelerometer and magnetometer windows, got "
                         f"{acc.shape} and {mag.shape}")
    if not (np.all(np.isfinite(acc)) and np.all(np.isfinite(mag))):
        raise ValueError("static alignment: the window holds non-finite samples")
    up = unit_vector(acc.mean(axis=0), "mean specific force")
    field = mag.mean(axis=0)
    magnitude = float(np.linalg.norm(field))
    if field_uT is not None and abs(magnitude - field_uT) > field_tolerance * field_uT:
        raise ValueError(f"static alignment: the field is disturbed ({magnitude:.1f} µT where "
                         f"{field_uT:.1f} µT is expected)")
    east = np.cross(field, up)
    norm = float(np.linalg.norm(east))
    if norm < 1e-3 * max(magnitude, 1e-9):
        raise ValueError("static alignment: the magnetic field is vertical (no horizontal part gives north)")
    east /= norm
    north = np.cross(up, east)
    q = rot.from_matrix(np.stack([east, north, up]))
    if declination_rad:
        q = rot.multiply(rot.from_axis_angle([0.0, 0.0, 1.0], -float(declination_rad)), q)
    return rot.canonical(q)


def turned_toward(q_world_from_sensor: ArrayLike, q_track: ArrayLike, share: float,
                  up_world: ArrayLike = (0.0, 0.0, 1.0)) -> FloatArray:
    """``q_world_from_sensor`` (4,) turned about ``up_world`` by ``share`` (0-1) of the mean
    heading by which the orientations ``q_track`` (K, 4) of the same sensor lie from it (the
    circular mean of each one's turn about the vertical): 0 keeps it, 1 takes the track's
    heading and keeps its own tilt."""
    q = np.asarray(q_world_from_sensor, dtype=np.float64)
    track = np.asarray(q_track, dtype=np.float64).reshape(-1, 4)
    track = track[np.isfinite(track).all(axis=1)]
    if not len(track) or share <= 0.0:
        return q
    up = unit_vector(up_world, "up")
    error = rot.multiply(track, rot.conjugate(q))
    turn = 2.0 * np.arctan2(error[:, 1:] @ up, error[:, 0])
    mean = float(np.angle(np.mean(np.exp(1j * turn))))
    return rot.canonical(rot.multiply(rot.from_axis_angle(up, min(float(share), 1.0) * mean), q))


def q_world_from_body_from_forward(forward_world: ArrayLike, up_world: ArrayLike) -> FloatArray:
    """``q_world_from_body`` (4,) with x = horizontal part of ``forward``, y = up, z = x × y."""
    up = unit_vector(up_world, "up_world")
    x = horizontal(unit_vector(forward_world, "forward axis"), up)
    norm = np.linalg.norm(x)
    if norm < 1e-6:
        raise ValueError("the forward axis is vertical: no heading can be taken from it")
    x = x / norm
    z = np.cross(x, up)
    return rot.from_matrix(np.column_stack((x, up, z)))


def pose_window(t_s: ArrayLike, window_s: tuple[float, float], what: str) -> slice:
    """Index slice of the samples with ``t0 <= t <= t1`` (s); the window must lie in the recording."""
    t = np.asarray(t_s, dtype=np.float64)
    t0, t1 = float(window_s[0]), float(window_s[1])
    if not (np.isfinite(t0) and np.isfinite(t1)) or t1 < t0:
        raise ValueError(f"{what} window {t0:g}:{t1:g} s is not an interval (start must not exceed end)")
    tolerance = 1e-9 * max(1.0, abs(t[-1]))
    if t0 < t[0] - tolerance or t1 > t[-1] + tolerance:
        raise ValueError(
            f"{what} window {t0:g}:{t1:g} s lies outside the recording ({t[0]:g}:{t[-1]:g} s)"
        )
    start = int(np.searchsorted(t, t0 - tolerance, side="left"))
    stop = int(np.searchsorted(t, t1 + tolerance, side="right"))
    if stop <= start:
        raise ValueError(f"{what} window {t0:g}:{t1:g} s holds no sample")
    return slice(start, stop)


def pose_stillness(q_window: ArrayLike, pose: str, sensor: str) -> tuple[FloatArray, PoseStillness]:
    """Mean orientation (4,) of a window ``(K, 4)`` (Markley average) and its stillness figures."""
    q = np.asarray(q_window, dtype=np.float64)
    if q.ndim != 2 or q.shape[0] == 0 or q.shape[1] != 4:
        raise ValueError(f"{pose}: sensor {sensor}: expected a (K, 4) window of quaternions, got {q.shape}")
    if not np.all(np.isfinite(q)):
        raise ValueError(f"{pose}: sensor {sensor}: NaN quaternion in the pose window")
    mean = rot.average(q)
    deviation = np.degrees(rot.angle_between(mean, q))
    figures = PoseStillness(pose, sensor, float(deviation.max()), float(np.sqrt(np.mean(deviation**2))), int(q.shape[0]))
    return mean, figures


def fit_rotation_axis(rotvecs_world: ArrayLike, reference_world: ArrayLike) -> tuple[FloatArray, float]:
    """Principal axis (3,) of rotation vectors ``(M, 3)`` and their RMS distance from it (rad).

    Least squares through the origin: the eigenvector of ``Σ r rᵀ`` with the largest
    eigenvalue, signed so that it points along ``reference`` (3,).
    """
    r = np.asarray(rotvecs_world, dtype=np.float64)
    if r.ndim != 2 or r.shape[0] == 0:
        raise ValueError("fit_rotation_axis needs at least one rotation vector")
    _, vectors = np.linalg.eigh(r.T @ r)
    axis = vectors[:, -1]
    if np.dot(axis, reference_world) < 0.0:
        axis = -axis
    off_axis = r - np.outer(r @ axis, axis)
    return axis, float(np.sqrt(np.mean(np.sum(off_axis**2, axis=1))))


def fit_swing_direction(
    d_world: ArrayLike, up_world: ArrayLike, reference_world: ArrayLike
) -> tuple[FloatArray, float]:
    """Principal horizontal direction (3,) of arm directions ``d`` (M, 3) and their RMS angle
    (rad) from the vertical plane through it; signed along ``reference`` (3,).

    Least squares through the origin on the horizontal parts (``Σ h hᵀ``, largest
    eigenvalue), so directions close to vertical weigh little.
    """
    up = unit_vector(up_world, "up_world")
    d = np.asarray(d_world, dtype=np.float64).reshape(-1, 3)
    h = horizontal(d, up)
    _, vectors = np.linalg.eigh(h.T @ h)
    lateral = horizontal(vectors[:, -1], up)
    lateral = lateral / np.linalg.norm(lateral)
    if np.dot(lateral, reference_world) < 0.0:
        lateral = -lateral
    normal = np.cross(up, lateral)
    units = d / np.linalg.norm(d, axis=1, keepdims=True)
    off_plane = np.arcsin(np.clip(units @ normal, -1.0, 1.0))
    return lateral, float(np.sqrt(np.mean(off_plane**2)))


def fit_arm_axis(
    side: str,
    sensor: str,
    q_world_from_arm_npose: ArrayLike,
    q_world_from_arm_tpose: ArrayLike,
    q_world_from_arm_movement: ArrayLike,
    up_world: ArrayLike,
    settings: BodyCalSettings = DEFAULT_SETTINGS,
) -> ArmAxisFit:
    """The forward axis from one arm's movement (both estimators of :class:`ArmAxisFit`).

    ``q_world_from_arm_npose`` and ``_tpose`` (4,) are the mean pose orientations;
    ``q_world_from_arm_movement`` (M, 4) every sample from the end of the N-pose to the end of
    the T-pose. Signs (module docstring): the right arm turns by −90° about forward (its long
    axis swings to the right), the left arm by +90° (its long axis swings to the left); forward
    is ``up × right``. Raises :class:`CalibrationRefused` when the arm rose less than
    ``settings.min_arm_angle_deg``.
    """
    if side not in ARM_SEGMENTS:
        raise ValueError(f"arm side must be 'left' or 'right', got {side!r}")
    up = unit_vector(up_world, "up_world")
    q_inv_n = rot.conjugate(np.asarray(q_world_from_arm_npose, dtype=np.float64))
    q_delta_t = rot.multiply(np.asarray(q_world_from_arm_tpose, dtype=np.float64), q_inv_n)
    r_t = rot.to_rotvec(q_delta_t)
    angle_deg = float(np.degrees(np.linalg.norm(r_t)))
    movement = np.asarray(q_world_from_arm_movement, dtype=np.float64).reshape(-1, 4)
    q_delta = np.vstack((rot.multiply(movement, q_inv_n), q_delta_t[None, :]))
    # Swing of the long axis (hanging in the N-pose).
    d = rot.rotate(q_delta, -up)
    d_t = d[-1]
    raise_deg = float(np.degrees(np.arccos(np.clip(-np.dot(d_t, up), -1.0, 1.0))))
    if raise_deg < settings.min_arm_angle_deg:
        raise CalibrationRefused(
            f"the {side} arm (sensor {sensor}) was not raised: it rose {raise_deg:.1f}° between "
            f"N-pose and T-pose (at least {settings.min_arm_angle_deg:g}° needed, about "
            f"{settings.arm_angle_expected_deg:g}° expected; it turned {angle_deg:.1f}° in all)",
            {"side": side, "sensor": sensor, "raise_angle_deg": raise_deg, "rotation_angle_deg": angle_deg},
        )
    lateral, swing_residual = fit_swing_direction(d, up, d_t)
    right = lateral if side == "right" else -lateral
    swing_forward = np.cross(up, right)
    # Rotation axis (Podoprosvetov et al.).
    rotvecs = rot.to_rotvec(q_delta)
    moved = np.linalg.norm(rotvecs, axis=1) >= np.radians(settings.movement_min_deg)
    rotvecs = np.vstack((rotvecs[moved], r_t[None, :]))
    axis, axis_residual = fit_rotation_axis(rotvecs, r_t)
    raw_forward = axis if side == "left" else -axis
    flat = horizontal(raw_forward, up)
    norm = np.linalg.norm(flat)
    axis_forward = flat / norm if norm > 1e-6 else swing_forward
    cos = float(np.clip(np.dot(axis_forward, swing_forward), -1.0, 1.0))
    return ArmAxisFit(
        side=side,
        sensor=sensor,
        forward_world=swing_forward if settings.forward_from == "swing" else axis_forward,
        swing_forward_world=swing_forward,
        axis_forward_world=axis_forward,
        raw_forward_world=raw_forward,
        rotation_angle_deg=angle_deg,
        raise_angle_deg=raise_deg,
        axis_tilt_deg=float(tilt_from_horizontal_deg(raw_forward, up)),
        axis_residual_deg=float(np.degrees(axis_residual)),
        swing_residual_deg=float(np.degrees(swing_residual)),
        axis_vs_swing_deg=float(np.degrees(np.arccos(cos))),
        n_samples=int(q_delta.shape[0]),
    )


def grade(value: float, good: float, acceptable: float) -> int:
    """0 (good) when ``value <= good``, 1 (acceptable) when ``value <= acceptable``, else 2 (poor)."""
    return 0 if value <= good else (1 if value <= acceptable else 2)


def verdict_of(checks: Sequence[tuple[int, str]]) -> tuple[str, tuple[str, ...]]:
    """The worst grade of ``checks`` ``(grade, words)`` as a verdict, and the words of every
    check that was not good."""
    worst = max((level for level, _ in checks), default=0)
    return VERDICTS[worst], tuple(text for level, text in checks if level > 0)


def stillness_checks(stillness: Sequence[PoseStillness], limit_deg: float, good_deg: float) -> list[tuple[int, str]]:
    """Graded checks of pose windows: :class:`CalibrationRefused` naming the first sensor that
    moved more than ``limit_deg`` from its window's mean orientation; acceptable above ``good_deg``."""
    checks = []
    for s in stillness:
        if s.max_deviation_deg > limit_deg:
            raise CalibrationRefused(
                f"sensor {s.sensor} moved during the {s.pose}: {s.max_deviation_deg:.1f}° from its "
                f"mean orientation (limit {limit_deg:g}°); repeat the pose standing still",
                {"pose": s.pose, "sensor": s.sensor, "max_deviation_deg": s.max_deviation_deg},
            )
        if s.max_deviation_deg > good_deg:
            checks.append((1, f"sensor {s.sensor} was not quite still in the {s.pose} "
                              f"({s.max_deviation_deg:.1f}°)"))
    return checks


def window_means(
    q_world_from_sensor: Mapping[str, ArrayLike], sensors: Sequence[str], window: slice, pose: str = "N-pose"
) -> tuple[dict[str, FloatArray], list[PoseStillness]]:
    """Mean orientation (4,) and stillness figures of each sensor over one pose window."""
    means, figures = {}, []
    for sensor in sensors:
        mean, still = pose_stillness(np.asarray(q_world_from_sensor[sensor])[window], pose, sensor)
        means[sensor] = mean
        figures.append(still)
    return means, figures


def check_mapping(
    mapping: Mapping[str, str],
    available_sensors: Sequence[str],
    model_segments: Sequence[str] | None = None,
) -> dict[str, str]:
    """Validate ``mapping`` (segment → sensor id) against the recording and the model."""
    if not mapping:
        raise ValueError("the sensor-to-segment mapping is empty")
    result: dict[str, str] = {}
    used: dict[str, str] = {}
    for segment, sensor in mapping.items():
        segment, sensor = str(segment).strip(), str(sensor).strip()
        if not segment:
            raise ValueError(f"sensor {sensor!r} is mapped to no segment")
        if not sensor:
            raise ValueError(f"segment {segment!r} has no sensor")
        if model_segments is not None and segment not in model_segments:
            raise ValueError(
                f"unknown segment {segment!r} in the mapping; the model has: {', '.join(model_segments)}"
            )
        if sensor not in available_sensors:
            raise ValueError(
                f"unknown sensor {sensor!r} in the mapping (for segment {segment}); the recording "
                f"has: {', '.join(available_sensors)}"
            )
        if sensor in used:
            raise ValueError(f"sensor {sensor} is mapped to two segments: {used[sensor]} and {segment}")
        used[sensor] = segment
        result[segment] = sensor
    return result


def _segment_rotations(
    q_world_from_body: FloatArray,
    means: Mapping[str, FloatArray],
    mapping: Mapping[str, str],
    q_segment_from_body_npose: Mapping[str, ArrayLike] | None,
) -> dict[str, FloatArray]:
    q_body_from_world = rot.conjugate(q_world_from_body)
    result = {}
    for segment, sensor in mapping.items():
        q_body_from_sensor = rot.multiply(q_body_from_world, means[sensor])
        q_seg_from_body = rot.identity()
        if q_segment_from_body_npose and segment in q_segment_from_body_npose:
            q_seg_from_body = rot.normalize(q_segment_from_body_npose[segment])
        result[segment] = rot.canonical(rot.multiply(q_seg_from_body, q_body_from_sensor))
    return result


# --------------------------------------------------------------------------------------------
# The two calibrations
# --------------------------------------------------------------------------------------------

def calibrate_npose_tpose(
    t_s: ArrayLike,
    q_world_from_sensor: Mapping[str, ArrayLike],
    mapping: Mapping[str, str],
    npose_s: tuple[float, float],
    tpose_s: tuple[float, float],
    up_world: ArrayLike = (0.0, 0.0, 1.0),
    arms: str = "auto",
    settings: BodyCalSettings = DEFAULT_SETTINGS,
    q_segment_from_body_npose: Mapping[str, ArrayLike] | None = None,
    npose_orientations: Mapping[str, ArrayLike] | None = None,
) -> BodyCalibration:
    """N-pose / T-pose calibration of a recording.

    ``t_s`` (N,) s; ``q_world_from_sensor`` sensor id → (N, 4); ``mapping`` segment → sensor
    id; ``npose_s`` and ``tpose_s`` the pose windows ``(start, end)`` in seconds, the T-pose
    after the N-pose; ``up_world`` the world's up direction; ``arms`` ``"auto"`` (every arm
    with a sensor that was raised), ``"left"``, ``"right"`` or ``"both"``.
    ``q_segment_from_body_npose`` (optional, segment → (4,)) for a calibration pose in which
    some segment is not parallel to the body. ``npose_orientations`` (optional, sensor id →
    ``q_world_from_sensor`` (4,)) replaces a sensor's mean N-pose orientation in its segment's
    rotation (e.g. :func:`static_alignment` of the N-pose window); the stillness checks use the
    orientation tracks, and an arm's movement is its track's rotation from the track's N-pose
    applied to the given N-pose orientation: the gyroscope's rotation over the few seconds of
    the raise, anchored where the still sensor measured it, so that a slow heading error of the
    track (the smoother carries a later magnetic disturbance back over tens of seconds) does not
    turn the forward direction. Raises :class:`CalibrationRefused` (a
    ``ValueError``) when a pose was not still, no arm was raised or the arms disagree.
    """
    t = np.asarray(t_s, dtype=np.float64)
    up = unit_vector(up_world, "up_world")
    mapping = check_mapping(mapping, list(q_world_from_sensor))
    n_window = pose_window(t, npose_s, "N-pose")
    t_window = pose_window(t, tpose_s, "T-pose")
    if t_window.start < n_window.stop:
        raise ValueError(
            f"the T-pose window {tpose_s[0]:g}:{tpose_s[1]:g} s must start after the N-pose window "
            f"{npose_s[0]:g}:{npose_s[1]:g} s ends"
        )
    if arms not in ("auto", "left", "right", "both"):
        raise ValueError(f"arms must be auto, left, right or both, got {arms!r}")
    means, stillness = window_means(q_world_from_sensor, list(dict.fromkeys(mapping.values())), n_window)
    candidates = {}
    for side, segments in ARM_SEGMENTS.items():
        segment = next((s for s in segments if s in mapping), None)
        if segment is not None:
            candidates[side] = mapping[segment]
    wanted = ["left", "right"] if arms in ("auto", "both") else [arms]
    if arms != "auto":
        missing = [side for side in wanted if side not in candidates]
        if missing:
            raise ValueError(f"no sensor on the {' or '.join(missing)} arm (map upper_arm_l/r)")
    sides = [side for side in wanted if side in candidates]
    if not sides:
        raise ValueError("an N/T-pose calibration needs a sensor on an arm (map upper_arm_l or upper_arm_r)")
    given = {sensor: unit_quaternion(q, f"N-pose orientation of sensor {sensor}")
             for sensor, q in (npose_orientations or {}).items() if sensor in means}
    fits: list[ArmAxisFit] = []
    refusals: list[CalibrationRefused] = []
    for side in sides:
        sensor = candidates[side]
        q = np.asarray(q_world_from_sensor[sensor], dtype=np.float64)
        q_n = means[sensor]
        if sensor in given:
            q = rot.multiply(rot.multiply(given[sensor], rot.conjugate(q_n)), q)
            q_n = given[sensor]
        q_t, still_t = pose_stillness(q[t_window], "T-pose", sensor)
        stillness.append(still_t)
        try:
            fits.append(fit_arm_axis(side, sensor, q_n, q_t, q[n_window.stop:t_window.stop], up, settings))
        except CalibrationRefused as refusal:
            refusals.append(refusal)
    checks = stillness_checks(stillness, settings.stillness_limit_deg, settings.stillness_good_deg)
    if refusals and (arms != "auto" or not fits):
        raise refusals[0]
    disagreement = None
    if len(fits) == 2:
        cos = float(np.clip(np.dot(fits[0].forward_world, fits[1].forward_world), -1.0, 1.0))
        disagreement = float(np.degrees(np.arccos(cos)))
        if disagreement > settings.lr_refuse_deg:
            raise CalibrationRefused(
                f"the left and right arm axes disagree by {disagreement:.0f}°: raise both arms "
                "sideways (was one raised forward?)",
                {"left_right_disagreement_deg": disagreement},
            )
        checks.append((grade(disagreement, settings.lr_good_deg, settings.lr_acceptable_deg),
                       f"left and right arm axes disagree by {disagreement:.1f}°"))
    for fit in fits:
        swing = settings.forward_from == "swing"
        angle = fit.raise_angle_deg if swing else fit.rotation_angle_deg
        checks.append((grade(abs(angle - settings.arm_angle_expected_deg), settings.arm_angle_good_deg,
                              settings.arm_angle_acceptable_deg),
                       f"the {fit.side} arm {'rose' if swing else 'turned'} {angle:.0f}° "
                       f"(about {settings.arm_angle_expected_deg:g}° expected)"))
        tilt_acceptable = np.inf if swing else settings.axis_tilt_acceptable_deg
        checks.append((grade(fit.axis_tilt_deg, settings.axis_tilt_good_deg, tilt_acceptable),
                       f"the {fit.side} arm turned about its own long axis while raised (rotation axis "
                       f"tilted {fit.axis_tilt_deg:.0f}° from horizontal; keep the palm facing down)"))
        residual = fit.swing_residual_deg if swing else fit.axis_residual_deg
        checks.append((grade(residual, settings.axis_residual_good_deg, settings.axis_residual_acceptable_deg),
                       f"the {fit.side} arm left its raise plane (residual {residual:.1f}°)" if swing else
                       f"the {fit.side} arm did not turn about one axis (residual {residual:.1f}°)"))
    forward = np.sum([fit.forward_world for fit in fits], axis=0)
    q_world_from_body = q_world_from_body_from_forward(forward, up)
    verdict, problems = verdict_of(checks)
    quality = CalibrationQuality("npose_tpose", tuple(stillness), tuple(fits), disagreement, None, verdict, problems)
    segments = _segment_rotations(q_world_from_body, {**means, **given}, mapping, q_segment_from_body_npose)
    details = {"npose_s": [float(npose_s[0]), float(npose_s[1])], "tpose_s": [float(tpose_s[0]), float(tpose_s[1])]}
    if given:
        # how far each sensor's tracked orientation still was from the one used (deg)
        details["npose_track_vs_given_deg"] = {
            sensor: float(np.degrees(rot.angle_between(means[sensor], q))) for sensor, q in sorted(given.items())}
    return BodyCalibration(q_world_from_body, up, dict(mapping), segments, quality, details)


def calibrate_heading(
    t_s: ArrayLike,
    q_world_from_sensor: Mapping[str, ArrayLike],
    mapping: Mapping[str, str],
    heading_sensor: str,
    heading_axis_sensor: ArrayLike,
    npose_s: tuple[float, float] | None = None,
    up_world: ArrayLike = (0.0, 0.0, 1.0),
    settings: BodyCalSettings = DEFAULT_SETTINGS,
    q_segment_from_body_npose: Mapping[str, ArrayLike] | None = None,
) -> BodyCalibration:
    """Calibration from one standing pose and a sensor axis that points forward.

    ``heading_sensor`` is a sensor id (it need not be in ``mapping``); ``heading_axis_sensor``
    (3,) the axis, in that sensor's frame, that points forward in the pose (e.g. ``(0, 0, 1)``
    for OpenSense's ``base_heading_axis = z``); ``npose_s`` the pose window (default: the first
    sample, as OpenSense does). Other arguments as :func:`calibrate_npose_tpose`.
    """
    t = np.asarray(t_s, dtype=np.float64)
    up = unit_vector(up_world, "up_world")
    axis = unit_vector(heading_axis_sensor, "heading axis")
    mapping = check_mapping(mapping, list(q_world_from_sensor))
    if heading_sensor not in q_world_from_sensor:
        raise ValueError(
            f"unknown heading sensor {heading_sensor!r}; the recording has: {', '.join(q_world_from_sensor)}"
        )
    window = pose_window(t, npose_s if npose_s is not None else (t[0], t[0]), "N-pose")
    sensors = list(dict.fromkeys(list(mapping.values()) + [heading_sensor]))
    means, stillness = window_means(q_world_from_sensor, sensors, window)
    checks = stillness_checks(stillness, settings.stillness_limit_deg, settings.stillness_good_deg)
    forward_raw = rot.rotate(means[heading_sensor], axis)
    tilt = float(tilt_from_horizontal_deg(forward_raw, up))
    if tilt > settings.heading_tilt_refuse_deg:
        raise CalibrationRefused(
            f"the heading axis of sensor {heading_sensor} is {tilt:.0f}° from horizontal: it cannot "
            "give the forward direction (choose an axis that points forward)",
            {"heading_axis_tilt_deg": tilt},
        )
    checks.append((grade(tilt, settings.heading_tilt_good_deg, settings.heading_tilt_acceptable_deg),
                   f"the heading axis of sensor {heading_sensor} is tilted {tilt:.0f}° from horizontal"))
    q_world_from_body = q_world_from_body_from_forward(forward_raw, up)
    verdict, problems = verdict_of(checks)
    quality = CalibrationQuality("heading", tuple(stillness), (), None, tilt, verdict, problems)
    segments = _segment_rotations(q_world_from_body, means, mapping, q_segment_from_body_npose)
    details = {
        "npose_s": [float(t[window.start]), float(t[window.stop - 1])],
        "heading_sensor": heading_sensor,
        "heading_axis_sensor": axis.tolist(),
    }
    return BodyCalibration(q_world_from_body, up, dict(mapping), segments, quality, details)


# --------------------------------------------------------------------------------------------
# Live mapping and display
# --------------------------------------------------------------------------------------------

def segment_orientations(
    calibration: BodyCalibration, q_world_from_sensor: Mapping[str, ArrayLike], require_all: bool = True,
    allow_nan: bool = False,
) -> dict[str, FloatArray]:
    """``q_world_from_segment = q_world_from_sensor ⊗ q_sensor_from_segment`` for every calibrated
    segment (``(..., 4)``, following the sensors' shapes).

    A calibrated sensor missing from ``q_world_from_sensor`` raises ``ValueError``, or, with
    ``require_all=False`` (live display while a sensor is silent), leaves its segment out. A NaN
    quaternion raises ``ValueError`` naming its sensor, unless ``allow_nan`` (the processing
    path, whose filters give NaN rows before their first orientation) passes it through.
    Sensors of one shape are turned in one vectorised product (the live display's case).
    """
    chosen: list[tuple[str, str, FloatArray]] = []  # (segment, sensor, q_world_from_sensor)
    missing: tuple[str, str] | None = None
    for segment, sensor in calibration.sensors.items():
        if sensor in q_world_from_sensor:
            chosen.append((segment, sensor, np.asarray(q_world_from_sensor[sensor], dtype=np.float64)))
        elif require_all:
            missing = (segment, sensor)  # reported after any NaN quaternion of an earlier segment
            break
    shapes = {q.shape for _seg, _sen, q in chosen}
    stacked = np.stack([q for _seg, _sen, q in chosen]) if len(shapes) == 1 else None
    if stacked is not None:
        finite = np.isfinite(stacked).reshape(len(chosen), -1).all(axis=1).tolist()
    else:
        finite = [bool(np.all(np.isfinite(q))) for _seg, _sen, q in chosen]
    for (segment, sensor, _q), ok in zip(chosen, finite):
        if not ok and not allow_nan:
            raise ValueError(f"sensor {sensor} (segment {segment}): NaN quaternion")
    if missing is not None:
        segment, sensor = missing
        raise ValueError(
            f"sensor {sensor} (segment {segment}) is missing from the data; it has: "
            f"{', '.join(q_world_from_sensor)}"
        )
    if stacked is None:  # sensors of different shapes (or none): one product each
        return {segment: rot.multiply(q, rot.conjugate(calibration.q_segment_from_sensor[segment]))
                for segment, _sensor, q in chosen}
    q_sensor_from_segment = rot.conjugate(np.array(
        [calibration.q_segment_from_sensor[segment] for segment, _sensor, _q in chosen], dtype=np.float64))
    product = rot.multiply(stacked, q_sensor_from_segment.reshape((len(chosen),) + (1,) * (stacked.ndim - 2) + (4,)))
    return {segment: product[i] for i, (segment, _sensor, _q) in enumerate(chosen)}


def fill_missing_segments(
    q_world_from_segment: Mapping[str, ArrayLike], segments_parent_first: Sequence[tuple[str, str | None]]
) -> dict[str, FloatArray]:
    """Give every segment without a sensor its parent's orientation (a rigid continuation).

    ``segments_parent_first`` lists ``(segment, parent)`` pairs, parents first (a skeleton
    model's order). A root without a sensor raises ``ValueError``.
    """
    result = {k: np.asarray(v, dtype=np.float64) for k, v in q_world_from_segment.items()}
    for segment, parent in segments_parent_first:
        if segment in result:
            continue
        if parent is None or parent not in result:
            raise ValueError(f"segment {segment} has no sensor and no parent orientation to follow")
        result[segment] = result[parent]
    return result
