"""``mimucap export``: a session's motion in the file formats other programs open.

``mimucap export SESSION.h5 [--calibration CAL.json] [--format c3d|bvh|sto|mot|csv] --out FILE
[--from S] [--to S] [--opensim-names] [--raw-sensors]``

The motion is the pipeline's result for the session (segment orientations and joint angles, as
the review shows them), computed with the session's stored calibrations, or with the body
calibration of ``--calibration`` and the magnetometer calibrations it was made with
(:func:`mimucap.session.recorded.calibration_choice.applied_calibrations`). The format follows ``--format``,
else the suffix of ``--out``:

* ``c3d``: joint angles (``LKneeAngles``… X/Y/Z = flexion/adduction/rotation, degrees), segment
  orientations, joint centres, the markers as events (Visual3D, Mokka, Vicon Nexus, OpenSim);
* ``bvh``: the skeleton's hierarchy and motion (Blender, MotionBuilder, game engines);
* ``sto``: an OpenSense orientation table, one virtual IMU per segment (``--raw-sensors``: the
  sensors' own orientations) for OpenSim's IMUPlacer and IMUInverseKinematicsTool, and beside
  it ``<name>_calibration.sto``, the body calibration's N-pose for IMUPlacer;
* ``mot``: joint angles as an OpenSim motion (``--opensim-names``: as OpenSim coordinates);
* ``csv``: joint angles with a header naming sequences, signs and units.

``--from``/``--to`` (seconds) keep a part of the recording. The markers go into every format that
has a place for them: C3D events, ``.mot``/``.csv``/``.sto`` header lines; BVH has none, so they
are listed in a ``<name>_markers.csv`` file beside it. Every file says what it holds (result,
calibrations, model, software, source file: :mod:`mimucap.session.recorded.provenance`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mimucap.cli import check_output_path, refuse_to_overwrite_input
from mimucap.core.wording import plural
from mimucap.cli.bodycal import add_heading_option

FORMATS = ("c3d", "bvh", "sto", "mot", "csv")


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "export",
        help="a session's motion as C3D, BVH, OpenSense .sto, OpenSim .mot or CSV",
        description=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("session", metavar="SESSION.h5", help="a MimuCap session file")
    parser.add_argument("--calibration", metavar="CAL.json", default=None,
                        help="body calibration to apply (default: the one stored with the session)")
    parser.add_argument("--format", choices=FORMATS, default=None, help="file format (default: from --out's suffix)")
    parser.add_argument("--out", required=True, metavar="FILE", help="file to write")
    parser.add_argument("--from", dest="t_from", type=float, default=None, metavar="S", help="start (s)")
    parser.add_argument("--to", dest="t_to", type=float, default=None, metavar="S", help="end (s)")
    parser.add_argument("--opensim-names", action="store_true",
                        help="mot: name the columns as OpenSim coordinates (hip_flexion_r, knee_angle_r…)")
    add_heading_option(parser)
    parser.add_argument("--raw-sensors", action="store_true",
                        help="sto: the sensors' own orientations instead of segment-aligned virtual sensors")
    parser.set_defaults(func=run)


def choose_format(out: str, given: str | None) -> str:
    """The export format: ``given``, else the suffix of ``out``; ``ValueError`` otherwise."""
    if given is not None:
        return given
    suffix = Path(out).suffix.lower().lstrip(".")
    if suffix not in FORMATS:
        raise ValueError(f"{out}: cannot tell the format from the suffix; give --format {'|'.join(FORMATS)}")
    return suffix


def run(args: argparse.Namespace) -> int:
    fmt = choose_format(args.out, args.format)
    if args.opensim_names and fmt != "mot":
        raise ValueError("--opensim-names applies to --format mot")
    if args.raw_sensors and fmt != "sto":
        raise ValueError("--raw-sensors applies to --format sto")
    check_output_path(args.out)
    refuse_to_overwrite_input(args.out, args.session, args.calibration)
    from mimucap.session.recorded.export import write_motion_file
    from mimucap.session.recorded.review import load_review

    from mimucap.cli.session_input import warn_about_magnetometers

    data = load_review(args.session, calibration_file=args.calibration, heading=args.heading)
    if not (fmt == "sto" and args.raw_sensors):  # the sensors' own orientations need no body calibration
        from mimucap.session.recorded.review import require_body_calibration

        require_body_calibration(data, f"a {fmt} export of joint angles or segments")
    warn_about_magnetometers("export", data.session, data.calibrations)
    written = write_motion_file(data, fmt, Path(args.out), args.t_from, args.t_to, opensim_names=args.opensim_names,
                                raw_sensors=args.raw_sensors)
    print(f"{data.path.name} ({data.pose_source}): {plural(len(written), 'file')} written: "
          + ", ".join(str(p) for p in written))
    return 0
