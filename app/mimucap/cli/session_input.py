"""A MimuCap session on the command line: its samples through the one processing path.

``bodycal`` and ``angles`` read a session's raw samples and run them through
:func:`mimucap.session.processing.process_session` (magnetometer calibration, orientation
filter, body calibration, joint angles), exactly as review and export do. The magnetometer
calibrations applied are, for each sensor, the first found of: a ``--mag-calibration`` file,
the calibration the session recorded, the user's calibration store (where ``mimucap magcal fit
--save`` and the wizard keep them), which gives a sensor only its own device's calibration
(:meth:`~mimucap.io.calibration_store.CalibrationStore.lookup`; the device the session says the
sensor was). Each calibration applied is judged as the live view judges it
(:mod:`mimucap.session.calibration_readiness`: verdict, device, the recording's local field, age)
and one that is not good is named with its figures (:func:`warn_about_magnetometers`), as is a
stored calibration that is not used. The N-pose and T-pose windows come from the session's
markers when none are given.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path

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
    from mimucap.io.quaternion_tables import MIMUCAP_SESSION, orientation_input_kind

    return orientation_input_kind(path) == MIMUCAP_SESSION


@dataclass
class ChosenMagnetometers:
    """The magnetometer calibrations a command applies to a session: ``calibrations`` sensor →
    calibration; ``lines`` one per sensor with a magnetometer, saying where its calibration came
    from and its standing; ``standings`` sensor → :class:`~mimucap.core.magcal_standing.Standing`;
    ``notes`` sensor → why a stored calibration was not used."""

    calibrations: dict = field(default_factory=dict)
    lines: list[str] = field(default_factory=list)
    standings: dict = field(default_factory=dict)
    notes: dict[str, str] = field(default_factory=dict)

    def not_good(self) -> list[str]:
        """Sensors whose applied calibration is not good."""
        return [sid for sid, standing in self.standings.items() if not standing.good]


def magnetometer_calibrations(session, files) -> ChosenMagnetometers:
    """The calibration each sensor gets (see the module docstring), with a line per sensor."""
    from mimucap.io.calibration_store import CalibrationFileError, CalibrationStore, calibration_from_json
    from mimucap.session.calibration_readiness import session_standings
    from mimucap.session.processing import recorded_processing

    chosen = ChosenMagnetometers()
    origin: dict[str, str] = {}
    for name in files or []:
        path = Path(name)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as error:
            raise ValueError(f"--mag-calibration {path}: cannot read it ({error})") from None
        calibration = calibration_from_json(data, str(path))
        if calibration.sensor_id not in session.sensors:
            raise ValueError(f"--mag-calibration {path}: sensor {calibration.sensor_id} is not in the session "
                             f"(it has {', '.join(session.sensors)})")
        chosen.calibrations[calibration.sensor_id] = calibration
        origin[calibration.sensor_id] = str(path)
    recorded = recorded_processing(session).mag_calibrations
    devices = session.devices()
    store = CalibrationStore()
    for sensor_id, stream in session.sensors.items():
        if sensor_id in chosen.calibrations or stream.mag_uT is None:
            continue
        if sensor_id in recorded:
            chosen.calibrations[sensor_id], origin[sensor_id] = recorded[sensor_id], "recorded with the session"
            continue
        try:
            found = store.lookup(sensor_id, devices[sensor_id])
        except CalibrationFileError as error:
            raise ValueError(str(error)) from None
        if found.calibration is not None:
            chosen.calibrations[sensor_id] = found.calibration
            origin[sensor_id] = f"stored ({store.path_for(sensor_id, found.calibration.device_id)})"
        elif found.note:
            chosen.notes[sensor_id] = found.note
    chosen.standings = session_standings(session, chosen.calibrations)
    for sid, stream in session.sensors.items():
        if stream.mag_uT is None:
            continue
        if sid in chosen.calibrations:
            chosen.lines.append(f"magnetometer {sid}: {origin[sid]}; {chosen.standings[sid].summary()}")
        else:
            note = chosen.notes.get(sid)
            chosen.lines.append(f"magnetometer {sid}: not calibrated (raw field used)" + (f": {note}" if note else ""))
    return chosen


def warn_about_magnetometers(command: str, session, chosen: ChosenMagnetometers, origin: str = "") -> list[str]:
    """Print on stderr a warning naming each sensor whose applied calibration is not good (with
    its figures) or whose stored calibration was not used, and return the sensors not good.
    ``origin``: the session's file, named when a command reads several."""
    from mimucap.core.clinical_names import sensor_name

    def name(sid: str) -> str:
        return sensor_name(session.sensors[sid].segment, sid)

    head = f"mimucap {command}: warning: " + (f"{origin}: " if origin else "")
    for sid in chosen.not_good():
        print(f"{head}the magnetometer calibration of {name(sid)} is "
              f"{chosen.standings[sid].summary()}; calibrate it again where the recording is made",
              file=sys.stderr)
    for sid, note in chosen.notes.items():
        print(f"{head}{name(sid)} is not calibrated: {note}", file=sys.stderr)
    return chosen.not_good()


def warn_about_recorded_magnetometers(command: str, session, origin: str = "") -> list[str]:
    """For a command that processes a session with the calibrations it recorded (``export``,
    ``gait``, ``report``): warn (stderr) about each recorded calibration that is not good, and
    name the sensors whose magnetometer the recording holds no calibration for; returns the
    sensors not good."""
    from mimucap.session.calibration_readiness import session_standings
    from mimucap.session.processing import recorded_processing

    recorded = recorded_processing(session).mag_calibrations
    chosen = ChosenMagnetometers(calibrations=dict(recorded), standings=session_standings(session, recorded))
    raw = [sid for sid, stream in session.sensors.items()
           if stream.mag_uT is not None and stream.q_world_from_sensor is None and sid not in recorded]
    if raw:
        more = f" and {len(raw) - 3} more" if len(raw) > 3 else ""
        print(f"mimucap {command}: warning: {origin + ': ' if origin else ''}the recording holds no magnetometer "
              f"calibration for {', '.join(raw[:3])}{more}: their raw field is used", file=sys.stderr)
    return warn_about_magnetometers(command, session, chosen, origin)


def pose_windows_from_markers(markers, end_s: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """The N-pose and T-pose windows (s) from the session's phase markers
    (:mod:`mimucap.core.phases`): the end of each pose, up to the next marker minus
    :data:`POSE_MARGIN_S`, at most :data:`POSE_LONGEST_S` long and not before the pose's marker
    plus :data:`POSE_SETTLE_S` (the subject is in the pose and still). The last N-pose before
    the first T-pose after it is used. ``ValueError`` when the markers do not name both poses."""
    from mimucap.core import phases

    npose_all = phases.phase_windows(markers, phases.NPOSE, end_s)
    tpose_all = phases.phase_windows(markers, phases.TPOSE, end_s)
    pairs = [(n, t) for t in tpose_all for n in npose_all if n[1] <= t[0]]
    if not pairs:
        labels = ", ".join(f"'{m.label}'" for m in sorted(markers, key=lambda m: m.t_s)) or "none"
        raise ValueError(f"no '{phases.NPOSE}' marker followed by a '{phases.TPOSE}' marker in the session "
                         f"(markers: {labels}); give --npose and --tpose")
    # The first T-pose, and the N-pose just before it.
    npose, tpose = min(pairs, key=lambda pair: (pair[1][0], -pair[0][0]))

    def held(window, name):
        start, stop = window
        last = stop - POSE_MARGIN_S
        first = max(start + POSE_SETTLE_S, last - POSE_LONGEST_S)
        if last <= first:
            raise ValueError(f"the {name} from {start:.2f} s to {stop:.2f} s is too short to hold the pose")
        return first, last

    return held(npose, "N-pose"), held(tpose, "T-pose")


def orientation_table(session, source: str, mag_calibrations: dict):
    """Every sensor's orientation (reprocessed) on the reference sensor's instants where every
    sensor has one, as a :class:`~mimucap.io.quaternion_tables.QuaternionTable` (world ENU)."""
    import numpy as np

    from mimucap.core.pipeline import RESULT_REPROCESSED, finite_track, orientation_at
    from mimucap.io.quaternion_tables import QuaternionTable
    from mimucap.session.processing import process_session

    output = process_session(session, result=RESULT_REPROCESSED, mag_calibrations=mag_calibrations)
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
    return QuaternionTable(t_common, quats, np.array([0.0, 0.0, 1.0]), "ENU", source, hints)
