"""Range of motion (ROM) from joint angles: the extremes of any joint-angle column over a time
window, and the active ROM of the standard clinical movements.

The range of a column over a window (:func:`range_of_motion`) is its largest minus its
smallest value over the samples whose time lies in the window, as goniometry reports it (Norkin
& White, "Measurement of Joint Motion: A Guide to Goniometry"); samples that are not finite (a
gap in the pose) are left out.

Each :class:`RomMovement` names the joint-angle column it reads and the sign that makes the
movement positive (abduction is negative adduction in the ISB convention of
``core.skeleton.JOINT_ANGLE_SIGNS_DOC``; trunk rotation to the right is negative). Shoulder
movements use the humerus's **elevation in the plane of the movement** instead, from the
segment orientations (the Z-X'-Y'' decomposition is singular at 90° of abduction): the
direction of the upper arm (elbow from shoulder) in the thorax frame, ``d = (d_x forward,
d_y up, d_z right)``, gives flexion ``atan2(d_x, −d_y)`` in the sagittal plane and abduction
``atan2(±d_z, −d_y)`` in the frontal plane (+ for the right arm, − for the left): 0 with the arm
hanging, 90° horizontal, 180° overhead, as a goniometer reads them.

A movement is repeated; each repetition's peak is captured by :class:`RepetitionCounter`
(at least ``min_prominence_deg`` of movement) and the peaks are averaged. The active ROM of one repetition is its peak minus the
lowest angle before it (since the previous peak); the table gives their mean, the peak angles,
the left/right difference and the reference value.

Reference values for adults (active ROM, degrees) are those of the American Academy of
Orthopaedic Surgeons, "Joint Motion: Method of Measuring and Recording" (AAOS, 1965), as
tabulated in Norkin & White, "Measurement of Joint Motion: A Guide to Goniometry" (F. A. Davis):
shoulder flexion 180, abduction 180, elbow flexion 150, hip flexion 120, abduction 45, knee
flexion 135, thoracolumbar flexion 80 and rotation 45. Soucie et al. 2011 ("Range of motion
measurements: reference values and a database for comparison studies", Haemophilia
17:500-507) measured passive ROM by age and sex and found mean adult values below several of
these (e.g. shoulder flexion and knee flexion); clinicians comparing with it should keep that
in mind.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mimucap.core import rotation as rot

REFERENCE_SOURCE = "AAOS 1965 (Norkin & White)"


@dataclass(frozen=True)
class RangeOfMotion:
    """One column's extremes over a window: ``min_deg``, ``max_deg`` and ``rom_deg`` = max − min
    (degrees), from ``samples`` finite samples."""

    min_deg: float
    max_deg: float
    rom_deg: float
    samples: int


def window_mask(t_s: np.ndarray, start_s: float | None = None, end_s: float | None = None) -> np.ndarray:
    """Boolean mask (T,) of the times ``t_s`` (T,) s in ``[start_s, end_s]`` (open ends when None);
    ``ValueError`` when ``end_s`` comes before ``start_s``."""
    t = np.asarray(t_s, dtype=float)
    if start_s is not None and end_s is not None and end_s < start_s:
        raise ValueError(f"the window ends ({end_s:.3f} s) before it starts ({start_s:.3f} s)")
    mask = np.ones(t.shape, dtype=bool)
    if start_s is not None:
        mask &= t >= start_s
    if end_s is not None:
        mask &= t <= end_s
    return mask


def range_of_motion(t_s: np.ndarray, angles_deg: Mapping[str, np.ndarray], start_s: float | None = None,
                    end_s: float | None = None) -> dict[str, RangeOfMotion]:
    """Column → :class:`RangeOfMotion` of joint-angle curves ``angles_deg`` (column → (T,) deg)
    sampled at ``t_s`` (T,) s, over ``[start_s, end_s]``. A column without a finite sample in
    the window is left out; ``ValueError`` when a column's length differs from ``t_s``."""
    t = np.asarray(t_s, dtype=float)
    mask = window_mask(t, start_s, end_s)
    found: dict[str, RangeOfMotion] = {}
    for column, values in angles_deg.items():
        values = np.asarray(values, dtype=float)
        if values.shape != t.shape:
            raise ValueError(f"joint angle {column}: {values.shape[0] if values.ndim else 0} samples "
                             f"for {t.shape[0]} times")
        chosen = values[mask]
        chosen = chosen[np.isfinite(chosen)]
        if chosen.size:
            low, high = float(chosen.min()), float(chosen.max())
            found[column] = RangeOfMotion(low, high, high - low, int(chosen.size))
    return found


# -- the clinical movements --------------------------------------------------------------------


@dataclass(frozen=True)
class RomMovement:
    """One clinical movement: ``key``, ``label``, ``joint`` (model joint), ``axis`` (column
    axis, or ``sagittal``/``frontal`` for the shoulder's elevation in that plane), ``sign`` (+1/−1, or per side for trunk rotation via
    ``sign_left``/``sign_right``), ``sided`` (a limb joint done left and right),
    ``instruction`` for the subject, ``reference_deg`` normal adult active ROM."""

    key: str
    label: str
    joint: str
    axis: str
    sign_left: float
    sign_right: float
    sided: bool
    instruction: str
    reference_deg: float

    def column(self, side: str) -> str:
        """The joint-angle column read (trunk joints have one column for both sides)."""
        if self.joint in ("lumbar", "neck"):
            return f"{self.joint}_{self.axis}_deg"
        return f"{self.joint}_{side[0]}_{self.axis}_deg"

    def sign(self, side: str) -> float:
        return self.sign_left if side == "left" else self.sign_right


MOVEMENTS: tuple[RomMovement, ...] = (
    RomMovement("shoulder_flexion", "Shoulder flexion", "shoulder", "sagittal", 1, 1, True,
                "Raise the {side} arm forward and up as far as you can, thumb up, then lower it.", 180.0),
    RomMovement("shoulder_abduction", "Shoulder abduction", "shoulder", "frontal", 1, 1, True,
                "Raise the {side} arm sideways and up as far as you can, palm forward, then lower it.", 180.0),
    RomMovement("elbow_flexion", "Elbow flexion", "elbow", "flexion", 1, 1, True,
                "Bend the {side} elbow as far as you can, palm up, then straighten it.", 150.0),
    RomMovement("hip_flexion", "Hip flexion", "hip", "flexion", 1, 1, True,
                "Standing, lift the {side} knee towards the chest as far as you can, then put the foot down.", 120.0),
    RomMovement("hip_abduction", "Hip abduction", "hip", "adduction", -1, -1, True,
                "Standing, move the straight {side} leg out to the side as far as you can, then back.", 45.0),
    RomMovement("knee_flexion", "Knee flexion", "knee", "flexion", 1, 1, True,
                "Standing, bend the {side} knee and bring the heel towards the buttock, then put the foot down.", 135.0),
    RomMovement("trunk_flexion", "Trunk flexion", "lumbar", "flexion", 1, 1, False,
                "Bend forward as far as you can with straight knees, then stand up straight.", 80.0),
    RomMovement("trunk_rotation", "Trunk rotation", "lumbar", "rotation", 1, -1, True,
                "Keeping the hips still, turn the upper body to the {side} as far as you can, then back.", 45.0),
)
MOVEMENT_KEYS = tuple(m.key for m in MOVEMENTS)


def movement(key: str) -> RomMovement:
    for m in MOVEMENTS:
        if m.key == key:
            return m
    raise ValueError(f"unknown ROM movement {key!r}; use one of {', '.join(MOVEMENT_KEYS)}")


def sides_of(m: RomMovement) -> tuple[str, ...]:
    return ("left", "right") if m.sided else ("both",)


#: The ROM protocol's markers: ``rom:<movement key>:<side>:start`` and ``...:end``, stored so in a
#: recording (machine-readable: the analysis finds the movements by them).
ROM_MARKER_PREFIX = "rom:"
#: The two ends of a ROM marker, stored and read as they are.
_MARKER_ENDS = ("start", "end")


def rom_marker_label(key: str, side: str, end: str) -> str:
    """The stored label of a ROM protocol marker: ``end`` is ``"start"`` or ``"end"``."""
    if end not in _MARKER_ENDS:
        raise ValueError(f"a ROM marker is a start or an end, got {end!r}")
    return f"{ROM_MARKER_PREFIX}{key}:{side}:{end}"


def parse_rom_marker(label: str) -> tuple[str, str, str] | None:
    """``(movement key, side, "start" | "end")`` of a ROM protocol marker's label, or ``None``
    for another label."""
    parts = str(label).split(":")
    if len(parts) != 4 or parts[0] + ":" != ROM_MARKER_PREFIX or parts[1] not in MOVEMENT_KEYS \
            or parts[3] not in _MARKER_ENDS:
        return None
    return parts[1], parts[2], parts[3]


def marker_words(label: str) -> str:
    """A marker's label as a person reads it: a ROM protocol marker ``rom:knee_flexion:left:start``
    reads "Knee flexion (left) — start" (a movement of both sides has no side); any other label
    is already the user's or the procedure's words and is returned as it is."""
    parsed = parse_rom_marker(label)
    if parsed is None:
        return str(label)
    key, side, end = parsed
    sided = f" ({side})" if side in ("left", "right") else ""
    return f"{movement(key).label}{sided} — {end}"


def shoulder_elevation_deg(q_world_from_thorax: np.ndarray, q_world_from_upper_arm: np.ndarray, plane: str,
                           side: str) -> np.ndarray:
    """Elevation (T,) deg of the upper arm in the sagittal (``plane="sagittal"``: flexion) or
    frontal (``"frontal"``: abduction) plane of the thorax (module doc)."""
    q_thorax_from_arm = rot.multiply(rot.conjugate(np.asarray(q_world_from_thorax, dtype=float)),
                                     np.asarray(q_world_from_upper_arm, dtype=float))
    d = rot.rotate(q_thorax_from_arm, np.array([0.0, -1.0, 0.0]))  # towards the elbow
    if plane == "sagittal":
        return np.degrees(np.arctan2(d[..., 0], -d[..., 1]))
    outward = d[..., 2] if side == "right" else -d[..., 2]
    return np.degrees(np.arctan2(outward, -d[..., 1]))


def movement_series(m: RomMovement, side: str, angles_deg: dict[str, np.ndarray],
                    q_world_from_segment: dict[str, np.ndarray] | None = None) -> np.ndarray:
    """The angle (T,) deg of movement ``m`` on ``side``, positive in the movement's direction.
    ``ValueError`` when the recording lacks the joint."""
    if m.axis in ("sagittal", "frontal"):
        arm = f"upper_arm_{side[0]}"
        if not q_world_from_segment or arm not in q_world_from_segment or "thorax" not in q_world_from_segment:
            raise ValueError(f"{m.label} ({side}) needs the thorax and {arm} orientations")
        return shoulder_elevation_deg(q_world_from_segment["thorax"], q_world_from_segment[arm], m.axis, side)
    column = m.column(side)
    if column not in angles_deg:
        raise ValueError(f"{m.label} ({side}) needs the joint-angle column {column}")
    return m.sign(side) * np.asarray(angles_deg[column], dtype=float)


@dataclass(frozen=True)
class RomResult:
    """ROM of one movement on one side: ``peaks_deg`` (K,) the repetitions' peak angles,
    ``excursions_deg`` (K,) their active ROM; ``peak_deg`` and ``active_rom_deg`` the means
    (NaN when no repetition was found); ``reference_deg`` the normal value."""

    key: str
    side: str
    peaks_deg: tuple[float, ...]
    excursions_deg: tuple[float, ...]
    reference_deg: float

    @property
    def repetitions(self) -> int:
        return len(self.peaks_deg)

    @property
    def peak_deg(self) -> float:
        return float(np.mean(self.peaks_deg)) if self.peaks_deg else math.nan

    @property
    def active_rom_deg(self) -> float:
        return float(np.mean(self.excursions_deg)) if self.excursions_deg else math.nan

    @property
    def percent_of_reference(self) -> float:
        return 100.0 * self.active_rom_deg / self.reference_deg


class RepetitionCounter:
    """Captures repetitions of a movement angle sample by sample: once the angle has risen at
    least ``min_prominence_deg`` above the lowest angle since the previous repetition, its
    highest value is the peak, captured when the angle has come back down by half of that
    excursion (and at least ``min_prominence_deg``). Hysteresis makes a held plateau with
    sensor noise one repetition, not several."""

    def __init__(self, min_prominence_deg: float = 10.0) -> None:
        self.min_prominence_deg = float(min_prominence_deg)
        self.baseline = math.inf
        self.peak = -math.inf
        self.peaks: list[float] = []
        self.excursions: list[float] = []

    def feed(self, value: float) -> bool:
        """Take one angle (deg); True when it completed a repetition."""
        if not math.isfinite(value):
            return False
        if value > self.peak:
            self.peak = value
        if self.peak - self.baseline < self.min_prominence_deg and value < self.baseline:
            self.baseline = self.peak = value
            return False
        excursion = self.peak - self.baseline
        if excursion >= self.min_prominence_deg and self.peak - value >= max(self.min_prominence_deg, 0.5 * excursion):
            self.peaks.append(self.peak)
            self.excursions.append(excursion)
            self.baseline = self.peak = value
            return True
        return False


def repetitions(values_deg: np.ndarray, min_prominence_deg: float = 10.0) -> tuple[list[float], list[float]]:
    """Peaks and excursions (deg) of the repetitions in a movement angle series (T,)
    (:class:`RepetitionCounter`)."""
    counter = RepetitionCounter(min_prominence_deg)
    for value in np.asarray(values_deg, dtype=float):
        counter.feed(float(value))
    return counter.peaks, counter.excursions


def rom_of(m: RomMovement, side: str, values_deg: np.ndarray, min_prominence_deg: float = 10.0) -> RomResult:
    """The :class:`RomResult` of movement ``m`` on ``side`` from its angle series."""
    peaks, excursions = repetitions(values_deg, min_prominence_deg)
    return RomResult(m.key, side, tuple(peaks), tuple(excursions), m.reference_deg)


def left_right_difference_deg(results: dict[tuple[str, str], RomResult], key: str) -> float:
    """Left minus right active ROM (deg) of movement ``key`` (NaN when a side is missing)."""
    left, right = results.get((key, "left")), results.get((key, "right"))
    if left is None or right is None:
        return math.nan
    return left.active_rom_deg - right.active_rom_deg
