"""Legs that walk on the ground: the simulated walk's feet roll on a level floor without
sliding, land on the heel and leave from the toe, and are stopped by the floor within a few
milliseconds, as real feet are.

The walk's joint-angle curves (:class:`~mimucap.core.simulate.walking.Walk`) say how the legs
move; on their own they do not keep the feet on a floor. This module turns them into a gait
that does, once per walk, over one stride of gait phase (right heel strike at phase 0, left at
0.5):

1. **Stance feet roll.** Each foot lands on its heel where the curves put it and turns down
   about the heel (the heel rocker) until the forefoot reaches the floor at
   :data:`FOOT_FLAT_PHASE` (Perry & Burnfield, "Gait Analysis: Normal and Pathological
   Function", 2010: within the loading response); it stays flat, then rises about the toe just
   as far as the curves' leg, from where the pelvis is, needs to reach it (the knee keeps the
   curves' flexion), and leaves the floor at :data:`TOE_OFF_PHASE` with the curves' pitch and
   pitch rate. No point on the floor slides: the heel, then the whole sole, then the toe is the
   pivot.
2. **The pelvis rides on them.** Forward, it goes where the curves' leg puts it above the
   single stance foot, fitted across the double supports with :data:`PELVIS_HARMONICS`
   harmonics of the stride; vertically it is highest in mid-stance, where the curves' leg holds
   it above the flat foot, and lowest in double support, at heel strike where the curves' leading
   leg puts its heel on the floor (a second harmonic of the stride); sideways it sways as the
   walk says. The body moves smoothly while the legs take up what the floor imposes.
3. **The legs reach the feet.** Each leg's hip angles and knee flexion are solved (Newton's
   method on the forward kinematics) so that the ankle is where the foot needs it and the
   ankle's axial rotation is the curves'; the ankle's other angles follow from the shank and the
   foot. In swing the foot follows the curves, joined without a jump in position or velocity to
   the foot that left the floor, lifted where it would pass nearer the floor than
   :data:`MIN_TOE_CLEARANCE_M`, and brought down onto its next landing point at
   :data:`HEEL_APPROACH_M_S`.
4. **The floor stops the foot.** At heel strike the heel's velocity goes to zero within
   :data:`HEEL_CONTACT_S` (the heel pad and the shoe compress: a minimum-jerk decay instead of
   an instantaneous stop); the ankle, carried on by the leg, keeps its velocity across the
   heel-ankle lever, so the foot turns down about the heel faster (the foot slap). When the
   forefoot lands, the foot's rotation stops within :data:`FOREFOOT_CONTACT_S`. The
   accelerometers measure this as the heel-strike transient, a few g at the foot, the shank and
   the thigh and a fraction of that at the pelvis, the sizes Light, McLellan & Klenerman measured
   at the tibia and the head ("Skeletal transients on heel strike in normal walking with
   different footwear", J. Biomech. 13:477-480, 1980: about 5 g and 0.5 g with hard heels, half
   with resilient ones). Winter ("Foot trajectory in human gait: a precise and
   multifactorial motor control task", Phys. Ther. 72:45-53, 1992) measured the heel arriving
   at about 0.9 m/s forward and slowly downward, and the toe clearing the floor by 1.3 cm in
   mid-swing.

The contacts that follow are marker events on the result, as an optical system with markers on
the sole would report them: a foot is on the floor while its heel or toe point is at or below
the floor (:meth:`GaitDesign.contact`; the heel pad and the sole are pressed a fraction of a
millimetre into it while the foot carries the body).

Frames: the walking frame is the world at heading 0 (x to the right, y forward, z up, floor at
z = 0); segment frames ISB (x anterior, y superior, z right); quaternions scalar first,
``q_A_from_B``. Units: m, s, rad unless named ``_deg``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mimucap.core import rotation as rot
from mimucap.core import skeleton
from mimucap.core.simulate.minimum_jerk import minimum_jerk

#: Gait phase of toe-off (heel strike at 0) of every simulated leg.
TOE_OFF_PHASE = 0.62
#: Gait phase at which the forefoot reaches the floor (end of the heel rocker).
FOOT_FLAT_PHASE = 0.08
#: Gait phase at which the heel is assumed to rise in the first pass of the design (terminal
#: stance, 31-50 % in Perry & Burnfield); the design then lets it rise where the leg needs it.
HEEL_OFF_PHASE = 0.38
#: How gently (deg) the heel begins to rise: the scale of the soft minimum between the flat
#: foot and the pitch the leg needs.
HEEL_RISE_SOFTNESS_DEG = 0.5
#: Gait phase after foot flat before the heel may rise.
HEEL_RISE_SETTLE_PHASE = 0.03
#: Gait phase at which the pelvis is highest (mid-stance; lowest in double support, a quarter
#: stride later).
PELVIS_TOP_PHASE = 0.3
#: The heel's downward speed (m/s) when it touches the floor: "negligible" (Winter 1992); a
#: little, so that the heel meets the floor instead of skimming it.
HEEL_APPROACH_M_S = 0.05
#: The least height (m) of the toe above the floor in mid-swing (Winter 1992: 1.29 cm).
MIN_TOE_CLEARANCE_M = 0.0129
#: Time (s) in which the floor stops the heel at heel strike, and the foot's rotation when the
#: forefoot lands: the compression of the heel pad and the sole.
HEEL_CONTACT_S = 0.015
FOREFOOT_CONTACT_S = 0.025
#: How near (m) the floor a sole point counts as on it (the design's numerical precision).
ON_FLOOR_M = 1e-6
#: Gait phase from heel strike to the other foot's toe-off: the double support.
DOUBLE_SUPPORT_PHASE = TOE_OFF_PHASE - 0.5
#: Harmonics of the stride kept in the pelvis' forward and vertical path.
PELVIS_HARMONICS = 8
#: Passes of the design: the stance feet and the pelvis path depend on each other.
DESIGN_PASSES = 2
#: Phase samples per stride of the design (fine enough to resolve the contacts' milliseconds).
DESIGN_SAMPLES = 2048
#: The Newton iterations of the legs' inverse kinematics that recompute the Jacobian (the others
#: reuse the last one).
JACOBIAN_AT = (0, 1, 3)
#: Width (gait phase) of the window that smooths the swinging foot's lift over the floor.
CLEARANCE_WINDOW_PHASE = 0.08
#: Share of the swing over which a foot's correction fades out after toe-off and in before
#: heel strike (gait phase).
SWING_JOIN_PHASE = 0.15

_UP = np.array([0.0, 0.0, 1.0])
_SIDES = ("r", "l")


@dataclass(frozen=True)
class LegGeometry:
    """The simulated subject's legs (m): ``height_m``; ``root_height_m`` of the pelvis root
    standing; per side ``hip_m`` the hip joint in the pelvis frame, ``knee_m`` the knee in the
    thigh frame, ``ankle_m`` the ankle in the shank frame; ``heel_m`` and ``toe_m`` the sole's
    heel and toe points in the foot frame (from the ankle; the sole is level in the N-pose and
    touches the floor); ``joints`` the hip, knee and ankle :class:`~mimucap.core.skeleton.Joint`
    of each side (their angle conventions)."""

    height_m: float
    root_height_m: float
    hip_m: dict[str, np.ndarray]
    knee_m: np.ndarray
    ankle_m: np.ndarray
    heel_m: np.ndarray
    toe_m: np.ndarray
    joints: dict[str, skeleton.Joint]

    @classmethod
    def of(cls, model: skeleton.SkeletonModel, height_m: float) -> LegGeometry:
        """The legs of ``model`` for a subject of ``height_m``; the feet are those of the
        fifteen-segment model when ``model`` has none (the subject has feet even where no
        sensor follows them)."""
        with_feet = model if "foot_r" in model.segment_names else skeleton.load_model("fifteen_segment")
        h = float(height_m)
        heel, toe = skeleton.foot_sole_m(h)
        return cls(
            height_m=h, root_height_m=model.root_height_ratio * h,
            hip_m={s: np.array(model.segment(f"thigh_{s}").attach_ratio) * h for s in _SIDES},
            knee_m=np.array(model.segment("shank_r").attach_ratio) * h,
            ankle_m=np.array(with_feet.segment("foot_r").attach_ratio) * h, heel_m=heel, toe_m=toe,
            joints={f"{kind}_{s}": with_feet.joint(f"{kind}_{s}") for kind in ("hip", "knee", "ankle") for s in _SIDES},
        )


@dataclass(frozen=True)
class LegPose:
    """One leg at ``n`` instants (world, m): thigh, shank and foot orientations (n, 4); hip,
    knee and ankle joints and the sole's heel and toe points (n, 3)."""

    q_thigh: np.ndarray
    q_shank: np.ndarray
    q_foot: np.ndarray
    hip: np.ndarray
    knee: np.ndarray
    ankle: np.ndarray
    heel: np.ndarray
    toe: np.ndarray


def leg_pose(geometry: LegGeometry, side: str, q_pelvis: np.ndarray, root: np.ndarray,
             hip_deg: np.ndarray, knee_deg: np.ndarray, ankle_deg: np.ndarray) -> LegPose:
    """Forward kinematics of one leg from the pelvis orientation (n, 4), the root (n, 3) and the
    hip, knee and ankle angles (n, 3) in degrees (clinical signs of
    :data:`~mimucap.core.skeleton.JOINT_ANGLE_SIGNS_DOC`)."""
    j = geometry.joints
    q_thigh = rot.multiply(q_pelvis, skeleton.joint_rotation_from_angles(j[f"hip_{side}"], hip_deg))
    q_shank = rot.multiply(q_thigh, skeleton.joint_rotation_from_angles(j[f"knee_{side}"], knee_deg))
    q_foot = rot.multiply(q_shank, skeleton.joint_rotation_from_angles(j[f"ankle_{side}"], ankle_deg))
    hip = root + rot.rotate(q_pelvis, geometry.hip_m[side])
    knee = hip + rot.rotate(q_thigh, geometry.knee_m)
    ankle = knee + rot.rotate(q_shank, geometry.ankle_m)
    return LegPose(q_thigh, q_shank, q_foot, hip, knee, ankle,
                   ankle + rot.rotate(q_foot, geometry.heel_m), ankle + rot.rotate(q_foot, geometry.toe_m))


def foot_pitch(q_foot: np.ndarray) -> np.ndarray:
    """Pitch (rad) of the sole (the foot's x axis) above the horizontal, positive toe up."""
    x = rot.rotate(q_foot, np.array([1.0, 0.0, 0.0]))
    return np.arctan2(x[..., 2], np.hypot(x[..., 0], x[..., 1]))


def _hermite(s: np.ndarray, s0: float, s1: float, v0, d0, v1, d1) -> np.ndarray:
    """Cubic Hermite on [s0, s1] with values ``v0``/``v1`` and slopes ``d0``/``d1`` (per unit of
    ``s``); arrays broadcast along the last axis. Zero outside [s0, s1] is the caller's job."""
    h = s1 - s0
    x = ((s - s0) / h)[..., None]
    h00, h10, h01, h11 = 2 * x**3 - 3 * x**2 + 1, x**3 - 2 * x**2 + x, -2 * x**3 + 3 * x**2, x**3 - x**2
    return (h00 * np.asarray(v0) + h10 * h * np.asarray(d0) + h01 * np.asarray(v1) + h11 * h * np.asarray(d1))


class PeriodicSpline:
    """The periodic cubic spline through ``values`` (n, k) sampled at phases j/n, j = 0..n−1
    (period 1): a uniform cubic B-spline whose coefficients solve ``(c[j−1] + 4 c[j] +
    c[j+1]) / 6 = values[j]``, a circular convolution undone in the Fourier domain. Twice
    continuously differentiable, as the accelerometer needs; numpy only."""

    def __init__(self, values: np.ndarray) -> None:
        y = np.asarray(values, dtype=np.float64)
        n = y.shape[0]
        kernel = np.zeros(n)
        kernel[[0, 1, -1]] = [4.0 / 6.0, 1.0 / 6.0, 1.0 / 6.0]
        self._coefficients = np.fft.irfft(np.fft.rfft(y, axis=0) / np.fft.rfft(kernel)[:, None], n=n, axis=0)

    def __call__(self, phase: np.ndarray) -> np.ndarray:
        """Values (m, k) at ``phase`` (m,) (any real numbers; period 1)."""
        c = self._coefficients
        n = c.shape[0]
        x = (np.asarray(phase, dtype=np.float64) % 1.0) * n
        j = np.floor(x).astype(np.int64)
        t = (x - j)[:, None]
        weights = ((1.0 - t) ** 3, 3.0 * t**3 - 6.0 * t**2 + 4.0, -3.0 * t**3 + 3.0 * t**2 + 3.0 * t + 1.0, t**3)
        return sum(w * c[(j + offset) % n] for w, offset in zip(weights, (-1, 0, 1, 2))) / 6.0


def _stop_profile(x: np.ndarray) -> np.ndarray:
    """∫₀ˣ (1 − minimum_jerk(u)) du: the distance covered while a unit velocity decays to zero
    along a minimum-jerk profile over x ∈ [0, 1] (½ for x ≥ 1, x for x ≤ 0)."""
    u = np.clip(x, 0.0, 1.0)
    covered = u - (2.5 * u**4 - 3.0 * u**5 + u**6)
    return np.where(x < 0.0, x, covered)


@dataclass
class GaitDesign:
    """The result (module doc) over one stride: ``stride_m`` (m); the leg angles of each side
    over that leg's own phase (``angles``: ``hip_r`` … → spline of (3,) degrees, periodic); the
    pelvis root's periodic path (``pelvis``: forward and vertical offsets, m); each foot's
    contact over its own phase (``contact_phases``: on, off); the heel's velocity when it lands
    (``landing_velocity_m_s``, walking frame) and the least toe clearance in swing
    (``min_toe_clearance_m``), for checks."""

    stride_m: float
    angles: dict[str, PeriodicSpline]
    pelvis: PeriodicSpline
    contact_phases: dict[str, tuple[float, float]]
    landing_velocity_m_s: dict[str, np.ndarray]
    min_toe_clearance_m: float

    def joint_angles_deg(self, phase: np.ndarray) -> dict[str, np.ndarray]:
        """Hip, knee and ankle angles (n, 3) degrees of both legs at gait ``phase`` (n,) (right
        heel strike at 0)."""
        p = np.asarray(phase, dtype=np.float64)
        return {joint: spline((p + _ONSET_SHIFT[joint[-1]]) % 1.0) for joint, spline in self.angles.items()}

    def pelvis_offset_m(self, phase: np.ndarray) -> np.ndarray:
        """The pelvis root's periodic deviation (n, 2) m at gait ``phase`` (n,): forward, from
        steady progression at ``stride_m`` per stride through 0 at phase 0; vertical, from the
        standing height."""
        return self.pelvis(np.asarray(phase, dtype=np.float64) % 1.0)

    def contact(self, phase: np.ndarray) -> np.ndarray:
        """Whether the left and right foot are on the floor (n, 2) at gait ``phase`` (n,)."""
        p = np.asarray(phase, dtype=np.float64)
        columns = []
        for side in ("l", "r"):
            on, off = self.contact_phases[side]
            own = (p + _ONSET_SHIFT[side]) % 1.0
            columns.append(((own >= on) & (own < off)).astype(float))
        return np.stack(columns, axis=-1)


#: Own phase of each leg = gait phase + this (the left heel strikes half a stride later).
_ONSET_SHIFT = {"r": 0.0, "l": 0.5}


@dataclass(frozen=True)
class _StanceFoot:
    """A stance foot relative to its landing heel point (floor origin), over own phase (n,):
    orientation (n, 4) and ankle (n, 3)."""

    q_foot: np.ndarray
    ankle: np.ndarray


def design_gait(leg_angles: Callable[[np.ndarray], dict[str, np.ndarray]],
                pelvis_orientation: Callable[[np.ndarray], np.ndarray],
                sway_m: Callable[[np.ndarray], np.ndarray],
                geometry: LegGeometry, stride_s_of: Callable[[float], float]) -> GaitDesign:
    """Design the gait (module doc) from the walk's curves: ``leg_angles(phase)`` a leg's hip,
    knee and ankle angles (n, 3) degrees at its own phase (heel strike at 0),
    ``pelvis_orientation(phase)`` the pelvis in the walking frame (n, 4) at gait phase (right
    heel strike at 0), ``sway_m(phase)`` the pelvis' sideways offset (n,) m (to the right),
    ``stride_s_of(stride_m)`` the stride's duration (s) for its length (m)."""
    n = DESIGN_SAMPLES
    own = np.arange(n) / n
    origin = np.zeros((n, 3))
    curves = {side: leg_angles(own) for side in _SIDES}
    q_pelvis = {side: pelvis_orientation((own - _ONSET_SHIFT[side]) % 1.0) for side in _SIDES}
    prescribed = {side: leg_pose(geometry, side, q_pelvis[side], origin, curves[side]["hip"], curves[side]["knee"],
                                 curves[side]["ankle"]) for side in _SIDES}
    sway = sway_m(own)
    stance = {side: _stance_foot(prescribed[side], geometry) for side in _SIDES}
    # The pelvis' top: where the curves' stance leg holds it above the flat foot.
    top = float((stance["r"].ankle - prescribed["r"].ankle)[int(round(PELVIS_TOP_PHASE * n)), 2])
    for _ in range(DESIGN_PASSES):
        path = _pelvis_path(stance, prescribed, sway, top)
        hips = {side: rot.rotate(q_pelvis[side], geometry.hip_m[side]) + path.root_at(own + _ONSET_SHIFT[side])
                - path.landing[side] for side in _SIDES}
        stance = {side: _stance_foot(prescribed[side], geometry, hips[side]) for side in _SIDES}
    path = _pelvis_path(stance, prescribed, sway, top)
    stride_m = float(np.hypot(path.stride[0], path.stride[1]))
    stride_s = float(stride_s_of(stride_m))

    angles: dict[str, np.ndarray] = {}
    contact_phases: dict[str, tuple[float, float]] = {}
    landing_velocity: dict[str, np.ndarray] = {}
    clearance = np.inf
    for side in _SIDES:
        onset = _ONSET_SHIFT[side]
        landing = path.landing[side]
        root_own = path.root_at(own + onset)
        presc = prescribed[side]
        hip_rel = rot.rotate(q_pelvis[side], geometry.hip_m[side]) + root_own - landing
        ankle_target, q_foot_target, landing_velocity[side] = _foot_targets(
            presc, root_own, landing, landing + path.stride, stride_s, geometry, hip_rel)
        hip, knee, ankle, pose = _reach(geometry, side, q_pelvis[side], root_own, curves[side], ankle_target,
                                        q_foot_target)
        angles[f"hip_{side}"], angles[f"knee_{side}"], angles[f"ankle_{side}"] = hip, knee, ankle
        low = np.minimum(pose.heel[:, 2], pose.toe[:, 2])
        on = low <= ON_FLOOR_M
        after = np.flatnonzero(~on & (own > 0.3))
        contact_phases[side] = (float(own[np.argmax(on)]), float(own[after[0]]) if after.size else 1.0)
        swing = (own > TOE_OFF_PHASE + 0.05) & (own < 0.95)
        clearance = min(clearance, float(pose.toe[swing, 2].min()))
    splines = {joint: PeriodicSpline(value) for joint, value in angles.items()}
    periodic = path.periodic
    offsets = np.stack((periodic[:, 1] - periodic[0, 1], periodic[:, 2] - geometry.root_height_m), axis=-1)
    pelvis = PeriodicSpline(offsets)
    return GaitDesign(stride_m, splines, pelvis, contact_phases, landing_velocity, clearance)


@dataclass(frozen=True)
class _PelvisPath:
    """The pelvis root over gait phase: ``periodic`` (n, 3) its deviation from steady
    progression ``stride`` (3,) per stride (walking frame), and each foot's ``landing`` point."""

    periodic: np.ndarray
    stride: np.ndarray
    landing: dict[str, np.ndarray]

    def root_at(self, gait_phase: np.ndarray) -> np.ndarray:
        """The root (n, 3) at gait phases in [0, 2) (this stride and the next)."""
        n = self.periodic.shape[0]
        k = np.rint((gait_phase % 1.0) * n).astype(int) % n
        return self.periodic[k] + np.outer(gait_phase, self.stride)


def _pelvis_path(stance: dict[str, _StanceFoot], prescribed: dict[str, LegPose], sway: np.ndarray,
                 top: float) -> _PelvisPath:
    """The pelvis path (module doc, 2) for the stance feet: forward, where the curves' legs put it
    above the feet in single support (fitted with :data:`PELVIS_HARMONICS` harmonics across the
    double supports); sideways the walk's ``sway`` (n,) m; vertically highest (``top``, m) in
    mid-stance and lowest in double support, at heel strike where the leading leg's heel
    reaches the floor. Each foot lands where the curves put its heel."""
    n = sway.shape[0]
    phase = np.arange(n) / n
    half = n // 2
    implied = {side: stance[side].ankle - prescribed[side].ankle for side in _SIDES}
    landing_r = np.array([sway[0] + prescribed["r"].heel[0, 0], 0.0, 0.0])
    landing_l = implied["r"][half] + landing_r + prescribed["l"].heel[0]
    landing_l[0], landing_l[2] = sway[half] + prescribed["l"].heel[0, 0], 0.0
    stride = landing_l + implied["l"][half] + prescribed["r"].heel[0]
    stride[0], stride[2] = 0.0, 0.0
    left_own = np.roll(np.arange(n), half)  # gait phase k ↔ left own phase k + n/2
    right_single = (phase >= DOUBLE_SUPPORT_PHASE) & (phase < 0.5)
    single = right_single | (phase >= 0.5 + DOUBLE_SUPPORT_PHASE)
    root = np.where(right_single[:, None], landing_r + implied["r"], landing_l + implied["l"][left_own])
    periodic = _fit_periodic(phase[single], (root - np.outer(phase, stride))[single], n, PELVIS_HARMONICS)
    periodic[:, 0] = sway
    at_strike = float(-prescribed["r"].heel[0, 2])
    shape = 0.5 * (1.0 - np.cos(4.0 * np.pi * (phase - PELVIS_TOP_PHASE)))
    periodic[:, 2] = top - (top - at_strike) * shape / shape[0]
    return _PelvisPath(periodic, stride, {"r": landing_r, "l": landing_l})


def _fit_periodic(phase: np.ndarray, values: np.ndarray, n: int, harmonics: int) -> np.ndarray:
    """The periodic function with ``harmonics`` harmonics (and a mean) that fits ``values``
    (m, k) at ``phase`` (m,) best (least squares), sampled at the n phases k/n."""
    def basis(p: np.ndarray) -> np.ndarray:
        k = np.arange(1, harmonics + 1)
        angle = 2.0 * np.pi * np.outer(p, k)
        return np.hstack((np.ones((p.shape[0], 1)), np.cos(angle), np.sin(angle)))
    coefficients, *_ = np.linalg.lstsq(basis(phase[::4]), values[::4], rcond=None)
    return basis(np.arange(n) / n) @ coefficients


def _right_axis(q_foot: np.ndarray) -> np.ndarray:
    """The horizontal axis (…, 3) to the right of the foot's heading: turning about it raises the toe."""
    x = rot.rotate(q_foot, np.array([1.0, 0.0, 0.0]))
    x[..., 2] = 0.0
    x /= np.linalg.norm(x, axis=-1, keepdims=True)
    return np.cross(x, _UP)


def _stance_foot(prescribed: LegPose, geometry: LegGeometry, hip: np.ndarray | None = None,
                 stride_s: float | None = None, strike: tuple[np.ndarray, np.ndarray] | None = None) -> _StanceFoot:
    """The rolling stance foot (module doc, 1) over own phase; the heel lands at the origin.

    ``hip`` (n, 3): the hip joint relative to the landing point; the heel rises as far as the
    curves' leg (its hip-ankle distance) needs to reach the foot from there (without it, from
    :data:`HEEL_OFF_PHASE` along a cubic into the curves' toe-off pitch). With ``stride_s`` the
    forefoot's landing is compliant (:data:`FOREFOOT_CONTACT_S`), without it the rotation stops
    at once; with ``strike`` too, the heel strike: ``(heel velocity, foot angular velocity)``
    (3,) m/s and rad/s (walking frame) as the heel meets the floor (see :func:`_slap_rate`)."""
    n = prescribed.q_foot.shape[0]
    s = np.arange(n) / n
    step = 1.0 / n
    pitch_presc = np.unwrap(foot_pitch(prescribed.q_foot))
    rate = np.gradient(pitch_presc) * n  # rad per unit of phase
    p_c, r_c = float(pitch_presc[0]), float(rate[0])
    q_c = prescribed.q_foot[0]
    axis = _right_axis(q_c[None])[0]
    # Heel rocker: the foot turns down about the heel from the landing pitch, at the rate the
    # heel strike leaves it with (reached along the heel's contact), slowing down at a steady
    # rate chosen so that the forefoot reaches the floor at FOOT_FLAT_PHASE.
    flat = FOOT_FLAT_PHASE
    if strike is None or stride_s is None:
        after_strike, blend = r_c, np.ones(n)
    else:
        after_strike = _slap_rate(strike[0], strike[1], q_c, axis, geometry) * stride_s
        blend = minimum_jerk(s * stride_s / HEEL_CONTACT_S)
    base = r_c * (1.0 - blend) + after_strike * blend
    within = s <= flat
    weight = 2.0 * s * blend
    deceleration = (p_c + np.sum(base[within]) * step) / (np.sum(weight[within]) * step)
    heel_rate = base - deceleration * weight
    heel_pitch = p_c + np.concatenate(([0.0], np.cumsum(heel_rate[:-1]))) * step
    # The forefoot then stops the rotation, along its contact when it is compliant (the rate
    # decays to zero over ``stop`` from ``start``, chosen so that the sole ends level).
    stop = 0.0 if stride_s is None else FOREFOOT_CONTACT_S / stride_s
    pitch = np.zeros(n)
    start_index = int(np.argmax(heel_pitch + 0.5 * stop * heel_rate <= 0.0))
    start = float(s[start_index])
    falling = s < start
    pitch[falling] = heel_pitch[falling]
    if stop > 0.0:
        landing = (s >= start) & (s < start + stop)
        pitch[landing] = heel_pitch[start_index] + heel_rate[start_index] * stop * _stop_profile(
            (s[landing] - start) / stop)
    flat_end = start + stop
    # The floor also stops the foot's turning about other axes than the pitch axis (along the
    # heel's contact): a turn ``held`` (n, 3) on top of the pitch.
    held = np.zeros((n, 3))
    if strike is not None and stride_s is not None:
        other = strike[1] - (strike[1] @ axis) * axis
        held = HEEL_CONTACT_S * _stop_profile(s * stride_s / HEEL_CONTACT_S)[:, None] * other

    def orientation(turn: np.ndarray, index: np.ndarray | slice) -> np.ndarray:
        return rot.multiply(rot.from_rotvec(held[index]), rot.multiply(rot.from_axis_angle(axis, turn - p_c), q_c))

    # The foot as it lies once flat (the last sample turning about the heel): its toe is the
    # pivot from then on.
    flat_index = int(np.flatnonzero(s <= flat_end)[-1])
    q_flat = orientation(np.array(pitch[flat_index]), flat_index)
    ankle_flat = -rot.rotate(q_flat, geometry.heel_m)
    toe_floor = ankle_flat + rot.rotate(q_flat, geometry.toe_m)
    late = (s > flat_end) & (s <= TOE_OFF_PHASE)
    if hip is None:
        pitch[late] = pitch[flat_index]
        rocker = late & (s >= HEEL_OFF_PHASE)
        to_index = int(np.flatnonzero(s <= TOE_OFF_PHASE)[-1])
        pitch[rocker] = _hermite(s[rocker], HEEL_OFF_PHASE, TOE_OFF_PHASE, [pitch[flat_index]], [0.0],
                                 [pitch_presc[to_index]], [rate[to_index]])[:, 0]
    else:
        # Toe rocker: the heel rises about the toe just as far as the curves' leg can reach
        # (the knee follows the curves), smoothly from the flat foot (a soft minimum with 0).
        reach = np.linalg.norm(prescribed.ankle - prescribed.hip, axis=-1)
        needed = _pitch_to_reach(hip[late], reach[late], ankle_flat, toe_floor, axis)  # from flat
        scale = np.radians(HEEL_RISE_SOFTNESS_DEG)
        settle = minimum_jerk((s[late] - s[flat_index]) / HEEL_RISE_SETTLE_PHASE)  # the foot is flat first
        pitch[late] = pitch[flat_index] - settle * scale * np.logaddexp(0.0, -needed / scale)
    q_foot = orientation(pitch, slice(None))
    # Pivots: the heel at the origin until the foot is flat, then the toe where it lies.
    ankle = -rot.rotate(q_foot, geometry.heel_m)
    on_toe = s > s[flat_index]
    ankle[on_toe] = toe_floor - rot.rotate(q_foot[on_toe], geometry.toe_m)
    return _StanceFoot(q_foot, ankle)


def _slap_rate(heel_velocity: np.ndarray, angular_velocity: np.ndarray, q_foot: np.ndarray, axis: np.ndarray,
               geometry: LegGeometry) -> float:
    """The foot's pitch rate (rad/s) once the floor has stopped its heel: the ankle, carried on
    by the leg, keeps its velocity across the heel-ankle lever, so the foot turns down about the
    heel (the foot slap); only the ankle's motion along the lever stops with the heel.
    ``heel_velocity`` (3,) m/s and ``angular_velocity`` (3,) rad/s of the foot as the heel meets
    the floor, ``q_foot`` its orientation (4,), ``axis`` (3,) the pitch axis (walking frame)."""
    lever = -rot.rotate(q_foot, geometry.heel_m)  # heel → ankle
    ankle_velocity = heel_velocity + np.cross(angular_velocity, lever)
    across = np.cross(axis, lever)  # the ankle's velocity per unit pitch rate
    return float(ankle_velocity @ across / (across @ across))


def _pitch_to_reach(hip: np.ndarray, reach: np.ndarray, ankle_flat: np.ndarray, toe: np.ndarray,
                    axis: np.ndarray) -> np.ndarray:
    """The turn (m,) rad of a foot about its ``toe`` (3,) from flat (ankle at ``ankle_flat``)
    that puts the ankle ``reach`` (m,) from ``hip`` (m, 3), between 85° toe down and 30° toe up
    (the nearer of them where none does). Turning the lever ``l`` = ankle − toe by ``p`` about
    the unit ``axis`` (Rodrigues) makes ``(hip − toe)·R(p) l = A cos p + B sin p + C``, which
    the distance fixes; of the two turns that give it, the one where turning further toe down
    brings the ankle nearer the hip."""
    lever = ankle_flat - toe
    d = hip - toe
    along = axis @ lever
    d_axis = d @ axis
    a = d @ lever - d_axis * along
    b = d @ np.cross(axis, lever)
    target = 0.5 * (lever @ lever + np.sum(d * d, axis=-1) - reach * reach) - d_axis * along
    radius = np.hypot(a, b)
    ratio = np.clip(target / radius, -1.0, 1.0)
    centre = np.arctan2(b, a)
    turns = np.stack((centre + np.arccos(ratio), centre - np.arccos(ratio)))
    turns = (turns + np.pi) % (2.0 * np.pi) - np.pi
    nearer = -a * np.sin(turns) + b * np.cos(turns) < 0.0  # d(distance)/d(turn) > 0
    turn = np.where(nearer[0], turns[0], turns[1])
    return np.clip(turn, -np.radians(85.0), np.radians(30.0))


def _foot_targets(prescribed: LegPose, root: np.ndarray, landing: np.ndarray, next_landing: np.ndarray,
                  stride_s: float, geometry: LegGeometry, hip: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where one foot must be over its own phase (n,) in the walking frame: ankle (n, 3) and
    foot orientation (n, 4), and the heel's velocity at heel strike (3,) m/s (module doc, 3-4).
    ``root`` (n, 3) is the pelvis root at each own phase; the foot lands at ``landing`` at own
    phase 0 and at ``next_landing`` one stride later."""
    n = root.shape[0]
    s = np.arange(n) / n
    step = 1.0 / n
    to = TOE_OFF_PHASE
    ankle_p = prescribed.ankle + root
    heel_p = prescribed.heel + root
    q_p = prescribed.q_foot
    # Into heel strike: the whole foot is moved so that the heel reaches the next landing point,
    # coming down at HEEL_APPROACH_M_S.
    join_in = s >= 1.0 - SWING_JOIN_PHASE
    heel_end = prescribed.heel[0] + root[0] + (next_landing - landing)
    end_slope = np.zeros(3)
    end_slope[2] = -HEEL_APPROACH_M_S * stride_s - (heel_end[2] - heel_p[-1, 2]) / step
    c_in = np.zeros((n, 3))
    c_in[join_in] = _hermite(s[join_in], 1.0 - SWING_JOIN_PHASE, 1.0, np.zeros(3), np.zeros(3),
                             next_landing - heel_end, end_slope)
    heel_before = heel_p[-1] + c_in[-1]
    landing_velocity = (next_landing - heel_before) / (step * stride_s)
    # The stance foot, its heel sliding to rest along the heel's contact.
    # The foot's angular velocity as it lands (the curves' foot; the correction has faded out).
    spin = rot.to_rotvec(rot.multiply(q_p[0], rot.conjugate(q_p[-1]))) / (step * stride_s)
    stance = _stance_foot(prescribed, geometry, hip, stride_s, (landing_velocity, spin))
    t_s = s * stride_s
    slide = landing_velocity * HEEL_CONTACT_S * _stop_profile(t_s / HEEL_CONTACT_S)[:, None]
    ankle_st = stance.ankle + landing + slide
    q_st = stance.q_foot
    # Out of toe-off: the difference to the curves' foot (position, orientation, and their
    # rates) fades out over the early swing.
    k = int(np.flatnonzero(s <= to)[-1])  # the last sample on the floor
    join_out = (s > to) & (s <= to + SWING_JOIN_PHASE)
    gap = ankle_st - ankle_p
    c0, d0 = gap[k], (gap[k] - gap[k - 1]) / step
    turn = rot.to_rotvec(rot.multiply(q_st, rot.conjugate(q_p)))
    r0, e0 = turn[k], (turn[k] - turn[k - 1]) / step
    c_out = np.zeros((n, 3))
    c_out[join_out] = _hermite(s[join_out], to, to + SWING_JOIN_PHASE, c0, d0, np.zeros(3), np.zeros(3))
    r_out = np.zeros((n, 3))
    r_out[join_out] = _hermite(s[join_out], to, to + SWING_JOIN_PHASE, r0, e0, np.zeros(3), np.zeros(3))
    swing = s > to
    ankle = np.where(swing[:, None], ankle_p + c_out + c_in, ankle_st)
    q_foot = np.where(swing[:, None], rot.multiply(rot.from_rotvec(r_out), q_p), q_st)
    ankle[:, 2] += _clearance_lift(s, ankle, q_foot, geometry)
    return ankle, q_foot, landing_velocity


def _clearance_lift(s: np.ndarray, ankle: np.ndarray, q_foot: np.ndarray, geometry: LegGeometry) -> np.ndarray:
    """How far (n,) m the swinging foot is raised so that its toe and heel stay
    :data:`MIN_TOE_CLEARANCE_M` above the floor between leaving it and coming down onto it
    (the shortfall, widened and smoothed with a Hann window of :data:`CLEARANCE_WINDOW_PHASE`, so
    that the lift is smooth and never less than the shortfall)."""
    n = s.shape[0]
    low = np.minimum((ankle + rot.rotate(q_foot, geometry.toe_m))[:, 2],
                     (ankle + rot.rotate(q_foot, geometry.heel_m))[:, 2])
    swing = s > TOE_OFF_PHASE
    risen = swing & (low >= MIN_TOE_CLEARANCE_M)
    if not np.any(risen):
        return np.zeros(n)
    first = int(np.argmax(risen))
    window = np.zeros(n, dtype=bool)
    window[first:] = True
    window &= s < 1.0 - SWING_JOIN_PHASE
    shortfall = np.where(window, np.maximum(MIN_TOE_CLEARANCE_M - low, 0.0), 0.0)
    if not np.any(shortfall > 0.0):
        return np.zeros(n)
    width = max(int(round(CLEARANCE_WINDOW_PHASE * n)) | 1, 3)
    half = width // 2
    padded = np.concatenate((shortfall[-half:], shortfall, shortfall[:half]))
    widened = np.lib.stride_tricks.sliding_window_view(padded, width).max(axis=1)
    kernel = np.hanning(width + 2)[1:-1]
    kernel /= kernel.sum()
    padded = np.concatenate((widened[-half:], widened, widened[:half]))
    return np.convolve(padded, kernel, mode="valid")


def _reach(geometry: LegGeometry, side: str, q_pelvis: np.ndarray, root: np.ndarray, curves: dict[str, np.ndarray],
           ankle_target: np.ndarray, q_foot_target: np.ndarray,
           iterations: int = 7) -> tuple[np.ndarray, np.ndarray, np.ndarray, LegPose]:
    """Hip, knee and ankle angles (n, 3) degrees that put the ankle at ``ankle_target`` (n, 3)
    with the foot at ``q_foot_target`` (n, 4), and the leg's pose: the hip's three angles and the
    knee's flexion are solved (Newton's method, from the curves' values) so that the ankle is
    there and the ankle's axial rotation is the curves' (the thigh turns with the pelvis and the
    planted foot, not the ankle); the knee's other angles are the curves', the ankle's follow
    from the shank and the foot."""
    hip, knee = curves["hip"].copy(), curves["knee"].copy()
    zero = np.zeros_like(hip)
    ankle_joint = geometry.joints[f"ankle_{side}"]
    delta = 1e-4  # degrees
    lever = np.radians(1.0) * 0.1  # weighs a degree of axial rotation like 1.7 mm at the ankle

    hip_centre = root + rot.rotate(q_pelvis, geometry.hip_m[side])
    hip_joint, knee_joint = geometry.joints[f"hip_{side}"], geometry.joints[f"knee_{side}"]

    def residual(h: np.ndarray, k: np.ndarray) -> np.ndarray:
        q_thigh = rot.multiply(q_pelvis, skeleton.joint_rotation_from_angles(hip_joint, h))
        q_shank = rot.multiply(q_thigh, skeleton.joint_rotation_from_angles(knee_joint, k))
        ankle = hip_centre + rot.rotate(q_thigh, geometry.knee_m) + rot.rotate(q_shank, geometry.ankle_m)
        turn = skeleton.joint_angles_from_rotation(ankle_joint, rot.multiply(rot.conjugate(q_shank), q_foot_target))
        return np.concatenate((ankle - ankle_target, (lever * (turn[:, 2] - curves["ankle"][:, 2]))[:, None]), axis=-1)

    unknown = ((hip, 0), (hip, 1), (hip, 2), (knee, 0))
    inverse = None
    for iteration in range(iterations):
        base = residual(hip, knee)
        if iteration in JACOBIAN_AT:  # the Jacobian changes little near the solution: reused
            jacobian = np.empty(base.shape + (4,))
            for column, (array, index) in enumerate(unknown):
                array[:, index] += delta
                jacobian[..., column] = (residual(hip, knee) - base) / delta
                array[:, index] -= delta
            inverse = np.linalg.inv(jacobian)
        step = -np.einsum("nij,nj->ni", inverse, base)
        for column, (array, index) in enumerate(unknown):
            array[:, index] += step[:, column]
    pose = leg_pose(geometry, side, q_pelvis, root, hip, knee, zero)
    ankle = skeleton.joint_angles_from_rotation(ankle_joint, rot.multiply(rot.conjugate(pose.q_shank), q_foot_target))
    return hip, knee, ankle, leg_pose(geometry, side, q_pelvis, root, hip, knee, ankle)
