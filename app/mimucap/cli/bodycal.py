"""``mimucap bodycal``: body calibration of a recording, written as CAL.json.

``mimucap bodycal INPUT [--mapping SENSOR=SEGMENT[,...]] [--npose T0:T1] [--tpose T2:T3]
[--heading-from SENSOR:AXIS] [--mag-calibration FILE] [--accept-poor] --out CAL.json [--json]``

INPUT is a MimuCap session or any orientation table
:func:`mimucap.io.quaternion_tables.read_quaternion_table` reads (quaternion CSV, OpenSim
``.sto``, Xsens export file or folder, APDM CSV). A session's raw samples go through the
processing path (its magnetometer calibrations, or the stored ones, or ``--mag-calibration``;
the orientation filter, reprocessed), and its N-pose and T-pose markers give the windows when
``--npose``/``--tpose`` are not given. With ``--tpose`` the N/T-pose calibration runs
(``--npose`` required); with ``--heading-from pelvis_imu:z`` the forward direction is that
sensor axis (OpenSense's ``base_heading_axis``) in the N-pose window (default: the first
sample). A calibration whose verdict is poor is written but the command exits with status 3,
unless ``--accept-poor``; so is one made while a sensor's magnetometer calibration is not good
(another device's, a local field that no longer fits it, too old: each named with its figures).
``--heading no-magnetometer`` (rooms where no magnetometer can be trusted) runs the filters
without magnetometers and takes the N-pose headings from their tracks; the calibration notes
the mode, and ``mimucap angles`` applies it with the same mode.
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
    from mimucap.io.quaternion_tables import orientation_input_kind

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
    poses by :func:`judged_on_the_poses` once the windows are known)."""
    from mimucap.io.quaternion_tables import read_quaternion_table
    from mimucap.session.calibrations import AppliedCalibrations

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


def judged_on_the_poses(session, mags, npose: tuple[float, float] | None, tpose: tuple[float, float] | None):
    """``mags`` (the calibrations applied) judged on the local field of the pose windows, from
    the N-pose to the end of the T-pose (the whole recording without windows): the body
    calibration takes its headings there, and a disturbance later in the recording is the
    doubtful-data flags' business, not a reason to call the calibration stale."""
    from dataclasses import replace

    from mimucap.session.calibration_readiness import session_standings

    windows = [w for w in (npose, tpose) if w is not None]
    span = None if not windows else (min(w[0] for w in windows), max(w[1] for w in windows))
    return replace(mags, standings=session_standings(session, mags.magnetometer, window_s=span))


def _refuse_up_for_session(args: argparse.Namespace) -> None:
    import numpy as np

    from mimucap.io.quaternion_tables import axis_vector

    if args.up is not None and not np.allclose(axis_vector(args.up), (0.0, 0.0, 1.0)):
        raise ValueError(f"{args.input}: up axis {args.up} cannot apply: MimuCap sessions are z up")


def static_npose_orientations(session, mags, mapping: dict[str, str],
                              npose: tuple[float, float]) -> dict:
    """Sensor → ``q_world_from_sensor`` (4,) of the N-pose window from its mean accelerometer and
    calibrated magnetometer samples (:func:`mimucap.core.bodycal.static_alignment`, the filter's
    world frame and declination), for the mapped sensors fused with a magnetometer calibration
    (what their filters converge to, whatever transient the filter's estimate still carries);
    the others keep their orientation tracks. ``mags``: sensor → the magnetometer calibration
    the processing path applied (``magnetometer`` of :func:`read_input`'s calibrations)."""
    import numpy as np

    from mimucap.core import bodycal
    from mimucap.session.processing import recorded_processing

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
        print(f"  N-pose orientations from the still sensors' accelerometer and calibrated magnetometer: "
              f"{', '.join(sorted(found))}")
    return found


def pose_doubts(table, mapping: dict[str, str], npose: tuple[float, float] | None,
                tpose: tuple[float, float] | None) -> dict[str, str]:
    """Mapped sensor → why its orientation was doubtful (words) somewhere from the N-pose's start
    to the T-pose's end (the N-pose alone without a T-pose), for the sensors the processing path
    doubted there (:attr:`~mimucap.io.quaternion_tables.QuaternionTable.doubt`)."""
    import numpy as np

    from mimucap.core.doubt import describe

    if npose is None or not table.doubt:
        return {}
    end = (tpose or npose)[1]
    inside = (table.t_s >= npose[0]) & (table.t_s <= end)
    found = {}
    for sensor in mapping.values():
        reasons = int(np.bitwise_or.reduce(table.doubt[sensor][inside])) if sensor in table.doubt and np.any(inside) else 0
        if reasons:
            found[sensor] = describe(reasons)
    return found


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "bodycal",
        help="body calibration (N/T-pose or heading axis) of an orientation recording",
        description=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--mapping", action="append", metavar="SENSOR=SEGMENT[,...]",
                        help="sensor of each segment (repeatable; default: the session's assignment)")
    parser.add_argument("--npose", metavar="T0:T1", help="N-pose window in seconds")
    parser.add_argument("--tpose", metavar="T2:T3", help="T-pose window in seconds (N/T-pose calibration)")
    parser.add_argument("--heading-from", metavar="SENSOR:AXIS",
                        help="sensor axis pointing forward in the N-pose, e.g. pelvis_imu:z or S1:-x")
    parser.add_argument("--arms", choices=("auto", "left", "right", "both"), default="auto",
                        help="arms raised in the T-pose (default: every arm sensor that turned)")
    parser.add_argument("--forward-from", choices=("swing", "rotation_axis"), default="swing",
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
    from mimucap.core.heading_modes import MODE_NO_MAGNETOMETER
    from mimucap.io.body_calibration_file import write_body_calibration
    from mimucap.io.quaternion_tables import axis_vector

    check_output_path(args.out)
    refuse_to_overwrite_input(args.out, args.input)
    table, session, mags = read_input(args)
    mapping = parse_mapping(args.mapping)
    if not mapping:
        if not table.segment_hints:
            raise ValueError("--mapping SENSOR=SEGMENT[,...] is required (the input names no segments)")
        from mimucap.core.pipeline import one_sensor_per_segment

        mapping = {segment: sensor for sensor, segment in one_sensor_per_segment(table.segment_hints).items()}
    model = choose_model(args.model, mapping)
    mapping = bodycal.check_mapping(mapping, table.sensor_ids, model.segment_names)
    npose = parse_window(args.npose, "--npose") if args.npose else None
    tpose = parse_window(args.tpose, "--tpose") if args.tpose else None
    if args.tpose and args.heading_from:
        raise ValueError("give either --tpose (N/T-pose calibration) or --heading-from, not both")
    if session is not None and npose is None and tpose is None and not args.heading_from:
        npose, tpose = pose_windows_from_markers(session.markers, float(table.t_s[-1]))
        print(f"  pose windows from the session's markers: N-pose {npose[0]:.2f}-{npose[1]:.2f} s, "
              f"T-pose {tpose[0]:.2f}-{tpose[1]:.2f} s")
    if session is not None:
        mags = judged_on_the_poses(session, mags, npose, tpose)
        for line in mags.lines():
            print(f"  {line}")
        warn_about_magnetometers("bodycal", session, mags)
    if tpose is not None:
        if npose is None:
            raise ValueError("--tpose needs --npose T0:T1 as well")
        # without magnetometers the N-pose headings are the tracks' own (each filter's arbitrary
        # start, the same the angles are computed with)
        static = ({} if session is None or args.heading == MODE_NO_MAGNETOMETER
                  else static_npose_orientations(session, mags.magnetometer, mapping, npose))
        calibration = bodycal.calibrate_npose_tpose(
            table.t_s, table.q_world_from_sensor, mapping, npose, tpose,
            up_world=table.up_world, arms=args.arms,
            settings=bodycal.BodyCalSettings(forward_from=args.forward_from), npose_orientations=static,
        )
    elif args.heading_from:
        sensor, sep, axis = args.heading_from.rpartition(":")
        if not sep or not sensor:
            raise ValueError(f"--heading-from {args.heading_from!r}: expected SENSOR:AXIS (e.g. pelvis_imu:z)")
        if sensor not in table.q_world_from_sensor and sensor in mapping:
            sensor = mapping[sensor]
        calibration = bodycal.calibrate_heading(
            table.t_s, table.q_world_from_sensor, mapping, sensor, axis_vector(axis),
            npose_s=npose, up_world=table.up_world,
        )
    else:
        raise ValueError("give --tpose T2:T3 (N/T-pose calibration) or --heading-from SENSOR:AXIS")
    from mimucap.session.calibrations import with_magnetometers

    calibration = bodycal.with_doubtful_sensors(calibration, pose_doubts(table, mapping, npose, tpose))
    # the magnetometer calibrations its N-pose orientations were computed with go with it
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
        worst = max(quality.stillness, key=lambda s: s.max_deviation_deg)
        print(f"  stillness: worst {worst.sensor} in the {worst.pose}, {worst.max_deviation_deg:.2f}°")
        print(f"  {len(calibration.sensors)} segments calibrated, written to {args.out}")
    if calibration.quality.verdict == "poor" and not args.accept_poor:
        print(f"mimucap bodycal: the calibration's verdict is poor ({'; '.join(calibration.quality.problems)}): "
              "redo the poses, or pass --accept-poor to use it anyway", file=sys.stderr)
        return EXIT_POOR
    poor_magnetometers = [sid for sid in mags.not_good() if sid in mapping.values()]
    if poor_magnetometers and not args.accept_poor:
        print(f"mimucap bodycal: the magnetometer calibration of {', '.join(poor_magnetometers)} is not good (see "
              "above): the N-pose headings it gives are not to be trusted; calibrate the magnetometers again, or "
              "pass --accept-poor to use the calibration anyway", file=sys.stderr)
        return EXIT_POOR
    return 0
