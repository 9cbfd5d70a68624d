"""Level walking of the simulated subject: gait joint-angle curves and a progression with feet
that do not slide. Frames and units as in :mod:`mimucap.core.simulate.body_pose`."""

from __future__ import annotations

import math

import numpy as np

from mimucap.core import phase_markers
from mimucap.core.simulate.activities import Activity
from mimucap.core.simulate.body_pose import BodyPose, pelvis_rotation
from mimucap.core.simulate.minimum_jerk import minimum_jerk

_TWO_PI = 2.0 * np.pi


def _periodic_bump(phase: np.ndarray, centre: float, width: float) -> np.ndarray:
    """Gaussian bump on the unit circle of gait phase (centre and width in cycles)."""
    d = (phase - centre + 0.5) % 1.0 - 0.5
    return np.exp(-(d / width) ** 2)


#: Leg segment lengths (thigh, shank) in m of the default subject (1.75 m, ten-segment ratios).
DEFAULT_LEG_LENGTHS_M = (0.245 * 1.75, 0.246 * 1.75)
_GAIT_GRID = 512
_GAIT_HARMONICS = 40


#: Gait phase of toe-off (heel strike at 0) of every simulated leg.
TOE_OFF_PHASE = 0.62


def stance_weight_right(phase: np.ndarray) -> np.ndarray:
    """Share (0..1) of the right foot in carrying the body at gait ``phase`` (right heel strike
    at 0, toe-off at 0.62; the left foot carries the rest): single support 0.12-0.5, smooth
    hand-overs in the double-support phases 0-0.12 and 0.5-0.62."""
    p = np.asarray(phase, dtype=np.float64) % 1.0
    return minimum_jerk(p / 0.12) - minimum_jerk((p - 0.5) / 0.12)


class Walk(Activity):
    """Level walking at ``speed_mps`` with feet that stay put while they carry the body.

    Joint-angle curves (right leg; phase 0 = right heel strike, the left leg half a cycle
    later), after the typical sagittal gait curves (Perry & Burnfield; Winter): hip flexion
    about +30° at heel strike to −10° at 50 %; knee flexion 5° at heel strike, a loading-
    response peak of ~17° at 15 %, ~6° at 40 %, 38° at toe-off and 60° in swing at 70 %;
    ankle plantar-flexion of about −15° at toe-off; arm swing ±20° opposite to the legs with the
    elbow flexed 10-30°; pelvis rotation ±5°, obliquity ±4°, thorax counter-rotation.

    Progression: the root moves forward exactly as far as the carrying foot moves backward
    relative to it (sagittal leg geometry with ``leg_lengths_m`` = (thigh, shank), the share
    of each foot from :func:`stance_weight_right`), so the stance foot does not slide; this
    fixes the stride length, and the stride duration ``stride_s`` follows from ``speed_mps``
    (about 1.09 s at 1.2 m/s for a 1.75 m subject). The forward speed fluctuates within the
    stride (about 0.8-1.5 m/s at a mean of 1.2 m/s). Sideways the pelvis sways ±2.5 cm
    towards the carrying foot (the feet may slide sideways by a few centimetres). Vertically the root oscillates by ±2 cm around 3.5 cm below its
    standing height, lowest in double support. ``turn_rate_dps`` walks along a circle.
    """

    name = "walk"
    marker = phase_markers.WALK
    blend_in_s = 1.0  # gait initiation and termination take about one step
    blend_out_s = 1.0

    def __init__(self, duration_s: float | None = None, speed_mps: float = 1.2, turn_rate_dps: float = 0.0,
                 leg_lengths_m: tuple[float, float] = DEFAULT_LEG_LENGTHS_M) -> None:
        if not 0.3 <= speed_mps <= 2.5:
            raise ValueError(f"walking speed must be in 0.3..2.5 m/s, got {speed_mps}")
        self.duration_s, self.speed = duration_s, float(speed_mps)
        self.turn_rate = math.radians(turn_rate_dps)
        self.treadmill = False
        self.fit_legs(leg_lengths_m)

    def on_treadmill(self, treadmill: bool = True) -> Walk:
        """Walk on a treadmill belt (``treadmill`` True) or over ground; returns self.

        On the belt the subject stays in place: the belt carries the stance foot back at the
        mean walking speed, so the root keeps only its fluctuation about the mean progression
        (the body's motion differs from walking over ground by a constant velocity, which no
        inertial sensor can tell apart)."""
        self.treadmill = bool(treadmill)
        return self

    def fit_legs(self, leg_lengths_m: tuple[float, float]) -> Walk:
        """Use the subject's (thigh, shank) lengths in m for the progression; returns self."""
        thigh, shank = (float(v) for v in leg_lengths_m)
        if not (0.1 < thigh < 1.0 and 0.1 < shank < 1.0):
            raise ValueError(f"leg lengths must be 0.1..1 m, got {leg_lengths_m}")
        phase = np.arange(_GAIT_GRID) / _GAIT_GRID
        lean = self.trunk(phase)[2]
        forward = {}
        for side, shift in (("r", 0.0), ("l", 0.5)):
            leg = self.leg((phase + shift) % 1.0)
            thigh_angle = np.radians(leg["hip"][:, 0] - lean)
            shank_angle = thigh_angle - np.radians(leg["knee"][:, 0])
            forward[side] = thigh * np.sin(thigh_angle) + shank * np.sin(shank_angle)
        step = 2.0 / _GAIT_GRID
        rate = {side: (np.roll(x, -1) - np.roll(x, 1)) / step for side, x in forward.items()}
        weight = stance_weight_right(phase)
        advance_per_phase = -(weight * rate["r"] + (1.0 - weight) * rate["l"])
        self.stride_m = float(advance_per_phase.mean())
        self.stride_s = self.stride_m / self.speed
        if not 0.5 <= self.stride_s <= 3.0:
            raise ValueError(f"walking at {self.speed} m/s needs a stride of {self.stride_s:.2f} s, outside 0.5..3 s")
        coefficients = np.fft.rfft(advance_per_phase - self.stride_m)[1:_GAIT_HARMONICS + 1] / _GAIT_GRID
        k = np.arange(1, coefficients.shape[0] + 1)
        # ∫ 2 Re(C_k e^{2πikφ}) dφ = 2 Re(C_k / (2πik) e^{2πikφ})
        self._integral = 2.0 * coefficients / (2j * np.pi * k)
        self._k = k
        self._offset = float(np.real(self._integral.sum()))
        return self

    def _distance(self, tau: np.ndarray) -> np.ndarray:
        """Forward distance (m) covered after ``tau`` seconds."""
        cycles = tau / self.stride_s
        angle = _TWO_PI * np.outer(cycles % 1.0, self._k)
        # Row-wise sums (not a matrix product, whose rounding could depend on the row count).
        periodic = (np.cos(angle) * np.real(self._integral)).sum(axis=1) - (np.sin(angle) * np.imag(self._integral)).sum(axis=1)
        return self.stride_m * cycles + periodic - self._offset

    def distance_m(self, tau_s: float) -> float:
        """Forward distance (m) the body covers ``tau_s`` seconds into the walk (after the
        one-second blend in from standing, exactly; over ground)."""
        return float(self._distance(np.array([float(tau_s)]))[0])

    @staticmethod
    def leg(phase: np.ndarray) -> dict[str, np.ndarray]:
        """Hip, knee and ankle angles (n,3) deg of one leg at its own gait ``phase``."""
        hip = np.stack((10.0 + 20.0 * np.cos(_TWO_PI * (phase - 0.04)),
                        5.0 * np.sin(_TWO_PI * (phase + 0.1)),
                        4.0 * np.cos(_TWO_PI * phase)), axis=-1)
        knee_flexion = (5.0 + 12.0 * _periodic_bump(phase, 0.15, 0.14) + 55.0 * _periodic_bump(phase, 0.70, 0.14))
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
        sway = 0.025 * np.sin(_TWO_PI * (phase - 0.06))
        right = np.stack((np.cos(heading), np.sin(heading)), axis=-1)
        xy = xy + sway[:, None] * right
        angles: dict[str, np.ndarray] = {}
        for side, shift in (("r", 0.0), ("l", 0.5)):
            for kind, value in self.leg((phase + shift) % 1.0).items():
                angles[f"{kind}_{side}"] = value
            for kind, value in self.arm((phase + shift + 0.5) % 1.0).items():
                angles[f"{kind}_{side}"] = value
        yaw, obliquity, lean = self.trunk(phase)
        angles["lumbar"] = np.stack((np.full(n, 2.0), -0.7 * obliquity, -0.8 * yaw), axis=-1)
        angles["neck"] = np.stack((np.full(n, -4.0), np.zeros(n), -0.2 * yaw), axis=-1)
        root_dz = -0.035 + 0.02 * np.cos(2.0 * _TWO_PI * (phase - 0.3))
        # Each foot is on the ground from its heel strike (own phase 0) to its toe-off (0.62).
        contact = np.stack([((phase + shift) % 1.0 < TOE_OFF_PHASE).astype(float) for shift in (0.5, 0.0)], axis=-1)
        return BodyPose(heading_rad=heading, root_xy_m=xy, q_body_from_pelvis=pelvis_rotation(yaw, obliquity, lean),
                        joint_angles_deg=angles, plant=np.zeros(n), ground=np.zeros(n), root_dz_m=root_dz,
                        contact=contact)
