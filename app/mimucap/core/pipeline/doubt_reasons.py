"""Why an orientation or a joint angle may be wrong: the reason bits and their names (no I/O).

Every stage of the processing path that can doubt its result says why with the same
vocabulary: the per-sensor chain (:mod:`.sensor_doubt`: the filter's uncertainty, a foreign
field, lost samples, standing reasons) and the joint angles (:mod:`.joint_angles`: the body
calibration, the magnetometer turns, the Euler sequence's singularity). Reasons are bits of a
``uint16`` (:data:`REASONS` names them for people and for files: the ``<joint>_ok`` columns
and their header lines, the review, the live status).
"""

from __future__ import annotations

import numpy as np

DOUBT_DTYPE = np.uint16

# Reasons of one sensor's orientation
NO_ORIENTATION = 1 << 0
SETTLING = 1 << 1
MAG_REJECTED = 1 << 2
MAG_MISSING = 1 << 3
NO_MAGNETOMETER = 1 << 4
FIELD_MISMATCH = 1 << 5
LOST_SAMPLES = 1 << 6
MAG_UNCALIBRATED = 1 << 7
ONBOARD_UNCALIBRATED = 1 << 8
ACC_REJECTED = 1 << 9
# Reasons of a joint angle beyond its sensors'
NO_BODY_CALIBRATION = 1 << 10
BODY_CALIBRATION_POOR = 1 << 11
OFF_BODY = 1 << 12
BODY_CALIBRATION_DOUBTFUL = 1 << 13
SINGULAR = 1 << 14

#: Reason bit → (short name for files, words for people), in the order people read them: what
#: to act on first.
REASONS: dict[int, tuple[str, str]] = {
    MAG_UNCALIBRATED: ("mag_uncalibrated", "magnetometer not calibrated"),
    ONBOARD_UNCALIBRATED: ("onboard_uncalibrated", "the sensor's own calibration is incomplete"),
    NO_BODY_CALIBRATION: ("no_body_calibration", "no body calibration"),
    BODY_CALIBRATION_POOR: ("body_calibration_poor", "the body calibration's verdict is poor"),
    BODY_CALIBRATION_DOUBTFUL: ("body_calibration_doubtful",
                                "the body calibration was made from doubtful orientations"),
    OFF_BODY: ("off_body", "sensors off the body (magnetometer calibration)"),
    FIELD_MISMATCH: ("field_mismatch", "heading taken from a magnetic field that differs from the calibrated one"),
    MAG_REJECTED: ("mag_rejected", "magnetometer rejected as disturbed for longer than the gyroscope can bridge"),
    MAG_MISSING: ("mag_missing", "magnetometer samples missing for longer than the gyroscope can bridge"),
    NO_MAGNETOMETER: ("no_magnetometer", "no magnetometer: heading from the gyroscope alone"),
    LOST_SAMPLES: ("lost_samples", "samples lost"),
    ACC_REJECTED: ("acc_rejected", "accelerometer rejected (strong accelerations)"),
    NO_ORIENTATION: ("no_orientation", "no orientation yet"),
    SETTLING: ("settling", "orientation still settling"),
    SINGULAR: ("singular", "near the angle sequence's singularity (gimbal lock)"),
}


def reason_names(reasons: int) -> list[str]:
    """The short names (:data:`REASONS`) of the bits set in ``reasons``."""
    return [name for bit, (name, _words) in REASONS.items() if reasons & bit]


def describe(reasons: int) -> str:
    """The reasons set in ``reasons`` in words, joined by "; " ("" when there are none)."""
    return "; ".join(words for bit, (_name, words) in REASONS.items() if reasons & bit)


def spans(t_s: np.ndarray, reasons: np.ndarray, join_s: float = 1.0) -> list[tuple[float, float, int]]:
    """The spans ``(start_s, end_s, reasons)`` where ``reasons`` (N,) are set, on the time axis
    ``t_s`` (N,) s; spans closer than ``join_s`` (s) are joined, their reasons combined."""
    reasons = np.asarray(reasons)
    doubtful = reasons != 0
    if not np.any(doubtful):
        return []
    edges = np.flatnonzero(np.diff(np.concatenate([[0], doubtful.astype(np.int8), [0]])))
    found: list[tuple[float, float, int]] = []
    for begin, end in zip(edges[::2], edges[1::2]):
        bits = int(np.bitwise_or.reduce(reasons[begin:end]))
        start, stop = float(t_s[begin]), float(t_s[end - 1])
        if found and start - found[-1][1] < join_s:
            found[-1] = (found[-1][0], stop, found[-1][2] | bits)
        else:
            found.append((start, stop, bits))
    return found
