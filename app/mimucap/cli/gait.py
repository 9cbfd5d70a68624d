"""``mimucap gait``: gait events, strides and parameters of a session or of a CSV of foot IMUs.

``mimucap gait INPUT --out DIR [--rate HZ] [--gyr-unit deg/s|rad/s]``

INPUT is a MimuCap session (``.h5``: foot sensors where the fifteen-segment suit has them,
shank sensors otherwise; processed as the review does) or a CSV of foot-worn IMUs in the
gaitmap layout (first column sample numbers; two header rows: sensor ``left_sensor`` /
``right_sensor``, channel ``acc_x`` … ``gyr_z``; axes x forward, y left, z up; ``--rate`` the
sample rate, ``--gyr-unit`` the gyroscope unit, default deg/s). Writes ``DIR/strides.csv``
(``foot, ic_s, fc_s, next_ic_s, stride_time_s, stride_length_m, straight, heading_change_deg,
analysed, refused_because``), ``DIR/parameters.csv`` (``parameter, unit, side, n, mean, sd,
cv_percent``) and ``DIR/bouts_turns.csv``; for a session also the gait-cycle curves and ROM
tables.
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
    parser.set_defaults(func=run)


def _is_csv(path: Path) -> bool:
    with open(path, "rb") as handle:
        head = handle.read(8)
    return not head.startswith(b"\x89HDF") and path.suffix.lower() in (".csv", ".txt")


def run(args: argparse.Namespace) -> int:
    from mimucap.core.analysis.gait import GaitInput, analyse_gait
    from mimucap.io.gait_csv import read_foot_imu_csv
    from mimucap.session.analysis import analyse_review, write_analysis_csv, write_gait_csv
    from mimucap.session.review import load_review

    source: Path = args.input
    if not source.is_file():
        raise OSError(f"{source}: no such file")
    out: Path = args.out
    if out.exists() and not out.is_dir():
        raise OSError(f"{out}: exists and is not a folder")
    if _is_csv(source):
        if args.rate is None:
            raise ValueError(f"{source}: a CSV input needs its sample rate (--rate HZ)")
        feet = read_foot_imu_csv(source, args.rate, args.gyr_unit)
        inputs = [GaitInput(side, "foot", f"{side}_sensor", imu.t_s, imu.sagittal_rate, imu.acc, imu.gyr)
                  for side, imu in feet.items()]
        gait = analyse_gait(inputs)
        out.mkdir(parents=True, exist_ok=True)
        written = write_gait_csv(out, gait)
    else:
        if args.rate is not None:
            raise ValueError("--rate applies to CSV input only (a session carries its time stamps)")
        from mimucap.cli.session_input import warn_about_recorded_magnetometers

        review = load_review(source)
        warn_about_recorded_magnetometers("gait", review.session)
        analysis = analyse_review(review)
        if analysis.gait is None:
            raise ValueError(f"{source}: no gait analysis: {analysis.gait_problem}")
        gait = analysis.gait
        written = write_analysis_csv(out, analysis)
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
