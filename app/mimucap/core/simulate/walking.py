"""Level walking of the simulated subject: gait joint-angle curves, walked on the floor by
:mod:`mimucap.core.simulate.gait_design`. Frames and units as in
:mod:`mimucap.core.simulate.body_pose`."""

from __future__ import annotations

import math

import numpy as np

from mimucap.core import phase_markers, skeleton
from mimucap.core import rotation as rot
from mimucap.core.simulate.activities import Activity
from mimucap.core.simulate.body_pose import BodyPose, pelvis_rotation
from mimucap.core.simulate.gait_design import GaitDesign, LegGeometry, design_gait

_TWO_PI = 2.0 * np.pi


def _periodic_bump(phase: np.ndarray, centre: float, width: float) -> np.ndarray:
    """Gaussian bump on the unit circle of gait phase (centre and width in cycles)."""
    d = (phase - centre + 0.5) % 1.0 - 0.5
    return np.exp(-(d / width) ** 2)


#: The subject the walk is designed for until :meth:`Walk.fit_body` says otherwise.
DEFAULT_MODEL = "fifteen_segment"
DEFAULT_HEIGHT_M = 1.75
#: Sideways sway (m) of the pelvis towards the carrying foot.
SWAY_M = 0.025


#: Gait designs made so far, by the legs' proportions, the subject's height and the speed.
_DESIGNS: dict[tuple, GaitDesign] = {}


def _design(model: skeleton.SkeletonModel, height_m: float, speed_mps: float) -> GaitDesign:
    """The gait design (:mod:`.gait_design`) of the walk's curves for a subject of ``height_m``
    with the legs of ``model``, walking at ``speed_mps``; made once per leg proportions, height
    and speed (the ten- and fifteen-segment models share their legs)."""
    legs = tuple(float(v) for name in ("thigh_l", "thigh_r", "shank_r") for v in
                 (*model.segment(name).attach_ratio, model.segment(name).length_ratio))
    key = (legs, model.root_height_ratio, float(height_m), float(speed_mps))
    if key not in _DESIGNS:
        geometry = LegGeometry.of(model, height_m)
        sway = lambda phase: SWAY_M * np.sin(_TWO_PI * (phase - 0.06))  # noqa: E731
        _DESIGNS[key] = design_gait(Walk.leg, Walk.pelvis_in_walking_frame, sway, geometry,
                                    lambda stride_m: stride_m / speed_mps)
    return _DESIGNS[key]


class Walk(Activity):
    """Level walking at ``speed_mps`` on feet that meet the floor.

    Joint-angle curves (right leg; phase 0 = right heel strike, the left leg half a cycle
    later), after the typical sagittal gait curves (Perry & Burnfield, "Gait Analysis: Normal and
    Pathological Function", 2010; Winter, "Biomechanics and Motor Control of Human Movement",
    2009), angles from the standing posture: hip flexion about +25° at heel strike, −13° at 50 %
    and +33° in mid-swing; knee flexion 5° at heel strike, a loading-response peak of ~17° at
    15 %, ~6° at 40 %, 40° at toe-off and 60° in swing at 72 %; ankle plantar-flexion of about
    −15° after toe-off; arm swing ±20° opposite to the legs with the elbow flexed 10-30°; pelvis
    rotation ±5°, obliquity ±4°, thorax counter-rotation.

    The legs then walk on the floor (:mod:`.gait_design`): the stance foot rolls from heel to
    toe without sliding, the pelvis rides on it (a smooth path, highest in mid-stance), the legs
    reach the feet (their hip, knee and ankle angles are solved for it, close to the curves), the
    swinging foot clears the floor and lands on its heel, which the floor stops within
    milliseconds. This fixes the stride length, and the stride duration ``stride_s`` follows
    from ``speed_mps`` (about 1.0 s at 1.2 m/s for a 1.75 m subject); the forward speed
    fluctuates within the stride. Sideways the pelvis sways ±2.5 cm towards the carrying foot.
    ``turn_rate_dps`` walks along a circle. The feet's contacts with the floor are marker
    events of that motion (:meth:`.gait_design.GaitDesign.contact`).
    """

    name = "walk"
    marker = phase_markers.WALK
    blend_in_s = 1.0  # gait initiation and termination take about one step
    blend_out_s = 1.0

    def __init__(self, duration_s: float | None = None, speed_mps: float = 1.2, turn_rate_dps: float = 0.0) -> None:
        if not 0.3 <= speed_mps <= 2.5:
            raise ValueError(f"walking speed must be in 0.3..2.5 m/s, got {speed_mps}")
        self.duration_s, self.speed = duration_s, float(speed_mps)
        self.turn_rate = math.radians(turn_rate_dps)
        self.treadmill = False
        self._body = (DEFAULT_MODEL, DEFAULT_HEIGHT_M)
        self._design: GaitDesign | None = None

    def on_treadmill(self, treadmill: bool = True) -> Walk:
        """Walk on a treadmill belt (``treadmill`` True) or over ground; returns self.

        On the belt the subject stays in place: the belt carries the stance foot back at the
        mean walking speed, so the root keeps only its fluctuation about the mean progression
        (the body's motion differs from walking over ground by a constant velocity, which no
        inertial sensor can tell apart)."""
        self.treadmill = bool(treadmill)
        return self

    def fit_body(self, model_name: str, height_m: float) -> Walk:
        """Walk with the legs of skeleton model ``model_name`` for a subject of ``height_m``
        metres (the gait design, :mod:`.gait_design`, made when first needed); returns self."""
        self._body = (str(model_name), float(height_m))
        self._design = None
        return self

    @property
    def design(self) -> GaitDesign:
        """The gait design of this walk's subject and speed (:mod:`.gait_design`)."""
        if self._design is None:
            design = _design(skeleton.load_model(self._body[0]), self._body[1], self.speed)
            stride_s = design.stride_m / self.speed
            if not 0.5 <= stride_s <= 3.0:
                raise ValueError(f"walking at {self.speed} m/s needs a stride of {stride_s:.2f} s, outside 0.5..3 s")
            self._design = design
        return self._design

    @property
    def stride_m(self) -> float:
        """Stride length (m)."""
        return self.design.stride_m

    @property
    def stride_s(self) -> float:
        """Stride duration (s) at the walk's speed."""
        return self.design.stride_m / self.speed

    def _distance(self, tau: np.ndarray) -> np.ndarray:
        """Forward distance (m) covered after ``tau`` seconds."""
        cycles = tau / self.stride_s
        return self.stride_m * cycles + self.design.pelvis_offset_m(cycles % 1.0)[:, 0]

    def distance_m(self, tau_s: float) -> float:
        """Forward distance (m) the body covers ``tau_s`` seconds into the walk (after the
        one-second blend in from standing, exactly; over ground)."""
        return float(self._distance(np.array([float(tau_s)]))[0])

    @staticmethod
    def leg(phase: np.ndarray) -> dict[str, np.ndarray]:
        """Hip, knee and ankle angles (n,3) deg of one leg at its own gait ``phase``: the curves
        the walk starts from (the legs that walk on the floor follow them, :mod:`.gait_design`).
        The hip flexes early in swing (most at 85 %, Perry & Burnfield), which carries the toe
        over the floor, and rotates internally through stance as the pelvis turns over the
        planted foot."""
        hip = np.stack((5.5 + 19.0 * np.cos(_TWO_PI * (phase - 0.04)) + 14.0 * _periodic_bump(phase, 0.82, 0.14),
                        5.0 * np.sin(_TWO_PI * (phase + 0.1)),
                        -4.0 * np.cos(_TWO_PI * phase)), axis=-1)
        knee_flexion = (5.0 + 12.0 * _periodic_bump(phase, 0.15, 0.14) + 55.0 * _periodic_bump(phase, 0.72, 0.14))
        knee = np.stack((knee_flexion, np.zeros_like(phase), 3.0 * np.cos(_TWO_PI * phase)), axis=-1)
        ankle_flexion = (2.0 - 7.0 * _periodic_bump(phase, 0.05, 0.05) + 10.0 * _periodic_bump(phase, 0.42, 0.12)
                         - 17.0 * _periodic_bump(phase, 0.63, 0.06))
        ankle = np.stack((ankle_flexion, np.zeros_like(phase), np.zeros_like(phase)), axis=-1)
        return {"hip": hip, "knee": knee, "ankle": ankle}

    @staticmethod
    def arm(phase: np.ndarray) -> dict[str, np.ndarray]:
        """One arm, given the gait phase of the *opposite* leg: the arm swings forward with it."""
        swing = np.cos(_TWO_PI * phase)
        shoulder = np.stack((3.0 + 20.0 * swing, np.full_like(phase, -6.0), np.zeros_like(phase)), axis=-1)
        elbow = np.stack((20.0 + 10.0 * swing, np.zeros_like(phase), np.zeros_like(phase)), axis=-1)
        wrist = np.stack((5.0 + 3.0 * swing, np.zeros_like(phase), np.zeros_like(phase)), axis=-1)
        return {"shoulder": shoulder, "elbow": elbow, "wrist": wrist}

    @staticmethod
    def trunk(phase: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pelvis yaw, obliquity (positive: right side down) and forward lean (deg) at the right
        leg's gait ``phase``: in right stance the left (swinging) side drops."""
        yaw = 5.0 * np.cos(_TWO_PI * phase)
        obliquity = -4.0 * np.sin(_TWO_PI * (phase + 0.1))  # the swinging side drops
        lean = 4.0 + 1.5 * np.cos(2.0 * _TWO_PI * (phase - 0.1))
        return yaw, obliquity, lean

    @staticmethod
    def pelvis_in_walking_frame(phase: np.ndarray) -> np.ndarray:
        """``q_world_from_pelvis`` (n, 4) at gait ``phase`` walking north (heading 0)."""
        yaw, obliquity, lean = Walk.trunk(phase)
        return rot.multiply(skeleton.q_world_from_body_facing(0.0), pelvis_rotation(yaw, obliquity, lean))

    def pose(self, tau, start):
        n = tau.shape[0]
        phase = (tau / self.stride_s) % 1.0
        heading = start.heading_rad + self.turn_rate * tau
        distance = self._distance(tau)
        if self.treadmill:
            distance = distance - self.speed * tau
        if self.turn_rate == 0.0:
            forward = np.array([-math.sin(start.heading_rad), math.cos(start.heading_rad)])
            xy = np.asarray(start.xy_m) + distance[:, None] * forward
        else:
            # Along a circle of radius speed / turn rate: d(x, y)/ds = (-sin ψ, cos ψ).
            radius = self.speed / self.turn_rate
            along = start.heading_rad + distance / radius
            xy = np.asarray(start.xy_m) + radius * np.stack(
                (np.cos(along) - math.cos(start.heading_rad), np.sin(along) - math.sin(start.heading_rad)), axis=-1
            )
        # Sideways sway towards the carrying foot: right of the line of progression in right stance.
        sway = SWAY_M * np.sin(_TWO_PI * (phase - 0.06))
        right = np.stack((np.cos(heading), np.sin(heading)), axis=-1)
        xy = xy + sway[:, None] * right
        angles: dict[str, np.ndarray] = {}
        angles.update(self.design.joint_angles_deg(phase))
        for side, shift in (("r", 0.0), ("l", 0.5)):
            for kind, value in self.arm((phase + shift + 0.5) % 1.0).items():
                angles[f"{kind}_{side}"] = value
        yaw, obliquity, lean = self.trunk(phase)
        angles["lumbar"] = np.stack((np.full(n, 2.0), -0.7 * obliquity, -0.8 * yaw), axis=-1)
        angles["neck"] = np.stack((np.full(n, -4.0), np.zeros(n), -0.2 * yaw), axis=-1)
        root_dz = self.design.pelvis_offset_m(phase)[:, 1]
        return BodyPose(heading_rad=heading, root_xy_m=xy, q_body_from_pelvis=pelvis_rotation(yaw, obliquity, lean),
                        joint_angles_deg=angles, plant=np.zeros(n), ground=np.zeros(n), root_dz_m=root_dz,
                        contact=self.design.contact(phase))
