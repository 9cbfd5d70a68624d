"""``mimucap angles``: joint angles of a recording with a body calibration.

``mimucap angles INPUT --calibration CAL.json [--live] [--shoulder zxy|xzy|yxy]
[--mag-calibration FILE] [--accept-poor] --out OUT.{csv,mot}``

INPUT is a MimuCap session or any orientation table ``mimucap bodycal`` reads. It goes through
the one processing path (a session's raw samples: magnetometer calibration, orientation
filter; then the body calibration ``q_world_from_segment = q_world_from_sensor ⊗
q_sensor_from_segment`` at the reference sensor's instants, and the joint angles of every joint
whose two segments have sensors; conventions: ISB Z-X'-Y'', left mirrored, zero in the
calibrated N-pose). A session is reprocessed (filter smoothed with past and future data) unless
``--live`` asks for the forward filter as the live view ran it. A calibration whose verdict is
poor is refused unless ``--accept-poor``. ``--heading`` chooses where the sensors' headings
come from (default: the calibration's mode, else the recording's setting: relative headings
from the field the body shares and the knees' axes). Each joint's ``<joint>_ok`` column says where its
angles are trustworthy (1) or doubtful (0); the header lists the doubtful spans and why.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mimucap.cli import check_output_path, refuse_to_overwrite_input
from mimucap.cli.bodycal import add_heading_option, add_reader_options, choose_model, read_input
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
    parser.add_argument("--live", action="store_true",
                        help="a session's forward filter as the live view ran it (default: reprocessed)")
    parser.add_argument("--accept-poor", action="store_true", help="use a calibration whose verdict is poor")
    add_heading_option(parser)
    add_reader_options(parser)
    parser.add_argument("--out", required=True, metavar="OUT.{csv,mot}", help="joint-angle file to write")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from mimucap.core.heading_modes import MODE_COUPLED
    from mimucap.core.heading_sources import heading_coupling
    from mimucap.core.pipeline.recording import process_recording
    from mimucap.core.pipeline.settings import RESULT_LIVE, RESULT_REPROCESSED, PipelineSettings
    from mimucap.core.sensor_samples import SensorSamples
    from mimucap.core.skeleton import joint_angle_columns
    from mimucap.io.angles_export import write_angles
    from mimucap.io.body_calibration_file import read_body_calibration
    from mimucap.session.recorded.calibration_choice import AppliedCalibrations
    from mimucap.session.recorded.provenance import heading_lines, provenance

    calibration, document = read_body_calibration(args.calibration)
    if not str(args.out).lower().endswith((".csv", ".mot")):
        raise ValueError(f"{args.out}: joint angles are written as .csv or .mot")
    check_output_path(args.out)
    refuse_to_overwrite_input(args.out, args.input, args.calibration)
    if calibration.quality.verdict == "poor" and not args.accept_poor:
        problems = "; ".join(calibration.quality.problems) or "see the calibration file"
        raise ValueError(f"{args.calibration}: the calibration's verdict is poor ({problems}); redo it, "
                         "or pass --accept-poor to use it anyway")
    try:
        model = choose_model(args.model or document.get("model", "auto"), calibration.sensors)
    except ValueError as error:
        if args.model is not None:
            raise
        raise ValueError(f"{args.calibration}: the calibration's model: {error}") from None
    unknown = [s for s in calibration.sensors if s not in model.segment_names]
    if unknown:
        raise ValueError(f"{args.calibration}: segment(s) {', '.join(unknown)} not in model {model.name}")
    result = RESULT_LIVE if args.live else RESULT_REPROCESSED
    # a calibration made without magnetometers holds with the filters run without them
    args.heading = args.heading or document.get("heading")
    trust = []
    if _is_session(args):
        output, record, markers, trust = _session_output(args, model, calibration, result)
    else:
        if args.live:
            raise ValueError(f"{args.input}: --live applies to MimuCap sessions (an orientation table has no filter to run)")
        table, _session, _mags = read_input(args)
        missing = [sensor for sensor in calibration.sensors.values() if sensor not in table.q_world_from_sensor]
        if missing:
            raise ValueError(f"{args.input}: calibrated sensor(s) {', '.join(missing)} missing from the data; it has: "
                             f"{', '.join(table.q_world_from_sensor)}")
        # each column: a sensor's orientations, as a device fusing on board sends them
        streams = {sid: SensorSamples(sid, table.t_s, np.arange(len(table.t_s)), q_world_from_sensor=q)
                   for sid, q in table.q_world_from_sensor.items()}
        settings = PipelineSettings(heading=args.heading or MODE_COUPLED)
        output = process_recording(streams, model, body_calibration=calibration, shoulder_sequence=args.shoulder,
                                   settings=settings, coupling=heading_coupling(settings, RESULT_REPROCESSED))
        markers = ()
        record = provenance(source_file=Path(args.input).name, result="orientations as the input gives them",
                            calibrations=AppliedCalibrations(body=calibration, body_origin=str(args.calibration)),
                            model=model, height_m=None)
    angles = output.angles_deg
    ordered = {c: angles[c] for c in joint_angle_columns(model, args.shoulder) if c in angles}
    if not ordered:
        raise ValueError(
            f"{args.calibration}: no joint has calibrated segments on both sides "
            f"(segments: {', '.join(calibration.sensors)})"
        )
    notes = [f"input: {args.input}", "computed from the sensors"] + record.lines() + trust
    write_angles(args.out, output.t_s, ordered, args.shoulder, notes, markers=markers,
                 joint_doubt=output.joint_doubt)
    joints = [j for j in model.joint_names if any(c.startswith(j + "_") for c in ordered)]
    print(f"{len(output.t_s)} samples, {len(ordered)} angle columns ({', '.join(joints)}) written to {args.out}")
    for line in doubt_summary(output.t_s, output.joint_doubt):
        print(f"  {line}")
    return 0


def doubt_summary(t_s, joint_doubt) -> list[str]:
    """One line per joint whose angles are doubtful somewhere: the share of samples and every
    reason in words."""
    import numpy as np

    from mimucap.core.pipeline.doubt_reasons import describe

    lines = []
    for joint, reasons in joint_doubt.items():
        doubtful = np.asarray(reasons) != 0
        if np.any(doubtful):
            why = describe(int(np.bitwise_or.reduce(np.asarray(reasons)[doubtful])))
            lines.append(f"{joint}: doubtful in {100.0 * np.mean(doubtful):.1f} % of the samples ({why})")
    return lines


def _is_session(args: argparse.Namespace) -> bool:
    from mimucap.cli.session_input import is_session

    return is_session(args.input)


def _session_output(args: argparse.Namespace, model, calibration, result: str):
    """A session's joint angles through the processing path with ``calibration``, what the
    result holds (:func:`mimucap.session.recorded.provenance.provenance`), the session's markers and a
    note on how long the gyroscope bridges a magnetometer."""
    import numpy as np

    from mimucap.cli.bodycal import _refuse_up_for_session, check_reader_options
    from mimucap.cli.session_input import warn_about_magnetometers
    from mimucap.core.pipeline.sensor_doubt import bridge_note
    from mimucap.io.session import read_session
    from mimucap.session.recorded.calibration_choice import applied_calibrations
    from mimucap.session.recorded.reprocessing import process_session
    from mimucap.session.recorded.stored_processing import recorded_processing, session_model
    from mimucap.session.recorded.provenance import heading_lines, provenance

    check_reader_options(args)
    _refuse_up_for_session(args)
    session = read_session(args.input)
    missing = [sensor for sensor in calibration.sensors.values() if sensor not in session.sensors]
    if missing:
        raise ValueError(f"{args.input}: calibrated sensor(s) {', '.join(missing)} missing from the data; it has: "
                         f"{', '.join(session.sensors)}")
    applied = applied_calibrations(session, body=calibration, body_origin=str(args.calibration),
                                   mag_files=args.mag_calibration or (), origin=str(args.input))
    for line in applied.lines() + list(applied.notes):
        print(f"  {line}")
    warn_about_magnetometers("angles", session, applied)
    output = process_session(session, result=result, calibrations=applied, model=model,
                             shoulder_sequence=args.shoulder, heading=args.heading)
    record = provenance(source_file=Path(args.input).name, result=result, calibrations=applied, model=model,
                        height_m=session_model(session)[1], metadata=session.metadata,
                        headings=heading_lines(output.heading_mode, output.heading_source))
    trust = []
    if output.reference_sensor is not None and len(output.t_s) > 1:
        step = float(np.median(np.diff(session.sensors[output.reference_sensor].t_s)))
        fusion = recorded_processing(session, origin=str(args.input)).settings.fusion
        trust.append(f"trust: {bridge_note(fusion, step)}")
    return output, record, session.markers, trust
