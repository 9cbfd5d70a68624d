"""``mimucap angles``: joint angles of a recording with a body calibration.

``mimucap angles INPUT --calibration CAL.json [--shoulder zxy|xzy|yxy] --out OUT.{csv,mot}``

Every sample of INPUT (any orientation table ``mimucap bodycal`` reads) gives
``q_world_from_segment = q_world_from_sensor ⊗ q_sensor_from_segment`` for the calibrated
segments, and the joint angles of every joint whose two segments have sensors
(conventions: ISB Z-X'-Y'', left mirrored, zero in the calibrated N-pose).
"""

from __future__ import annotations

import argparse

from mimucap.cli import check_output_path, refuse_to_overwrite_input
from mimucap.cli.bodycal import add_reader_options, choose_model, read_input
from mimucap.core.skeleton_models import SHOULDER_SEQUENCES


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "angles",
        help="joint angles of a recording with a body calibration, as CSV or OpenSim .mot",
        description=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--calibration", required=True, metavar="CAL.json", help="from mimucap bodycal")
    parser.add_argument("--shoulder", choices=SHOULDER_SEQUENCES, default="zxy",
                        help="shoulder Euler sequence (default zxy; yxy is ISB's, singular arm down)")
    parser.add_argument("--model", default=None, help="skeleton model (default: the calibration's)")
    add_reader_options(parser)
    parser.add_argument("--out", required=True, metavar="OUT.{csv,mot}", help="joint-angle file to write")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mimucap.core import bodycal
    from mimucap.core.skeleton import joint_angle_columns, joint_angles_deg
    from mimucap.io.angles_export import write_angles
    from mimucap.io.body_calibration_file import read_body_calibration

    calibration, document = read_body_calibration(args.calibration)
    if not str(args.out).lower().endswith((".csv", ".mot")):
        raise ValueError(f"{args.out}: joint angles are written as .csv or .mot")
    check_output_path(args.out)
    refuse_to_overwrite_input(args.out, args.input, args.calibration)
    table = read_input(args)
    try:
        model = choose_model(args.model or document.get("model", "auto"), calibration.sensors)
    except ValueError as error:
        if args.model is not None:
            raise
        raise ValueError(f"{args.calibration}: the calibration's model: {error}") from None
    unknown = [s for s in calibration.sensors if s not in model.segment_names]
    if unknown:
        raise ValueError(f"{args.calibration}: segment(s) {', '.join(unknown)} not in model {model.name}")
    q_world_from_segment = bodycal.segment_orientations(calibration, table.q_world_from_sensor)
    angles = joint_angles_deg(model, q_world_from_segment, args.shoulder)
    if not angles:
        raise ValueError(
            f"{args.calibration}: no joint has calibrated segments on both sides "
            f"(segments: {', '.join(calibration.sensors)})"
        )
    ordered = {c: angles[c] for c in joint_angle_columns(model, args.shoulder) if c in angles}
    notes = [
        f"input: {args.input}",
        f"calibration: {args.calibration} (method {calibration.quality.method}, verdict {calibration.quality.verdict})",
        f"model: {model.name}",
    ]
    write_angles(args.out, table.t_s, ordered, args.shoulder, notes)
    joints = [j for j in model.joint_names if any(c.startswith(j + "_") for c in ordered)]
    print(f"{len(table.t_s)} samples, {len(ordered)} angle columns ({', '.join(joints)}) written to {args.out}")
    return 0
