"""A MimuCap session on the command line: its samples through the one processing path.

``bodycal`` and ``angles`` read a session's raw samples and run them through
:func:`mimucap.session.recorded.reprocessing.process_session` (magnetometer calibration, orientation
filter, body calibration, joint angles), exactly as review and export do, with the
calibrations :func:`mimucap.session.recorded.calibration_choice.applied_calibrations` chooses (per sensor: a
``--mag-calibration`` file, the one the body calibration was made with, the one the session
recorded, the user's calibration store for a session that does not record its live
processing, which gives a sensor only its own device's calibration). Each calibration applied
is judged as the live view judges it (verdict, device, the recording's local field, age), and
one that is not good is named with its figures (:func:`warn_about_magnetometers`), as is a
stored calibration that is not used. The N-pose and T-pose windows (or, for a functional
calibration, the still and walking windows) come from the session's markers when none are given.
"""

from __future__ import annotations

import argparse
import sys

#: Seconds after a pose's marker before the pose can be held (the subject gets into it).
POSE_SETTLE_S = 1.0
#: Seconds before the next marker that still belong to the pose, and the longest window (s).
POSE_MARGIN_S = 0.3
POSE_LONGEST_S = 1.0


def add_session_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--mag-calibration", action="append", metavar="FILE", default=None,
                        help="magnetometer calibration JSON to apply (repeatable; default: the session's, "
                             "then the user's stored ones)")


def is_session(path) -> bool:
    from mimucap.io.orientation_inputs import MIMUCAP_SESSION, orientation_input_kind

    return orientation_input_kind(path) == MIMUCAP_SESSION


def magnetometer_calibrations(session, files):
    """The magnetometer calibrations to apply to ``session`` without its body calibration
    (:func:`mimucap.session.recorded.calibration_choice.applied_calibrations` with the files given): an
    :class:`~mimucap.session.recorded.calibration_choice.AppliedCalibrations` whose ``lines()`` say, per
    sensor, where its calibration came from and how it stands."""
    from mimucap.session.recorded.calibration_choice import applied_calibrations

    return applied_calibrations(session, mag_files=files or (), stored_body=False)


def warn_about_magnetometers(command: str, session, applied, origin: str = "") -> list[str]:
    """Print on stderr a warning naming each sensor whose applied calibration is not good for
    this recording (with its figures), whose stored calibration was not used, or whose raw field
    is used, and return the sensors not good. ``applied``: the
    :class:`~mimucap.session.recorded.calibration_choice.AppliedCalibrations`; ``origin``: the session's file,
    named when a command reads several."""
    from mimucap.core.clinical_names import sensor_name

    def name(sid: str) -> str:
        return sensor_name(session.sensors[sid].segment, sid)

    head = f"mimucap {command}: warning: " + (f"{origin}: " if origin else "")
    for sid in applied.not_good():
        print(f"{head}the magnetometer calibration of {name(sid)} is "
              f"{applied.standings[sid].summary()}; calibrate it again where the recording is made",
              file=sys.stderr)
    for sid, note in applied.store_notes.items():
        print(f"{head}{name(sid)} is not calibrated: {note}", file=sys.stderr)
    raw = [sid for sid in applied.raw_field if sid not in applied.store_notes]
    if raw:
        more = f" and {len(raw) - 3} more" if len(raw) > 3 else ""
        print(f"{head}the recording holds no magnetometer calibration for {', '.join(raw[:3])}{more}: their raw "
              "field is used", file=sys.stderr)
    return applied.not_good()


def held_window(window: tuple[float, float], name: str) -> tuple[float, float]:
    """The part of a pose's phase window (s) in which the pose is held: up to the next marker
    minus :data:`POSE_MARGIN_S`, at most :data:`POSE_LONGEST_S` long and not before the pose's
    marker plus :data:`POSE_SETTLE_S`. ``ValueError`` when the phase is too short."""
    start, stop = window
    last = stop - POSE_MARGIN_S
    first = max(start + POSE_SETTLE_S, last - POSE_LONGEST_S)
    if last <= first:
        raise ValueError(f"the {name} from {start:.2f} s to {stop:.2f} s is too short to hold the pose")
    return first, last


def _marker_labels(markers) -> str:
    return ", ".join(f"'{m.label}'" for m in sorted(markers, key=lambda m: m.t_s)) or "none"


def pose_windows_from_markers(markers, end_s: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """The N-pose and T-pose windows (s) from the session's phase markers
    (:mod:`mimucap.core.phase_markers`): each pose's :func:`held_window`. The last N-pose before the
    first T-pose after it is used. ``ValueError`` when the markers do not name both poses."""
    from mimucap.core import phase_markers

    npose_all = phase_markers.phase_windows(markers, phase_markers.NPOSE, end_s)
    tpose_all = phase_markers.phase_windows(markers, phase_markers.TPOSE, end_s)
    pairs = [(n, t) for t in tpose_all for n in npose_all if n[1] <= t[0]]
    if not pairs:
        raise ValueError(f"no '{phase_markers.NPOSE}' marker followed by a '{phase_markers.TPOSE}' marker in the "
                         f"session (markers: {_marker_labels(markers)}); give --npose and --tpose")
    # The first T-pose, and the N-pose just before it.
    npose, tpose = min(pairs, key=lambda pair: (pair[1][0], -pair[0][0]))
    return held_window(npose, "N-pose"), held_window(tpose, "T-pose")


def functional_windows_from_markers(markers, end_s: float) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The still-standing and movement windows (s) of a functional calibration from the
    session's phase markers: the :func:`held_window` of the last N-pose before the first walk
    after an N-pose, and that walk's phase (to the next marker). None when the markers name no
    N-pose followed by a walk (the T-pose is not used)."""
    from mimucap.core import phase_markers

    npose_all = phase_markers.phase_windows(markers, phase_markers.NPOSE, end_s)
    walks = phase_markers.phase_windows(markers, phase_markers.WALK, end_s)
    pairs = [(n, w) for w in walks for n in npose_all if n[1] <= w[0]]
    if not pairs:
        return None
    npose, walk = min(pairs, key=lambda pair: (pair[1][0], -pair[0][0]))
    return held_window(npose, "N-pose"), walk


def orientation_table(session, source: str, mag_calibrations: dict, heading: str | None = None):
    """Every sensor's orientation (reprocessed, with ``mag_calibrations``: sensor → the
    magnetometer calibration applied, and the heading mode ``heading``: the filters run without
    magnetometers in :data:`~mimucap.core.heading_modes.MODE_NO_MAGNETOMETER`) on the reference
    sensor's instants where every sensor has one, as a
    :class:`~mimucap.io.orientation_tables.QuaternionTable` (world ENU), with the reasons each
    may be wrong."""
    import numpy as np

    from mimucap.core.pipeline.instants import finite_track, orientation_at
    from mimucap.core.pipeline.joint_angles import at_instants
    from mimucap.core.pipeline.settings import RESULT_REPROCESSED
    from mimucap.io.orientation_tables import QuaternionTable
    from mimucap.session.recorded.calibration_choice import AppliedCalibrations
    from mimucap.session.recorded.reprocessing import process_session

    output = process_session(session, result=RESULT_REPROCESSED,
                             calibrations=AppliedCalibrations(magnetometer=dict(mag_calibrations)), heading=heading)
    for problem in output.problems:
        print(f"  {problem}")
    tracks = {sid: finite_track(session.sensors[sid].t_s, q) for sid, q in output.q_world_from_sensor.items()}
    tracks = {sid: track for sid, track in tracks.items() if len(track[0])}
    if not tracks:
        raise ValueError(f"{source}: no sensor gives an orientation")
    reference = max(tracks, key=lambda sid: len(tracks[sid][0]))
    start = max(t[0] for t, _q in tracks.values())
    stop = min(t[-1] for t, _q in tracks.values())
    t_ref = tracks[reference][0]
    t_common = t_ref[(t_ref >= start) & (t_ref <= stop)]
    quats = {sid: orientation_at(t_common, t, q) for sid, (t, q) in tracks.items()}
    hints = {sid: s.segment for sid, s in session.sensors.items() if s.segment}
    hold_s = float(np.max(np.diff(t_ref))) if len(t_ref) > 1 else 0.0
    doubts = {sid: at_instants(t_common, session.sensors[sid].t_s, output.doubt[sid], hold_s) for sid in tracks}
    return QuaternionTable(t_common, quats, np.array([0.0, 0.0, 1.0]), "ENU", source, hints, doubts)
