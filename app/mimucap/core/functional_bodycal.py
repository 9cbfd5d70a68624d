"""Functional body calibration: every segment frame from standing still, then walking (or
flexing the elbows), for patients who cannot hold a T-pose.

Frames (``docs/conventions.md``): ``world`` is the frame the orientation tracks are expressed
in, with its up unit vector ``up_world``; each ``segment`` frame is ISB: x anterior, y up along
the segment's long axis, z to the right (``x = y × z``); ``body`` x forward, y up, z right.
Quaternions scalar-first Hamilton ``(..., 4)``, ``q_A_from_B``. Angles in degrees where named
``_deg``.

The segment frame in its sensor's coordinates, ``R_sensor_from_segment = [x_s y_s z_s]``:

* ``y_s``, the long axis, is **up** in the still-standing window: ``R_sensor_from_world(still)
  · up`` (the segments of a person standing upright are vertical, as the N-pose assumes; no
  arm needs to be raised).
* ``z_s``, the lateral axis, is the **flexion axis of the segment's hinge joint** (the knee for
  thigh and shank, the elbow for upper arm and forearm, the ankle for the foot, the wrist for
  the hand) found from the movement (:mod:`mimucap.core.hinge_axis`; Seel, Raisch, Schauer,
  "IMU-based joint angle measurement for gait analysis", 2014; Laidig, Lehmann, Bégin, Seel,
  "Exploiting kinematic constraints to compensate magnetometer disturbances when calculating
  joint angles of approximate hinge joints", 2017), with the two sensors' heading disagreement
  left out of the fit, made perpendicular to ``y_s``. Its sign is
  physical: a knee flexes one way only (the distal segment turns backwards about the
  right-pointing axis), an elbow the other way; the ankle's and wrist's axes point the way
  their proximal segment's does (those joints move both ways from standing).
* The **walking direction** at each instant is perpendicular to the knees' flexion axes
  (``forward = up × right``, the horizontal part of the legs' right-pointing axes summed; the
  elbows' when no knee moved): a person walks in the plane in which the knees bend.
  Segments without a hinge of their own (pelvis, thorax, head; a hand or foot whose joint did
  not move enough) face, on average over the movement, the walking direction:
  ``x_s`` is the mean of ``R_sensor_from_world(t) · forward(t)``, made perpendicular to
  ``y_s``. For the pelvis and thorax this is their anatomical definition while walking (the
  pelvis rotates a few degrees either way about the line of progression, Perry & Burnfield,
  "Gait Analysis: Normal and Pathological Function"); for a hand or a foot it is an assumption,
  the one the N-pose makes, and the calibration names those segments.
* ``x_s = y_s × z_s`` (or ``z_s = x_s × y_s``).

``q_world_from_body`` is the pelvis's heading in the still window (x its horizontal anterior
axis, y up), or, without a pelvis sensor, the mean heading of the calibrated segments.

Joint angles then read zero flexion and adduction when standing still (every long axis was
vertical); the axial rotations in the still pose are what the functional axes measure (a
thigh's knee axis turned from the pelvis's walking direction reads as hip rotation), not
zero by construction as after an N-pose.

How well the movement defined each axis (:class:`FunctionalQuality`, graded into the verdict
with words naming the axis): per hinge, the flexion excursion (the axis is defined by the
turning about it), how far the two sensors' axes stayed from one direction in the world (the
joint moved as a hinge), the angle between the axes fitted on each half of the joint's turning
(repeatability), the axis' tilt from horizontal when standing, the two sensors' heading
disagreement, and the angle between the left and right axes when standing; per
walking-direction segment, its spread and the angle between the two halves' estimates.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mimucap.core import hinge_axis
from mimucap.core import rotation as rot
from mimucap.core.bodycal import (
    VERDICTS,
    BodyCalibration,
    CalibrationQuality,
    CalibrationRefused,
    check_mapping,
    check_settings,
    grade,
    horizontal,
    pose_window,
    q_world_from_body_from_forward,
    stillness_checks,
    unit_quaternion,
    unit_vector,
    verdict_of,
    window_means,
)
from mimucap.core.clinical_names import joint_name, segment_name

FloatArray = NDArray[np.float64]

METHOD = "functional"
STILL_POSE = "quiet standing"
#: What a segment's heading came from when no hinge gave it.
WALKING_DIRECTION = "walking direction"


@dataclass(frozen=True)
class Hinge:
    """A hinge joint: ``proximal`` and ``distal`` segments, and how its axis' sign is found.

    ``flexion_sign``: the sign of clinical flexion as a turn of the distal segment about the
    right-pointing axis (+1: elbow, ankle dorsiflexion, wrist; −1: the knee bends backwards).
    ``one_sided``: the joint moves from standing in its flexion direction only (knee, elbow), so
    the excursion gives the sign; otherwise the axis points the way the proximal segment's
    lateral axis does."""

    joint: str
    proximal: str
    distal: str
    flexion_sign: float
    one_sided: bool


HINGES: tuple[Hinge, ...] = tuple(
    Hinge(f"{joint}_{side}", f"{proximal}_{side}", f"{distal}_{side}", sign, one_sided)
    for joint, proximal, distal, sign, one_sided in (
        ("knee", "thigh", "shank", -1.0, True),
        ("elbow", "upper_arm", "forearm", 1.0, True),
        ("ankle", "shank", "foot", 1.0, False),
        ("wrist", "forearm", "hand", 1.0, False),
    )
    for side in ("l", "r")
)
#: The hinge whose flexion axis is each segment's lateral axis, and which of its two segments it is.
AXIS_OWNER: dict[str, tuple[str, str]] = {
    **{f"thigh_{s}": (f"knee_{s}", "proximal") for s in "lr"},
    **{f"shank_{s}": (f"knee_{s}", "distal") for s in "lr"},
    **{f"upper_arm_{s}": (f"elbow_{s}", "proximal") for s in "lr"},
    **{f"forearm_{s}": (f"elbow_{s}", "distal") for s in "lr"},
    **{f"foot_{s}": (f"ankle_{s}", "distal") for s in "lr"},
    **{f"hand_{s}": (f"wrist_{s}", "distal") for s in "lr"},
}
#: Hinges whose axes give the walking direction, in order of preference (the first kind with a
#: usable axis is taken).
WALKING_HINGES: tuple[tuple[str, ...], ...] = (("knee_l", "knee_r"), ("elbow_l", "elbow_r"))


@dataclass(frozen=True)
class FunctionalSettings:
    """Limits of the functional calibration (angles in degrees).

    Still window: refused above ``stillness_limit_deg`` (3), acceptable above
    ``stillness_good_deg`` (1.5), as the N-pose. A hinge's axis is used when the joint's
    flexion excursion (2.5th to 97.5th percentile from standing) reaches ``min_excursion_deg``
    (8) and, for a knee or an elbow, its smaller excursion the other way is at most
    ``max_backward_share`` (0.5) of it (otherwise flexion cannot be told from extension); an
    ankle's or wrist's axis only when its two halves agree within ``halves_acceptable_deg``
    (otherwise its distal segment faces the walking direction).
    Grades (good / acceptable, poor beyond): excursion at least ``excursion_good_deg`` (20) /
    ``excursion_acceptable_deg`` (12) (an orientation error ε over an excursion Δ tilts the
    fitted axis by about ε/Δ rad: 1° over 20° is 3°); angle between the axes (or a
    walking-direction segment's forward axis) found on the movement's two halves
    ``halves_good_deg`` (5) / ``halves_acceptable_deg`` (10) (two independent halves differ by
    about √2 times the error of either, so the whole movement's estimate is off by about half
    their difference); RMS angle between the two sensors' axes in the world
    ``residual_good_deg`` (15) / ``residual_acceptable_deg`` (25), wide because sensors on the
    skin see a knee's secondary rotations several times larger than the bones make (Benoit et
    al., "In vivo knee kinematics during gait reveals new rotation profiles and smaller
    translations", 2007): a larger one means a sensor slipped or sits on another segment than
    mapped; tilt of a knee or elbow axis from horizontal when standing ``tilt_good_deg`` (15) /
    ``tilt_acceptable_deg`` (30); angle between the left and right knee (or elbow) axes when
    standing ``left_right_good_deg`` (10) / ``left_right_acceptable_deg``
    (20); heading disagreement of a knee's (or elbow's) two sensors ``heading_offset_good_deg``
    (5) / ``heading_offset_acceptable_deg`` (10): it is left out of the axes, but the joint's
    axial rotation, computed later from the same sensors, carries it; that disagreement is sought
    only when both segments' long axes swung at least ``min_swing_deg`` (10) from vertical (a
    segment that keeps its orientation would take up any heading turn of the other in its
    axis). ``hinge_from``:
    ``"orientations"`` (default) or ``"rates"``, the estimator of :mod:`mimucap.core.hinge_axis`.
    """

    stillness_limit_deg: float = 3.0
    stillness_good_deg: float = 1.5
    min_excursion_deg: float = 8.0
    max_backward_share: float = 0.5
    excursion_good_deg: float = 20.0
    excursion_acceptable_deg: float = 12.0
    residual_good_deg: float = 15.0
    residual_acceptable_deg: float = 25.0
    halves_good_deg: float = 5.0
    halves_acceptable_deg: float = 10.0
    tilt_good_deg: float = 15.0
    tilt_acceptable_deg: float = 30.0
    left_right_good_deg: float = 10.0
    left_right_acceptable_deg: float = 20.0
    heading_offset_good_deg: float = 5.0
    heading_offset_acceptable_deg: float = 10.0
    min_swing_deg: float = 10.0
    hinge_from: str = "orientations"

    def __post_init__(self) -> None:
        check_settings(self, "hinge_from", hinge_axis.ESTIMATORS)


DEFAULT_FUNCTIONAL_SETTINGS = FunctionalSettings()


@dataclass(frozen=True)
class HingeAxisFit:
    """One hinge joint's axis from the movement, and how well the movement defined it.

    ``j_proximal_sensor`` and ``j_distal_sensor`` (3,) the unit axis in each sensor's frame
    across the segment's long axis (the segment's lateral axis), pointing to the body's right
    once signed (``signed``); ``heading_offset_deg`` the turn about the vertical that best
    reconciles the two sensors' headings with a hinge (their filters' heading disagreement,
    left out of the fit), None when a segment hardly swung and the headings were taken as they
    are; ``flexion_low_deg`` and
    ``flexion_high_deg`` the 2.5th and 97.5th percentiles of the flexion during the movement,
    counted from the still window; ``residual_deg`` the RMS angle between the two sensors'
    axes in the world (the offset removed); ``halves_deg`` the larger angle between either sensor's axis fitted on
    the first and on the second half of the joint's turning during the movement (their parts
    across the segment's long axis); ``tilt_deg`` the larger tilt of the axis from horizontal when standing; ``used``
    whether its axis defines its segments, ``note`` why not; ``n_samples`` samples fitted.
    """

    joint: str
    proximal_sensor: str
    distal_sensor: str
    j_proximal_sensor: FloatArray
    j_distal_sensor: FloatArray
    heading_offset_deg: float | None
    flexion_low_deg: float
    flexion_high_deg: float
    residual_deg: float
    halves_deg: float
    tilt_deg: float
    used: bool
    signed: bool
    note: str
    n_samples: int

    @property
    def excursion_deg(self) -> float:
        return self.flexion_high_deg - self.flexion_low_deg

    def to_dict(self) -> dict:
        return {"joint": self.joint, "proximal_sensor": self.proximal_sensor, "distal_sensor": self.distal_sensor,
                "j_proximal_sensor": self.j_proximal_sensor.tolist(), "j_distal_sensor": self.j_distal_sensor.tolist(),
                "heading_offset_deg": self.heading_offset_deg,
                "flexion_low_deg": self.flexion_low_deg, "flexion_high_deg": self.flexion_high_deg,
                "residual_deg": self.residual_deg, "halves_deg": self.halves_deg, "tilt_deg": self.tilt_deg,
                "used": self.used, "note": self.note, "n_samples": self.n_samples}


@dataclass(frozen=True)
class ForwardAxisFit:
    """A segment's anterior axis from the walking direction.

    ``x_sensor`` (3,) unit, perpendicular to the segment's long axis; ``spread_deg`` the RMS
    angle of the per-sample walking direction (in the sensor frame, across the long axis)
    from it; ``halves_deg`` the angle between the estimates of the movement's two halves;
    ``n_samples`` samples used."""

    segment: str
    sensor: str
    x_sensor: FloatArray
    spread_deg: float
    halves_deg: float
    n_samples: int

    def to_dict(self) -> dict:
        return {"segment": self.segment, "sensor": self.sensor, "x_sensor": self.x_sensor.tolist(),
                "spread_deg": self.spread_deg, "halves_deg": self.halves_deg, "n_samples": self.n_samples}


@dataclass(frozen=True)
class AxisVerdict:
    """How well the movement defined one axis, for the person who calibrates.

    ``axis``: the hinge joint whose flexion axis it is (``knee_l``), or the segment whose
    anterior axis is the walking direction (``pelvis``); ``segments`` the segments it gives
    their frame; ``verdict`` good, acceptable or poor (the worst of its checks; :data:`NOT_DEFINED`
    when the movement did not define it and its segments took the walking direction); ``name``
    what a person calls it ("Left knee axis", "Pelvis forward direction"); ``detail`` why, in
    clinical words (what the movement showed, figures in degrees); ``words`` the whole sentence."""

    axis: str
    segments: tuple[str, ...]
    verdict: str
    name: str
    detail: str

    @property
    def words(self) -> str:
        return f"{self.name} {self.verdict}: {self.detail}"

    def to_dict(self) -> dict:
        return {"axis": self.axis, "segments": list(self.segments), "verdict": self.verdict, "words": self.words}


#: The verdict of an axis that the movement did not define (its segments face the walking direction).
NOT_DEFINED = "not defined by the movement"


@dataclass(frozen=True)
class FunctionalQuality(CalibrationQuality):
    """:class:`~mimucap.core.bodycal.CalibrationQuality` of a functional calibration, with
    ``hinges`` (every hinge fitted), ``forwards`` (every segment faced to the walking
    direction), ``axis_sources`` (segment → the joint whose axis gave its lateral axis, or
    :data:`WALKING_DIRECTION`), ``walking_direction_from`` (the joints whose axes gave the
    walking direction) and ``left_right_deg`` (joint kind → angle between the left and right
    axes when standing)."""

    hinges: tuple[HingeAxisFit, ...] = ()
    forwards: tuple[ForwardAxisFit, ...] = ()
    axis_sources: Mapping[str, str] = field(default_factory=dict)
    walking_direction_from: tuple[str, ...] = ()
    left_right_deg: Mapping[str, float] = field(default_factory=dict)
    axes: tuple[AxisVerdict, ...] = ()

    def to_dict(self) -> dict:
        document = super().to_dict()
        document.update({
            "axes": [axis.to_dict() for axis in self.axes],
            "hinges": [fit.to_dict() for fit in self.hinges],
            "forwards": [fit.to_dict() for fit in self.forwards],
            "axis_sources": dict(self.axis_sources),
            "walking_direction_from": list(self.walking_direction_from),
            "left_right_deg": dict(self.left_right_deg),
        })
        return document


# --------------------------------------------------------------------------------------------
# Building blocks
# --------------------------------------------------------------------------------------------

def across(v: ArrayLike, axis: ArrayLike) -> FloatArray:
    """``v`` (..., 3) without its component along the unit ``axis`` (3,), normalised; rows too
    close to the axis to have a direction become NaN."""
    v = np.asarray(v, dtype=np.float64)
    part = v - np.sum(v * axis, axis=-1, keepdims=True) * np.asarray(axis, dtype=np.float64)
    norm = np.linalg.norm(part, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(norm > 1e-6, part / norm, np.nan)


def _angle_deg(a: FloatArray, b: FloatArray, signed: bool = True) -> float:
    cos = float(np.dot(a, b)) / float(np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.degrees(np.arccos(np.clip(cos if signed else abs(cos), -1.0, 1.0))))


def _fit_axes(q1: FloatArray, q2: FloatArray, t: FloatArray, estimator: str, up_world: FloatArray,
              find_offset: bool) -> tuple[FloatArray, FloatArray, float]:
    """The hinge axes (signed alike) and the second sensor's heading offset (rad; 0 unless
    ``find_offset``)."""
    if estimator == "orientations":
        return hinge_axis.fit_hinge_from_orientations(q1, q2, up_world, find_offset)
    index1, rates1 = hinge_axis.angular_rates(t, q1)
    index2, rates2 = hinge_axis.angular_rates(t, q2)
    _, at1, at2 = np.intersect1d(index1, index2, return_indices=True)
    j1, j2 = hinge_axis.fit_hinge_from_rates(rates1[at1], rates2[at2])
    j2, _ = hinge_axis.consistent_signs(j1, j2, q1, q2)
    if not find_offset:
        return j1, j2, 0.0
    finite = np.all(np.isfinite(q1), axis=1) & np.all(np.isfinite(q2), axis=1)
    return j1, j2, hinge_axis.heading_offset_rad(rot.rotate(q1[finite], j1), rot.rotate(q2[finite], j2), up_world)


def swing_deg(track: FloatArray, up_sensor: FloatArray, up_world: FloatArray) -> float:
    """How far (deg) a segment's long axis ``up_sensor`` (3,), vertical standing, tilted while
    its sensor turned as ``track`` (N, 4): the 97.5th percentile of its angle from vertical."""
    tilted = rot.rotate(track, up_sensor) @ up_world
    tilted = tilted[np.isfinite(tilted)]
    return float(np.percentile(np.degrees(np.arccos(np.clip(tilted, -1.0, 1.0))), 97.5)) if tilted.size else 0.0


def fit_hinge(hinge: Hinge, sensors: tuple[str, str], t_s: FloatArray, tracks: tuple[FloatArray, FloatArray],
              still: tuple[FloatArray, FloatArray], up_sensor: tuple[FloatArray, FloatArray],
              up_world: FloatArray, settings: FunctionalSettings) -> HingeAxisFit:
    """Fit ``hinge`` on the movement: ``tracks`` the two sensors' orientations (N, 4) at the
    instants ``t_s`` (N,); ``still`` their mean orientations (4,) standing; ``up_sensor`` the
    up direction (3,) in each sensor's frame standing. The sensors' heading offset is found only
    when both segments swung by ``settings.min_swing_deg`` (it is not observable otherwise). A
    one-sided joint's axes are signed by its excursion; the others' are returned unsigned
    (``signed`` False)."""
    q1 = tracks[0]
    swing = min(swing_deg(track, up, up_world) for track, up in zip(tracks, up_sensor))
    find_offset = swing >= settings.min_swing_deg
    raw1, raw2, offset = _fit_axes(tracks[0], tracks[1], t_s, settings.hinge_from, up_world, find_offset)
    # The second sensor's orientations with the two sensors' heading disagreement removed.
    turn = rot.from_axis_angle(up_world, offset)
    q2 = rot.multiply(turn, tracks[1])
    still2 = rot.multiply(turn, still[1])
    tilt = max(float(np.degrees(np.arcsin(min(1.0, abs(float(np.dot(rot.rotate(q, j), up_world)))))))
               for q, j in ((still[0], raw1), (still[1], raw2)))
    # The segments' lateral axes: the parts of the hinge axis across their long axes.
    j1, j2 = across(raw1, up_sensor[0]), across(raw2, up_sensor[1])
    note, signed = "", False
    if not (np.all(np.isfinite(j1)) and np.all(np.isfinite(j2))):
        j1, j2 = raw1, raw2
        note = f"its axis lies along a segment's long axis ({tilt:.0f}° from horizontal when standing)"
    j2, residual = hinge_axis.consistent_signs(j1, j2, q1, q2)
    reference = rot.multiply(rot.conjugate(still[0]), still2)
    flexion_track = hinge.flexion_sign * np.degrees(hinge_axis.hinge_angle_rad(j1, q1, q2, reference))
    flexion = flexion_track[np.isfinite(flexion_track)]
    low, high = (float(v) for v in np.percentile(flexion, [2.5, 97.5]))
    if hinge.one_sided:
        if -low > high:  # it bent the other way: the axis points left
            j1, j2, low, high = -j1, -j2, -high, -low
        signed = True
        if not note and -low > settings.max_backward_share * high:
            note = (f"it turned {high:.0f}° one way and {-low:.0f}° the other from standing: flexion cannot be "
                    "told from extension")
    if not note and high - low < settings.min_excursion_deg:
        note = f"it moved only {high - low:.0f}° (at least {settings.min_excursion_deg:g}° needed)"
    # The two halves of the joint's turning (not of the time: the joint may rest in between).
    turned = np.concatenate(([0.0], np.cumsum(np.abs(np.diff(np.nan_to_num(flexion_track))))))
    half = int(np.searchsorted(turned, 0.5 * turned[-1]))
    halves = 0.0
    if min(half, q1.shape[0] - half) >= hinge_axis.MIN_SAMPLES:
        first = _fit_axes(q1[:half], tracks[1][:half], t_s[:half], settings.hinge_from, up_world, find_offset)
        second = _fit_axes(q1[half:], tracks[1][half:], t_s[half:], settings.hinge_from, up_world, find_offset)
        for k in (0, 1):
            a, b = across(first[k], up_sensor[k]), across(second[k], up_sensor[k])
            halves = max(halves, _angle_deg(a, b, signed=False) if np.all(np.isfinite(a + b)) else 90.0)
    if not note and not hinge.one_sided and halves > settings.halves_acceptable_deg:
        note = f"the axes of the movement's two halves differ by {halves:.0f}°"
    return HingeAxisFit(hinge.joint, sensors[0], sensors[1], j1, j2, float(np.degrees(offset)) if find_offset else None,
                        low, high, residual, halves, tilt, used=not note, signed=signed, note=note,
                        n_samples=int(q1.shape[0]))


def walking_direction(tracks: Sequence[FloatArray], z_sensor: Sequence[FloatArray], up_world: FloatArray
                      ) -> FloatArray:
    """The walking direction (N, 3), a horizontal unit vector per instant (NaN where undefined):
    ``up × right``, with ``right`` the horizontal part of the segments' lateral axes
    ``z_sensor`` (3,) carried into the world by their ``tracks`` (N, 4), summed."""
    right = np.zeros((tracks[0].shape[0], 3))
    for q, z in zip(tracks, z_sensor):
        right += horizontal(rot.rotate(q, z), up_world)
    norm = np.linalg.norm(right, axis=1, keepdims=True)
    usable = norm > 0.3 * len(tracks)  # the axes are not all near vertical or cancelling
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(usable, np.cross(up_world, right / norm), np.nan)


def fit_forward(segment: str, sensor: str, track: FloatArray, forward_world: FloatArray, up_sensor: FloatArray,
                ) -> ForwardAxisFit:
    """A segment's anterior axis (in its sensor's frame, across its long axis ``up_sensor``)
    facing, on average, the walking direction ``forward_world`` (N, 3) while its sensor turned
    as ``track`` (N, 4)."""
    local = across(rot.rotate(rot.conjugate(track), forward_world), up_sensor)
    local = local[np.all(np.isfinite(local), axis=1)]
    if local.shape[0] < hinge_axis.MIN_SAMPLES:
        raise CalibrationRefused(f"the walking direction is undefined for the {segment} (sensor {sensor}): walk "
                                 "longer, or bend the knees more")

    def mean(rows: FloatArray) -> FloatArray:
        return across(rows.sum(axis=0), up_sensor)

    x = mean(local)
    spread = float(np.degrees(np.sqrt(np.mean(np.arccos(np.clip(local @ x, -1.0, 1.0)) ** 2))))
    half = local.shape[0] // 2
    halves = _angle_deg(mean(local[:half]), mean(local[half:]))
    return ForwardAxisFit(segment, sensor, x, spread, halves, int(local.shape[0]))


def _segment_rotation(x_sensor: FloatArray | None, y_sensor: FloatArray, z_sensor: FloatArray | None) -> FloatArray:
    """``q_segment_from_sensor`` (4,) from the long axis and either the lateral or the anterior
    axis (sensor frame)."""
    if z_sensor is not None:
        z = across(z_sensor, y_sensor)
        x = np.cross(y_sensor, z)
    else:
        x = across(x_sensor, y_sensor)
        z = np.cross(x, y_sensor)
    r_sensor_from_segment = np.column_stack((x, y_sensor, z))
    return rot.canonical(rot.from_matrix(r_sensor_from_segment.T))


def first_still_window(t_s: ArrayLike, q_world_from_sensor: Mapping[str, ArrayLike], duration_s: float = 1.0,
                       limit_deg: float = DEFAULT_FUNCTIONAL_SETTINGS.stillness_good_deg) -> tuple[float, float]:
    """The first window ``(start, end)`` (s) of ``duration_s`` in which every sensor's
    orientation (N, 4) at the instants ``t_s`` (N,) stays within ``limit_deg`` of its mean, by
    steps of a tenth of the duration. ``ValueError`` when there is none."""
    t = np.asarray(t_s, dtype=np.float64)
    tracks = [np.asarray(q, dtype=np.float64) for q in q_world_from_sensor.values()]
    starts = np.arange(t[0], t[-1] - duration_s + 1e-9, duration_s / 10.0) if t[-1] - t[0] >= duration_s else []
    for start in starts:
        window = slice(int(np.searchsorted(t, start)), int(np.searchsorted(t, start + duration_s, side="right")))
        for q in tracks:
            part = q[window]
            if not np.all(np.isfinite(part)) or np.degrees(rot.angle_between(rot.average(part), part)).max() > limit_deg:
                break
        else:
            return float(t[window.start]), float(t[window.stop - 1])
    raise ValueError(f"no {duration_s:g} s in which every sensor stayed within {limit_deg:g}° (standing still)")


# --------------------------------------------------------------------------------------------
# The procedure
# --------------------------------------------------------------------------------------------

def calibrate_functional(
    t_s: ArrayLike,
    q_world_from_sensor: Mapping[str, ArrayLike],
    mapping: Mapping[str, str],
    still_s: tuple[float, float],
    movement_s: tuple[float, float],
    up_world: ArrayLike = (0.0, 0.0, 1.0),
    settings: FunctionalSettings = DEFAULT_FUNCTIONAL_SETTINGS,
    still_orientations: Mapping[str, ArrayLike] | None = None,
) -> BodyCalibration:
    """Functional calibration of a recording (module docstring).

    ``t_s`` (N,) s; ``q_world_from_sensor`` sensor id → (N, 4) orientation tracks at those
    instants (NaN rows allowed in the movement); ``mapping`` segment → sensor id; ``still_s``
    the window ``(start, end)`` s in which the subject stood still and upright; ``movement_s``
    the window in which they walked (or flexed the elbows), before or after it, not
    overlapping; ``up_world`` the world's up direction. ``still_orientations`` (optional,
    sensor id → (4,)) replaces a sensor's mean still orientation for its long axis (e.g.
    :func:`~mimucap.core.bodycal.static_alignment` of its accelerometer), as the N-pose
    calibration's ``npose_orientations``. Raises :class:`~mimucap.core.bodycal.CalibrationRefused`
    (a ``ValueError``) when a sensor moved while standing or the movement defined no
    knee or elbow axis for a segment that needs the walking direction; ``ValueError`` for
    windows outside the recording or overlapping.
    """
    t = np.asarray(t_s, dtype=np.float64)
    up = unit_vector(up_world, "up_world")
    mapping = check_mapping(mapping, list(q_world_from_sensor))
    still = pose_window(t, still_s, "still-standing")
    moving = pose_window(t, movement_s, "movement")
    if still.start < moving.stop and moving.start < still.stop:
        raise ValueError(f"the still-standing window {still_s[0]:g}:{still_s[1]:g} s and the movement window "
                         f"{movement_s[0]:g}:{movement_s[1]:g} s overlap")
    sensors = list(dict.fromkeys(mapping.values()))
    means, stillness = window_means(q_world_from_sensor, sensors, still, STILL_POSE)
    checks = stillness_checks(stillness, settings.stillness_limit_deg, settings.stillness_good_deg)
    given = {sensor: unit_quaternion(q, f"still orientation of sensor {sensor}")
             for sensor, q in (still_orientations or {}).items() if sensor in means}
    q_still = {**means, **given}
    up_sensor = {segment: rot.rotate(rot.conjugate(q_still[sensor]), up) for segment, sensor in mapping.items()}
    t_move = t[moving]
    tracks = {segment: np.asarray(q_world_from_sensor[sensor], dtype=np.float64)[moving]
              for segment, sensor in mapping.items()}

    # 1. Every hinge with both segments mapped.
    fits: dict[str, HingeAxisFit] = {}
    for hinge in HINGES:
        if hinge.proximal in mapping and hinge.distal in mapping:
            pair = (hinge.proximal, hinge.distal)
            fits[hinge.joint] = fit_hinge(
                hinge, (mapping[pair[0]], mapping[pair[1]]), t_move, (tracks[pair[0]], tracks[pair[1]]),
                (means[mapping[pair[0]]], means[mapping[pair[1]]]), (up_sensor[pair[0]], up_sensor[pair[1]]), up,
                settings)

    def owner_axis(segment: str) -> FloatArray | None:
        joint, side = AXIS_OWNER.get(segment, (None, None))
        fit = fits.get(joint)
        if fit is None or not fit.used or not fit.signed:
            return None
        return fit.j_proximal_sensor if side == "proximal" else fit.j_distal_sensor

    # 2. Lateral axes from the one-sided hinges (knee, elbow); the walking direction from them.
    z_sensor: dict[str, FloatArray] = {}
    sources: dict[str, str] = {}
    for segment in mapping:
        axis = owner_axis(segment)
        if axis is not None:
            z_sensor[segment] = across(axis, up_sensor[segment])
            sources[segment] = AXIS_OWNER[segment][0]
    direction_from: tuple[str, ...] = ()
    forward = None
    for joints in WALKING_HINGES:
        segments = [s for s in z_sensor if AXIS_OWNER[s][0] in joints]
        if segments:
            direction_from = tuple(j for j in joints if j in fits and fits[j].used)
            forward = walking_direction([tracks[s] for s in segments], [z_sensor[s] for s in segments], up)
            break

    # 3. The ankles and wrists whose joint moved are signed by their proximal segment's lateral
    # axis and give their distal segment's; 4. every other segment faces the walking direction.
    for hinge in HINGES:
        fit = fits.get(hinge.joint)
        if hinge.one_sided or fit is None or not fit.used or hinge.proximal not in z_sensor:
            continue
        if float(np.dot(fit.j_proximal_sensor, z_sensor[hinge.proximal])) < 0.0:
            fit = _flipped(fit)
        fits[hinge.joint] = fit = replace(fit, signed=True)
        z_sensor[hinge.distal] = across(fit.j_distal_sensor, up_sensor[hinge.distal])
        sources[hinge.distal] = hinge.joint
    forwards: list[ForwardAxisFit] = []
    x_sensor: dict[str, FloatArray] = {}
    for segment, sensor in mapping.items():
        if segment in z_sensor:
            continue
        if forward is None:
            raise CalibrationRefused(
                f"the movement defined no knee or elbow flexion axis, so the {segment} (sensor {sensor}) has no "
                "forward direction: walk, or bend the knees or elbows "
                + _hinge_notes(fits, ("knee_l", "knee_r", "elbow_l", "elbow_r")))
        fit = fit_forward(segment, sensor, tracks[segment], forward, up_sensor[segment])
        forwards.append(fit)
        x_sensor[segment] = fit.x_sensor
        sources[segment] = WALKING_DIRECTION

    q_segment_from_sensor = {segment: _segment_rotation(x_sensor.get(segment), up_sensor[segment],
                                                        z_sensor.get(segment)) for segment in mapping}
    left_right = {}
    for kind in ("knee", "elbow"):
        pair = [fits.get(f"{kind}_{s}") for s in "lr"]
        if all(fit is not None and fit.used for fit in pair):
            world = [rot.rotate(q_still[fit.proximal_sensor], fit.j_proximal_sensor) for fit in pair]
            left_right[kind] = _angle_deg(world[0], world[1])
    axes = axis_verdicts(fits, forwards, mapping, settings)
    checks += [check for axis in axes.values() for check in axis[1]]
    checks += [(grade(angle, settings.left_right_good_deg, settings.left_right_acceptable_deg),
                f"the left and right {kind} axes differ by {angle:.0f}° when standing")
               for kind, angle in left_right.items()]

    # The body's heading standing: the pelvis's, else the segments' mean.
    heading_from = ["pelvis"] if "pelvis" in mapping else list(mapping)
    facing = sum(horizontal(rot.rotate(rot.multiply(q_still[mapping[s]], rot.conjugate(q_segment_from_sensor[s])),
                                       np.array([1.0, 0.0, 0.0])), up) for s in heading_from)
    q_world_from_body = q_world_from_body_from_forward(facing, up)
    verdict, problems = verdict_of(checks)
    quality = FunctionalQuality(METHOD, tuple(stillness), verdict=verdict, problems=problems,
                                hinges=tuple(fits.values()), forwards=tuple(forwards), axis_sources=sources,
                                walking_direction_from=direction_from, left_right_deg=left_right,
                                axes=tuple(verdict for verdict, _ in axes.values()))
    details = {"still_s": [float(still_s[0]), float(still_s[1])],
               "movement_s": [float(movement_s[0]), float(movement_s[1])], "hinge_from": settings.hinge_from}
    if given:
        details["still_track_vs_given_deg"] = {
            sensor: float(np.degrees(rot.angle_between(means[sensor], q))) for sensor, q in sorted(given.items())}
    return BodyCalibration(q_world_from_body, up, dict(mapping), q_segment_from_sensor, quality, details)


def _flipped(fit: HingeAxisFit) -> HingeAxisFit:
    return replace(fit, j_proximal_sensor=-fit.j_proximal_sensor, j_distal_sensor=-fit.j_distal_sensor,
                   flexion_low_deg=-fit.flexion_high_deg, flexion_high_deg=-fit.flexion_low_deg)


def _hinge_notes(fits: Mapping[str, HingeAxisFit], joints: Sequence[str]) -> str:
    notes = [f"{joint}: {fits[joint].note}" for joint in joints if joint in fits and fits[joint].note]
    return f"({'; '.join(notes)})" if notes else "(no knee or elbow has sensors on both its segments)"


def axis_verdicts(fits: Mapping[str, HingeAxisFit], forwards: Sequence[ForwardAxisFit], mapping: Mapping[str, str],
                  settings: FunctionalSettings) -> dict[str, tuple[AxisVerdict, list[tuple[int, str]]]]:
    """Every axis (hinge joint, or segment faced to the walking direction) → its
    :class:`AxisVerdict` and its graded checks ``(grade, words)`` (those of the verdict)."""
    s = settings
    found: dict[str, tuple[AxisVerdict, list[tuple[int, str]]]] = {}
    for fit in fits.values():
        name = joint_name(fit.joint)
        hinge = next(h for h in HINGES if h.joint == fit.joint)
        owned = tuple(seg for seg in (hinge.proximal, hinge.distal)
                      if AXIS_OWNER.get(seg, ("", ""))[0] == fit.joint and seg in mapping)
        if not fit.used:
            level = 1 if hinge.one_sided else 0
            instead = " and ".join(segment_name(seg).lower() for seg in owned)
            verdict = AxisVerdict(fit.joint, (), NOT_DEFINED, f"{name} axis", fit.note
                                  + (f"; the {instead} face the walking direction instead" if owned else ""))
            found[fit.joint] = (verdict, [(level, verdict.words)])
            continue
        lower = name.lower()
        checks = [
            (grade(-fit.excursion_deg, -s.excursion_good_deg, -s.excursion_acceptable_deg),
             (f"the {lower} moved only {fit.excursion_deg:.0f}°: its axis is weakly defined "
              f"(at least {s.excursion_good_deg:g}° wanted)")),
            (grade(fit.residual_deg, s.residual_good_deg, s.residual_acceptable_deg),
             (f"the {lower} did not move as a hinge: its axis wandered {fit.residual_deg:.1f}° RMS between its "
              "two sensors")),
            (grade(fit.halves_deg, s.halves_good_deg, s.halves_acceptable_deg),
             f"the {lower} axis differs by {fit.halves_deg:.1f}° between the two halves of the movement"),
        ]
        if hinge.one_sided:
            checks.append((grade(fit.tilt_deg, s.tilt_good_deg, s.tilt_acceptable_deg),
                           f"the {lower} axis is tilted {fit.tilt_deg:.0f}° from horizontal when standing"))
            if fit.heading_offset_deg is not None:
                offset = abs(fit.heading_offset_deg)
                checks.append((grade(offset, s.heading_offset_good_deg, s.heading_offset_acceptable_deg),
                               (f"the {lower}'s two sensors disagree on their heading by {offset:.0f}° (check "
                                "their magnetometer calibrations): its rotation angle will carry it")))
        verdict, problems = verdict_of(checks)
        detail = (f"it bent {fit.flexion_low_deg:.0f}° to {fit.flexion_high_deg:.0f}°, the two halves of the movement "
                  f"found it within {fit.halves_deg:.1f}° of each other, and it moved as a hinge within "
                  f"{fit.residual_deg:.0f}° RMS")
        if problems:
            detail += f" ({'; '.join(problems)})"
        found[fit.joint] = (AxisVerdict(fit.joint, owned, verdict, f"{name} axis", detail), checks)
    for fit in forwards:
        level = grade(fit.halves_deg, s.halves_good_deg, s.halves_acceptable_deg)
        name = segment_name(fit.segment)
        check = (f"the {name.lower()}'s forward direction differs by {fit.halves_deg:.1f}° between the two halves of "
                 "the movement")
        detail = (f"it faces the walking direction; the two halves of the movement found it within "
                  f"{fit.halves_deg:.1f}° of each other")
        found[fit.segment] = (AxisVerdict(fit.segment, (fit.segment,), VERDICTS[level], f"{name} forward direction",
                                          detail), [(level, check)])
    return found
