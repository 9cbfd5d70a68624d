"""``mimucap gait``: gait events, strides and parameters of a session or of a CSV of foot IMUs.

``mimucap gait INPUT --out DIR [--calibration CAL.json] [--live] [--temporal-only] [--rate HZ]
[--gyr-unit deg/s|rad/s]``

INPUT is a MimuCap session (``.h5``: foot sensors where the fifteen-segment suit has them,
shank sensors otherwise; processed as the review does, with its stored body calibration or the
one of ``--calibration``; reprocessed unless ``--live``) or a CSV of foot-worn IMUs in the
gaitmap layout (first column sample numbers; two header rows: sensor ``left_sensor`` /
``right_sensor``, channel ``acc_x`` … ``gyr_z``; ``--rate`` the sample rate, ``--gyr-unit`` the
gyroscope unit, default deg/s). The sensors' sagittal axes are found in their own samples
(:func:`mimucap.core.analysis.sagittal.axes_from_data`), so a sensor mounted in any
orientation is analysed alike. Writes ``DIR/strides.csv``
(``foot, ic_s, fc_s, next_ic_s, stride_time_s, stride_length_m, straight, heading_change_deg,
analysed, refused_because``), ``DIR/parameters.csv`` (``parameter, unit, side, n, mean, sd,
cv_percent``) and ``DIR/bouts_turns.csv``; for a session also the gait-cycle curves and ROM
tables. Every table begins with ``#`` lines saying what it holds (result, calibrations,
software, source file).

Turns, stride length, gait speed and the joint-angle curves of a session need a body
calibration: a session without one is refused (status 1) with a message naming
``--calibration``, unless ``--temporal-only`` asks for the temporal parameters alone (labelled
so in every table).
"""

from __future__ import annotations

import argparse
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "gait", help="gait events, strides and parameters of a session or a foot-IMU CSV",
        description="Detect initial and final contacts, strides, turns and gait parameters; write CSV tables.",
    )
    parser.add_argument("input", type=Path, help="session (.h5) or foot IMU CSV (gaitmap layout)")
    parser.add_argument("--out", type=Path, required=True, help="output folder (created if missing)")
    parser.add_argument("--rate", type=float, help="CSV input: sample rate in Hz")
    parser.add_argument("--gyr-unit", choices=("deg/s", "rad/s"), default="deg/s",
                        help="CSV input: gyroscope unit (default deg/s)")
    parser.add_argument("--calibration", type=Path, metavar="CAL.json",
                        help="session: body calibration to apply (default: the one stored with the session)")
    parser.add_argument("--live", action="store_true",
                        help="session: the forward filter as the live view ran it (default: reprocessed)")
    parser.add_argument("--temporal-only", action="store_true",
                        help="session without a body calibration: the temporal parameters alone")
    parser.set_defaults(func=run)


def session_review(session: Path, calibration: Path | None, live: bool, allow_uncalibrated: bool, what: str):
    """The review of ``session`` (reprocessed, or as seen live) with its stored body calibration
    or ``calibration``; ``ValueError`` naming ``--calibration`` when it has none and
    ``allow_uncalibrated`` is False (``what`` names what needs it)."""
    from mimucap.core.pipeline import RESULT_LIVE, RESULT_REPROCESSED
    from mimucap.session.review import load_review, require_body_calibration

    if calibration is not None and not calibration.is_file():
        raise OSError(f"{calibration}: no such file")
    review = load_review(session, result=RESULT_LIVE if live else RESULT_REPROCESSED, calibration_file=calibration)
    if not allow_uncalibrated:
        require_body_calibration(review, what)
    return review


def _is_csv(path: Path) -> bool:
    with open(path, "rb") as handle:
        head = handle.read(8)
    return not head.startswith(b"\x89HDF") and path.suffix.lower() in (".csv", ".txt")


def run(args: argparse.Namespace) -> int:
    from mimucap.core.analysis.gait import GaitInput, analyse_gait
    from mimucap.core.analysis.sagittal import axes_from_data
    from mimucap.io.gait_csv import read_foot_imu_csv
    from mimucap.session.analysis import analyse_review, write_analysis_csv, write_gait_csv

    source: Path = args.input
    if not source.is_file():
        raise OSError(f"{source}: no such file")
    out: Path = args.out
    if out.exists() and not out.is_dir():
        raise OSError(f"{out}: exists and is not a folder")
    if _is_csv(source):
        if args.rate is None:
            raise ValueError(f"{source}: a CSV input needs its sample rate (--rate HZ)")
        for given, option in ((args.calibration, "--calibration"), (args.live, "--live"),
                              (args.temporal_only, "--temporal-only")):
            if given:
                raise ValueError(f"{option} applies to a session (a foot IMU CSV has no filter or body calibration)")
        feet = read_foot_imu_csv(source, args.rate, args.gyr_unit)
        inputs = [GaitInput.from_axes(side, "foot", f"{side}_sensor", imu.t_s, imu.acc, imu.gyr,
                                      axes_from_data(imu.acc, imu.gyr, args.rate))
                  for side, imu in feet.items()]
        gait = analyse_gait(inputs)
        out.mkdir(parents=True, exist_ok=True)
        notes = [f"Source file: {source.name}; foot IMUs in the gaitmap layout (axes given by the layout, "
                 f"{args.rate:g} Hz, gyroscope in {args.gyr_unit}); no orientation filter or body calibration"]
        written = write_gait_csv(out, gait, notes)
    else:
        if args.rate is not None:
            raise ValueError("--rate applies to CSV input only (a session carries its time stamps)")
        from mimucap.cli.session_input import warn_about_magnetometers

        review = session_review(source, args.calibration, args.live, args.temporal_only, "the gait analysis")
        warn_about_magnetometers("gait", review.session, review.calibrations)
        analysis = analyse_review(review)
        if analysis.gait is None:
            raise ValueError(f"{source}: no gait analysis: {analysis.gait_problem}")
        gait = analysis.gait
        written = write_analysis_csv(out, analysis)
        if analysis.limits:
            print(f"{source.name}: {analysis.limits}")
    analysed = gait.analysed
    refused = len(gait.strides) - len(analysed)
    cadence = gait.parameters.get("cadence", "both")
    speed = gait.parameters.get("gait_speed", "both")
    summary = f"{len(analysed)} strides analysed, {refused} refused, {len(gait.turns)} turn(s)"
    if analysed:
        summary += f"; cadence {cadence.mean:.1f} steps/min"
        if speed.n:
            summary += f", gait speed {speed.mean:.2f} m/s"
    else:
        summary += ": no straight-walking stride found"
    print(summary)
    for path in written:
        print(f"wrote {path}")
    return 0
