"""``mimucap bodycal``: body calibration of a recording, written as CAL.json.

``mimucap bodycal INPUT [--method npose-tpose|heading|functional] [--mapping SENSOR=SEGMENT[,...]]
[--npose T0:T1] [--tpose T2:T3] [--heading-from SENSOR:AXIS] [--still T0:T1] [--movement T2:T3]
[--hinge-from orientations|rates] [--heading MODE] [--mag-calibration FILE] [--accept-poor] --out CAL.json [--json]``

INPUT is a MimuCap session or any orientation table
:func:`mimucap.io.orientation_inputs.read_quaternion_table` reads (quaternion CSV, OpenSim
``.sto``, Xsens export file or folder, APDM CSV). A session's raw samples go through the
processing path (its magnetometer calibrations, or the stored ones, or ``--mag-calibration``;
the orientation filter, reprocessed). Three methods:

* ``npose-tpose`` (the default; ``--npose``, ``--tpose``): N-pose then both arms raised
  sideways; a session's N-pose and T-pose markers give the windows when none are given.
* ``heading`` (chosen by ``--heading-from pelvis_imu:z``): the forward direction is that sensor
  axis (OpenSense's ``base_heading_axis``) in the N-pose window (default: the first sample).
* ``functional`` (``--still``, ``--movement``): standing still, then walking (or flexing the
  elbows); the joints' flexion axes and the walking direction give every segment
  (:mod:`mimucap.core.functional_bodycal`). A session's windows come from its markers (the
  N-pose before the first walk, and that walk; the T-pose is not used); otherwise the still
  window is the first second in which every sensor was still and the movement runs from its
  end to the end of the recording.

Options of another method are refused. A calibration whose verdict is poor is written but the
command exits with status 3, unless ``--accept-poor``; so is one made while a sensor's
magnetometer calibration is not good (another device's, a local field that no longer fits it,
too old: each named with its figures). ``--heading no-magnetometer`` (rooms where no
magnetometer can be trusted) runs the filters without magnetometers and takes the still pose's
headings from their tracks; the calibration notes the mode, and ``mimucap angles`` applies it
with the same mode.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

from mimucap.cli import check_output_path, refuse_to_overwrite_input
from mimucap.cli.session_input import (
    add_session_options, is_session, magnetometer_calibrations, orientation_table,
    pose_windows_from_markers, warn_about_magnetometers,
)
from mimucap.core.skeleton_models import MODEL_NAMES
from mimucap.io.input_names import XSENS_FILE, XSENS_FOLDER


def parse_window(text: str, option: str) -> tuple[float, float]:
    """``"T0:T1"`` (seconds) → ``(T0, T1)``; a single ``"T"`` is the window ``T:T``."""
    parts = text.split(":")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ValueError(f"{option} {text!r}: expected START:END in seconds") from None
    if len(values) == 1:
        values = values * 2
    if len(values) != 2:
        raise ValueError(f"{option} {text!r}: expected START:END in seconds")
    return values[0], values[1]


def parse_mapping(items: list[str] | None) -> dict[str, str]:
    """``["S1=pelvis,S2=thorax", ...]`` → ``{segment: sensor}`` with named errors."""
    mapping: dict[str, str] = {}
    for item in items or []:
        for pair in item.split(","):
            pair = pair.strip()
            if not pair:
                continue
            if "=" not in pair:
                raise ValueError(f"--mapping entry {pair!r}: expected SENSOR=SEGMENT")
            sensor, segment = (p.strip() for p in pair.split("=", 1))
            if not sensor:
                raise ValueError(f"--mapping entry {pair!r}: segment {segment!r} has no sensor")
            if not segment:
                raise ValueError(f"--mapping entry {pair!r}: sensor {sensor!r} has no segment")
            if segment in mapping:
                raise ValueError(f"--mapping: segment {segment} is given two sensors ({mapping[segment]} and {sensor})")
            mapping[segment] = sensor
    return mapping


def choose_model(name: str, segments) -> object:
    """The skeleton model named (or, for ``auto``, the smallest one holding every segment)."""
    from mimucap.io.skeleton_model_file import load_model

    if name != "auto":
        return load_model(name)
    for candidate in MODEL_NAMES:
        model = load_model(candidate)
        if all(s in model.segment_names for s in segments):
            return model
    return load_model(MODEL_NAMES[-1])


def add_heading_option(parser: argparse.ArgumentParser) -> None:
    """``--heading MODE``: where the sensors' headings come from (the session's setting when absent)."""
    from mimucap.core.heading_modes import MODE_LABELS, MODES

    parser.add_argument("--heading", choices=MODES, default=None,
                        help="where the sensors' headings come from (default: the recording's setting, else coupled): "
                             + "; ".join(f"{mode}: {label}" for mode, label in MODE_LABELS.items()))


def add_reader_options(parser: argparse.ArgumentParser) -> None:
    """The input argument and the orientation readers' options, shared with ``mimucap angles``."""
    parser.add_argument("input", help="orientation table: .csv, .sto, Xsens .txt or folder, session .h5")
    parser.add_argument("--up", metavar="AXIS", default=None,
                        help="world up axis of a CSV or .sto table (x, y, z, -x...; default: z)")
    parser.add_argument("--sensor-names", metavar="XML", default=None,
                        help="OpenSense mapping (myIMUMappings.xml) naming Xsens sensors")
    parser.add_argument("--trial", metavar="PREFIX", default=None,
                        help="trial prefix when an Xsens folder holds several trials")
    parser.add_argument("--rate", metavar="HZ", type=float, default=None,
                        help="Xsens update rate when the export header gives none (default 100)")
    add_session_options(parser)


#: The inputs each Xsens reader option applies to (it is refused for the others, not ignored).
OPTION_INPUTS = {
    "--sensor-names": (XSENS_FOLDER, XSENS_FILE),
    "--trial": (XSENS_FOLDER,),
    "--rate": (XSENS_FOLDER, XSENS_FILE),
}


def check_reader_options(args: argparse.Namespace) -> None:
    """``ValueError`` for a reader option given with an input it does not apply to (e.g.
    ``--trial`` with a MimuCap session), which the reader would otherwise ignore silently."""
    from mimucap.io.orientation_inputs import orientation_input_kind

    given = {"--sensor-names": args.sensor_names, "--trial": args.trial, "--rate": args.rate}
    if all(value is None for value in given.values()):
        return
    kind = orientation_input_kind(args.input)
    for option, kinds in OPTION_INPUTS.items():
        if given[option] is not None and kind not in kinds:
            raise ValueError(f"{args.input}: {option} applies to {' and '.join(kinds)} only, not to {kind}")


#: Exit status of a calibration whose verdict is poor (written, but not to be used unseen).
EXIT_POOR = 3


def read_input(args: argparse.Namespace):
    """The orientation table of ``args.input`` with the reader options checked first (a
    session's through the processing path); the session too, or None; and the magnetometer
    calibrations applied (:func:`magnetometer_calibrations`; none for a table; judged on the
    calibration's windows by :func:`judged_on_the_windows` once they are known)."""
    from mimucap.io.orientation_inputs import read_quaternion_table
    from mimucap.session.recorded.calibration_choice import AppliedCalibrations

    if args.rate is not None and not (math.isfinite(args.rate) and args.rate > 0):
        raise ValueError(f"--rate {args.rate:g}: the update rate must be a positive number of Hz")
    check_reader_options(args)
    if is_session(args.input):
        from mimucap.io.session import read_session

        _refuse_up_for_session(args)
        session = read_session(args.input)
        mags = magnetometer_calibrations(session, args.mag_calibration)
        heading = getattr(args, "heading", None)
        return orientation_table(session, str(args.input), mags.magnetometer, heading), session, mags
    if args.mag_calibration:
        raise ValueError(f"{args.input}: --mag-calibration applies to MimuCap sessions (raw magnetometer "
                         "samples), not to orientation tables")
    return read_quaternion_table(args.input, up_axis=args.up, sensor_names=args.sensor_names,
                                 trial_prefix=args.trial, rate_hz=args.rate), None, AppliedCalibrations()


def judged_on_the_windows(session, mags, windows):
    """``mags`` (the calibrations applied) judged on the local field of the calibration's
    ``windows`` (``(start, end)`` s each: from the N-pose to the end of the T-pose, or from the
    still standing to the end of the movement; the whole recording without windows): the body
    calibration takes its headings there, and a disturbance later in the recording is the
    doubtful-data flags' business, not a reason to call the calibration stale."""
    from dataclasses import replace

    from mimucap.session.recorded.calibration_readiness import session_standings

    span = None if not windows else (min(w[0] for w in windows), max(w[1] for w in windows))
    return replace(mags, standings=session_standings(session, mags.magnetometer, window_s=span))


def _refuse_up_for_session(args: argparse.Namespace) -> None:
    import numpy as np

    from mimucap.io.orientation_tables import axis_vector

    if args.up is not None and not np.allclose(axis_vector(args.up), (0.0, 0.0, 1.0)):
        raise ValueError(f"{args.input}: up axis {args.up} cannot apply: MimuCap sessions are z up")


def static_npose_orientations(session, mags, mapping: dict[str, str], npose: tuple[float, float], table,
                              pose: str = "N-pose") -> dict:
    """Sensor → ``q_world_from_sensor`` (4,) of the still ``pose`` window from its mean accelerometer and
    calibrated magnetometer samples (:func:`mimucap.core.bodycal.static_alignment`, the filter's
    world frame and declination), for the mapped sensors fused with a magnetometer calibration
    (what their filters converge to, whatever transient the filter's estimate still carries);
    the others keep their orientation tracks. ``mags``: sensor → the magnetometer calibration
    the processing path applied (``magnetometer`` of :func:`read_input`'s calibrations);
    ``table`` the reprocessed orientation tracks (:func:`read_input`).

    The static alignment's heading is that of the field at the sensor's place in the pose. Where
    the room's field is not the same over the body (a floor's field fading with height turns the
    thighs' field by degrees with no change of magnitude or dip a check could see), that place's
    turn would stay in the segment's rotation about its long axis for the whole recording, while
    the reprocessed track, the gyroscope carrying the field of the whole recording, holds the
    heading the angles are computed with. So each sensor's heading is turned toward its track's
    in the pose by the share :func:`~mimucap.core.heading_sources.own_field_weight` denies its own
    field, from how much that field's deviation from the body's varied while it moved
    (:func:`field_spreads`): none in a field the body shares."""
    import numpy as np

    from mimucap.core import bodycal
    from mimucap.core.heading_sources import own_field_weight
    from mimucap.session.recorded.stored_processing import recorded_processing

    fusion = recorded_processing(session).settings.fusion
    found = {}
    for sensor_id in mapping.values():
        stream = session.sensors[sensor_id]
        if (sensor_id not in mags or stream.q_world_from_sensor is not None or stream.acc is None
                or stream.mag_uT is None):
            continue
        inside = (stream.t_s >= npose[0]) & (stream.t_s <= npose[1])
        acc, mag = stream.acc[inside], stream.mag_uT[inside]
        good = np.all(np.isfinite(acc), axis=1) & np.all(np.isfinite(mag), axis=1)
        if not np.any(good):
            continue
        try:
            found[sensor_id] = bodycal.static_alignment(acc[good], mags[sensor_id].apply(mag[good], sensor_id),
                                                        fusion.declination_rad, mags[sensor_id].field_uT,
                                                        fusion.mag_norm_tol)
        except ValueError:
            continue  # a vertical or disturbed field: the orientation track stays
    if found:
        print(f"  {pose} orientations from the still sensors' accelerometer and calibrated magnetometer: "
              f"{', '.join(sorted(found))}")
    spreads = field_spreads(session, mags, table, fusion.rest_max_rate_rad_s) if found else {}
    in_pose = (table.t_s >= npose[0]) & (table.t_s <= npose[1])
    turned = []
    for sensor_id in sorted(found):
        weight = own_field_weight(spreads.get(sensor_id, np.nan))
        if weight < 1.0 and sensor_id in table.q_world_from_sensor:
            found[sensor_id] = bodycal.turned_toward(found[sensor_id], table.q_world_from_sensor[sensor_id][in_pose],
                                                     1.0 - weight, table.up_world)
            turned.append(f"{sensor_id} {100.0 * (1.0 - weight):.0f} %")
    if turned:
        print(f"  {pose} headings toward the reprocessed track, the field varying over the sensor's path: "
              f"{', '.join(turned)}")
    return found


def field_spreads(session, mags, table, rest_rate_rad_s: float) -> dict[str, float]:
    """Sensor → how much its field's deviation from the body's varied while it moved (µT,
    :func:`~mimucap.core.fusion.uniform_field.deviation_spread_uT`), for the sensors of
    ``table`` (reprocessed tracks) with a magnetometer calibration among ``mags``, at the
    table's instants: those outside the session's off-body windows (the magnetometer turns)
    at which the sensor turned faster than ``rest_rate_rad_s`` (the filter's rest limit)."""
    import numpy as np

    from mimucap.core.fusion.uniform_field import deviation_spread_uT
    from mimucap.core.pipeline.instants import value_at
    from mimucap.session.recorded.reprocessing import off_body_windows

    t = table.t_s
    sensors = [sid for sid in table.q_world_from_sensor if sid in mags and session.sensors[sid].mag_uT is not None
               and session.sensors[sid].gyr is not None]
    if not sensors:
        return {}
    on_body = np.ones(t.shape, bool)
    for start, end in off_body_windows(session):
        on_body &= ~((t >= start) & (t <= end))
    q = np.stack([table.q_world_from_sensor[sid] for sid in sensors], axis=1)
    mag, moving = [], []
    for sid in sensors:
        stream = session.sensors[sid]
        mag.append(value_at(t, stream.t_s, mags[sid].apply(stream.mag_uT, sid), np.nan))
        rate = np.linalg.norm(value_at(t, stream.t_s, stream.gyr, np.nan), axis=-1)
        moving.append(on_body & (rate > rest_rate_rad_s))
    spread = deviation_spread_uT(q, np.stack(mag, axis=1), np.stack(moving, axis=1))
    return dict(zip(sensors, spread.tolist()))


def pose_doubts(table, mapping: dict[str, str], windows) -> dict[str, str]:
    """Mapped sensor → why its orientation was doubtful (words) somewhere in the calibration's
    ``windows`` (``(start, end)`` s each; for the N/T-pose, from the N-pose's start to the
    T-pose's end), for the sensors the processing path doubted there
    (:attr:`~mimucap.io.orientation_tables.QuaternionTable.doubt`)."""
    import numpy as np

    from mimucap.core.pipeline.doubt_reasons import describe

    if not windows or not table.doubt:
        return {}
    inside = np.zeros(table.t_s.shape, bool)
    for start, end in windows:
        inside |= (table.t_s >= start) & (table.t_s <= end)
    found = {}
    for sensor in mapping.values():
        reasons = int(np.bitwise_or.reduce(table.doubt[sensor][inside])) if sensor in table.doubt and np.any(inside) else 0
        if reasons:
            found[sensor] = describe(reasons)
    return found


#: The options of each method (refused with the others), and the method each selects when no
#: ``--method`` is given.
METHOD_OPTIONS = {
    "npose-tpose": ("--tpose", "--arms", "--forward-from"),
    "heading": ("--heading-from",),
    "functional": ("--still", "--movement", "--hinge-from"),
}


def chosen_method(args: argparse.Namespace) -> str:
    """The calibration method: ``--method``, else ``heading`` with ``--heading-from``, else
    ``npose-tpose``. ``ValueError`` for an option of another method (named) and for ``--npose``
    with the functional method."""
    given = {"--tpose": args.tpose, "--arms": args.arms, "--forward-from": args.forward_from,
             "--heading-from": args.heading_from, "--still": args.still, "--movement": args.movement,
             "--hinge-from": args.hinge_from}
    method = args.method or ("heading" if args.heading_from else "npose-tpose")
    if args.method is None and args.tpose and args.heading_from:
        raise ValueError("give either --tpose (N/T-pose calibration) or --heading-from, not both")
    for other, options in METHOD_OPTIONS.items():
        if other == method:
            continue
        wrong = [option for option in options if given[option] is not None]
        if wrong:
            raise ValueError(f"{', '.join(wrong)} belong{'s' if len(wrong) == 1 else ''} to the {other} method, not "
                             f"to --method {method}")
    if method == "functional" and args.npose:
        raise ValueError("--method functional takes its standing window from --still, not --npose")
    if method == "heading" and not args.heading_from:
        raise ValueError("--method heading needs --heading-from SENSOR:AXIS")
    return method


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "bodycal",
        help="body calibration (N/T-pose, heading axis or functional) of an orientation recording",
        description=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--method", choices=tuple(METHOD_OPTIONS), default=None,
                        help="npose-tpose (default), heading (with --heading-from) or functional (stand still, walk)")
    parser.add_argument("--mapping", action="append", metavar="SENSOR=SEGMENT[,...]",
                        help="sensor of each segment (repeatable; default: the session's assignment)")
    parser.add_argument("--npose", metavar="T0:T1", help="N-pose window in seconds")
    parser.add_argument("--tpose", metavar="T2:T3", help="T-pose window in seconds (N/T-pose calibration)")
    parser.add_argument("--heading-from", metavar="SENSOR:AXIS",
                        help="sensor axis pointing forward in the N-pose, e.g. pelvis_imu:z or S1:-x")
    parser.add_argument("--still", metavar="T0:T1", help="functional: window in which the subject stood still")
    parser.add_argument("--movement", metavar="T2:T3",
                        help="functional: window in which the subject walked (or flexed the elbows)")
    parser.add_argument("--hinge-from", choices=("orientations", "rates"), default=None,
                        help="functional: hinge axes from the sensors' relative orientation (default) or their "
                             "angular rates alone (Seel et al.; needs no heading)")
    parser.add_argument("--arms", choices=("auto", "left", "right", "both"), default=None,
                        help="arms raised in the T-pose (default: every arm sensor that turned)")
    parser.add_argument("--forward-from", choices=("swing", "rotation_axis"), default=None,
                        help="forward estimate of the N/T-pose: the arm's swing (default) or its rotation axis (Podoprosvetov et al.)")
    parser.add_argument("--model", default="auto", help=f"skeleton model: auto, {', '.join(MODEL_NAMES)} or a JSON file")
    parser.add_argument("--accept-poor", action="store_true",
                        help="exit 0 even when the calibration's verdict is poor or a magnetometer calibration "
                             "is not good")
    add_heading_option(parser)
    add_reader_options(parser)
    parser.add_argument("--out", required=True, metavar="CAL.json", help="calibration file to write")
    parser.add_argument("--json", action="store_true", help="print the calibration as JSON")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mimucap.core import bodycal
    from mimucap.io.body_calibration_file import write_body_calibration
    from mimucap.session.recorded.calibration_choice import with_magnetometers

    check_output_path(args.out)
    refuse_to_overwrite_input(args.out, args.input)
    method = chosen_method(args)
    table, session, mags = read_input(args)
    mapping = parse_mapping(args.mapping)
    if not mapping:
        if not table.segment_hints:
            raise ValueError("--mapping SENSOR=SEGMENT[,...] is required (the input names no segments)")
        from mimucap.core.pipeline.segments import one_sensor_per_segment

        mapping = {segment: sensor for sensor, segment in one_sensor_per_segment(table.segment_hints).items()}
    model = choose_model(args.model, mapping)
    mapping = bodycal.check_mapping(mapping, table.sensor_ids, model.segment_names)
    if method == "functional":
        calibration, windows = _functional(args, table, session, mags, mapping)
    else:
        calibration, windows = _posed(args, method, table, session, mags, mapping)
    if session is not None:
        mags = judged_on_the_windows(session, mags, windows)
        for line in mags.lines():
            print(f"  {line}")
        warn_about_magnetometers("bodycal", session, mags)
    calibration = bodycal.with_doubtful_sensors(calibration, pose_doubts(table, mapping, windows))
    # the magnetometer calibrations its orientations were computed with go with it
    calibration = with_magnetometers(calibration, mags.magnetometer if session is not None else None,
                                     origin=f"mimucap bodycal of {args.input}")
    extra = {"model": model.name, "input": str(args.input), "world_frame": table.world_frame}
    if args.heading is not None:
        extra["heading"] = args.heading
    if mags.standings:
        extra["magnetometer_standing"] = {sid: standing.to_json() for sid, standing in mags.standings.items()}
    document = write_body_calibration(args.out, calibration, extra)
    if args.json:
        print(json.dumps(document, indent=2))
    else:
        _print_summary(args, calibration)
    if calibration.quality.verdict == "poor" and not args.accept_poor:
        print(f"mimucap bodycal: the calibration's verdict is poor ({'; '.join(calibration.quality.problems)}): "
              f"{'redo the movement' if method == 'functional' else 'redo the poses'}, or pass --accept-poor to use "
              "it anyway", file=sys.stderr)
        return EXIT_POOR
    poor_magnetometers = [sid for sid in mags.not_good() if sid in mapping.values()]
    if poor_magnetometers and not args.accept_poor:
        print(f"mimucap bodycal: the magnetometer calibration of {', '.join(poor_magnetometers)} is not good (see "
              "above): the headings it gives are not to be trusted; calibrate the magnetometers again, or "
              "pass --accept-poor to use the calibration anyway", file=sys.stderr)
        return EXIT_POOR
    return 0


def _tracks_own_headings(args, session) -> bool:
    """Whether the still pose's sensor orientations are the tracks' own: without a session (no
    raw samples to align on), and without magnetometers (each filter's arbitrary start, the
    heading the angles are computed with)."""
    from mimucap.core.heading_modes import MODE_NO_MAGNETOMETER

    return session is None or args.heading == MODE_NO_MAGNETOMETER


def _posed(args, method: str, table, session, mags, mapping):
    """The N/T-pose or heading calibration and its windows (for the doubt check)."""
    from mimucap.core import bodycal
    from mimucap.io.orientation_tables import axis_vector

    npose = parse_window(args.npose, "--npose") if args.npose else None
    tpose = parse_window(args.tpose, "--tpose") if args.tpose else None
    if session is not None and method == "npose-tpose" and npose is None and tpose is None:
        npose, tpose = pose_windows_from_markers(session.markers, float(table.t_s[-1]))
        print(f"  pose windows from the session's markers: N-pose {npose[0]:.2f}-{npose[1]:.2f} s, "
              f"T-pose {tpose[0]:.2f}-{tpose[1]:.2f} s")
    if method == "heading":
        sensor, sep, axis = args.heading_from.rpartition(":")
        if not sep or not sensor:
            raise ValueError(f"--heading-from {args.heading_from!r}: expected SENSOR:AXIS (e.g. pelvis_imu:z)")
        if sensor not in table.q_world_from_sensor and sensor in mapping:
            sensor = mapping[sensor]
        calibration = bodycal.calibrate_heading(
            table.t_s, table.q_world_from_sensor, mapping, sensor, axis_vector(axis),
            npose_s=npose, up_world=table.up_world,
        )
        return calibration, [npose] if npose is not None else []
    if tpose is None:
        raise ValueError("give --tpose T2:T3 (N/T-pose calibration) or --heading-from SENSOR:AXIS, or use "
                         "--method functional")
    if npose is None:
        raise ValueError("--tpose needs --npose T0:T1 as well")
    static = {} if _tracks_own_headings(args, session) else static_npose_orientations(session, mags.magnetometer,
                                                                                        mapping, npose, table)
    calibration = bodycal.calibrate_npose_tpose(
        table.t_s, table.q_world_from_sensor, mapping, npose, tpose,
        up_world=table.up_world, arms=args.arms or "auto",
        settings=bodycal.BodyCalSettings(forward_from=args.forward_from or "swing"), npose_orientations=static,
    )
    return calibration, [(npose[0], tpose[1])]


def _functional(args, table, session, mags, mapping):
    """The functional calibration and its windows: given, from the session's markers, or the
    first still second and the rest of the recording."""
    import numpy as np

    from mimucap.cli.session_input import functional_windows_from_markers
    from mimucap.core import functional_bodycal as fb

    still = parse_window(args.still, "--still") if args.still else None
    movement = parse_window(args.movement, "--movement") if args.movement else None
    end = float(table.t_s[-1])
    if still is None and movement is None and session is not None:
        found = functional_windows_from_markers(session.markers, end)
        if found is not None:
            still, movement = found
            print(f"  windows from the session's markers: standing still {still[0]:.2f}-{still[1]:.2f} s (N-pose), "
                  f"movement {movement[0]:.2f}-{movement[1]:.2f} s (walk)")
    if still is None:
        used = {sensor: table.q_world_from_sensor[sensor] for sensor in dict.fromkeys(mapping.values())}
        if movement is not None:  # look for it outside the movement
            outside = (table.t_s < movement[0]) | (table.t_s > movement[1])
            used = {sensor: np.where(outside[:, None], q, np.nan) for sensor, q in used.items()}
        still = fb.first_still_window(table.t_s, used)
        print(f"  standing still: {still[0]:.2f}-{still[1]:.2f} s, the first second in which every sensor was still")
    if movement is None:
        if end - still[1] < 1.0:
            raise ValueError(f"nothing follows the still window {still[0]:g}:{still[1]:g} s: give --movement T2:T3")
        movement = (float(table.t_s[np.searchsorted(table.t_s, still[1], side="right")]), end)
        print(f"  movement: {movement[0]:.2f}-{movement[1]:.2f} s, the rest of the recording")
    static = {} if _tracks_own_headings(args, session) else static_npose_orientations(
        session, mags.magnetometer, mapping, still, table, "quiet-standing")
    calibration = fb.calibrate_functional(
        table.t_s, table.q_world_from_sensor, mapping, still, movement, up_world=table.up_world,
        settings=fb.FunctionalSettings(hinge_from=args.hinge_from or "orientations"), still_orientations=static)
    return calibration, [still, movement]


def _print_summary(args, calibration) -> None:
    quality = calibration.quality
    print(f"body calibration ({quality.method}) of {args.input}: verdict {quality.verdict}")
    for problem in quality.problems:
        print(f"  - {problem}")
    for arm in quality.arms:
        print(f"  {arm.side} arm {arm.sensor}: rose {arm.raise_angle_deg:.1f}° (turned "
              f"{arm.rotation_angle_deg:.1f}°), rotation axis tilt {arm.axis_tilt_deg:.1f}°, "
              f"raise plane residual {arm.swing_residual_deg:.1f}°, rotation-axis vs swing "
              f"heading {arm.axis_vs_swing_deg:.1f}°")
    if quality.left_right_disagreement_deg is not None:
        print(f"  left/right axis disagreement {quality.left_right_disagreement_deg:.1f}°")
    if quality.heading_axis_tilt_deg is not None:
        print(f"  heading axis tilt {quality.heading_axis_tilt_deg:.1f}°")
    axes = getattr(quality, "axes", ())
    if axes:
        print("  how well the movement defined each axis:")
        for axis in axes:
            print(f"    {axis.words}")
    for hinge in getattr(quality, "hinges", ()):
        state = "used" if hinge.used else f"not used: {hinge.note}"
        print(f"  {hinge.joint} axis ({hinge.proximal_sensor}, {hinge.distal_sensor}): flexion "
              f"{hinge.flexion_low_deg:.0f} to {hinge.flexion_high_deg:.0f}°, sensors' axes {hinge.residual_deg:.1f}° "
              f"RMS apart, halves {hinge.halves_deg:.1f}° apart, tilt {hinge.tilt_deg:.0f}°, "
              + ("headings taken as they are (a segment hardly swung)" if hinge.heading_offset_deg is None else
                 f"headings {hinge.heading_offset_deg:+.1f}° apart") + f"; {state}")
    for forward in getattr(quality, "forwards", ()):
        print(f"  {forward.segment} ({forward.sensor}) faces the walking direction: spread {forward.spread_deg:.1f}°")
    for kind, angle in getattr(quality, "left_right_deg", {}).items():
        print(f"  left and right {kind} axes {angle:.1f}° apart when standing")
    worst = max(quality.stillness, key=lambda s: s.max_deviation_deg)
    print(f"  stillness: worst {worst.sensor} in the {worst.pose}, {worst.max_deviation_deg:.2f}°")
    print(f"  {len(calibration.sensors)} segments calibrated, written to {args.out}")
