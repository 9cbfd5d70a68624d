"""The phases of a recording session, as its markers name them, and their time windows.

A session that carries its own calibration holds a marker at the start of each phase: the
magnetometer turns (one turn about each sensor axis, the single-axis protocol of Choe, Zhao,
Qiu and So, "Study of calibration method of low-cost MEMS magnetometer"), the N-pose, the
T-pose, then the movements. The simulated suit writes them (:mod:`mimucap.core.simulate.scenarios`);
a person marks them in the same words. A phase lasts from its marker to the next marker, or
to the end of the recording.

Markers are ``(t_s, label)`` pairs or objects with ``t_s`` (s, host clock of the session) and
``label`` attributes (:class:`mimucap.io.session.Marker`). Standard library only.
"""

from __future__ import annotations

from collections.abc import Iterable

#: Marker labels of the phases. A T-pose with one arm raised reads "T-pose (right arm)".
MAG_TURNS = "magnetometer turns"
MAG_FIGURE8 = "magnetometer figure 8"
MAG_TUMBLE = "magnetometer tumble"
NPOSE = "N-pose"
TPOSE = "T-pose"
WALK = "walk"
TURN = "turn"
SQUAT = "squat"
ARM_RAISE = "arm raise"
#: Phases of the clinical tests (Timed Up and Go, the chair stand): seated, rising, sitting down.
SITTING = "sitting"
SIT_TO_STAND = "sit-to-stand"
STAND_TO_SIT = "stand-to-sit"
#: The user's own start and stop of a clinical test (they override what the sensors show).
TEST_START = "test start"
TEST_STOP = "test stop"


def _pairs(markers: Iterable) -> list[tuple[float, str]]:
    pairs = []
    for marker in markers:
        if hasattr(marker, "label"):
            pairs.append((float(marker.t_s), str(marker.label)))
        else:
            t_s, label = marker
            pairs.append((float(t_s), str(label)))
    return sorted(pairs, key=lambda pair: pair[0])


def is_phase(label: str, phase: str) -> bool:
    """Whether a marker ``label`` starts phase ``phase`` (``"T-pose (left arm)"`` is a
    :data:`TPOSE`); letter case and surrounding spaces do not matter."""
    text, name = label.strip().lower(), phase.strip().lower()
    return text == name or text.startswith(name + " (")


def phase_windows(markers: Iterable, phase: str, end_s: float) -> list[tuple[float, float]]:
    """Time windows ``(start_s, end_s)`` of every ``phase`` in the markers, in time order: from
    its marker to the next marker (of any label) or to ``end_s`` (the end of the recording).
    Empty windows (a marker at or after ``end_s``) are left out."""
    pairs = _pairs(markers)
    windows = []
    for index, (t_s, label) in enumerate(pairs):
        if not is_phase(label, phase):
            continue
        stop = pairs[index + 1][0] if index + 1 < len(pairs) else float(end_s)
        stop = min(stop, float(end_s))
        if stop > t_s:
            windows.append((t_s, stop))
    return windows


#: Phases in which the sensors are turned in the hands, not worn on their segments.
OFF_BODY_PHASES = (MAG_TURNS, MAG_FIGURE8, MAG_TUMBLE)


def off_body_windows(markers: Iterable, end_s: float) -> list[tuple[float, float]]:
    """The time windows ``(start_s, end_s)``, in time order, in which the markers say the sensors
    were in the hands (a magnetometer calibration phase), not on the body: no joint angle, turn
    or stride is measured there."""
    markers = list(markers)
    return sorted(window for phase in OFF_BODY_PHASES for window in phase_windows(markers, phase, end_s))
