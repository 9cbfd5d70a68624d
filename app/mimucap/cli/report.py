"""``mimucap report``: the clinical PDF report of a session, or a before/after comparison.

``mimucap report SESSION.h5 --out REPORT.pdf [--calibration CAL.json] [--live] [--before EARLIER.h5]
[--before-calibration CAL.json] [--bands BANDS.csv] [--notes TEXT] [--csv DIR]``

The session is processed as the review does (reprocessed unless ``--live``), with its stored
body calibration or the one of ``--calibration``; a session without one is refused (a report's
joint angles, ROM and spatial gait parameters need it). The report's first page says what it
holds (result, calibrations, model, software, file); it holds the subject id, date, sensors
and calibration quality, the gait table, the gait-cycle curves of every joint angle (with the
normative band of ``--bands``, format in :mod:`mimucap.io.normative_bands`), the ROM table,
the markers and the notes. ``--before`` makes a comparison report (the earlier session beside
this one, with the differences). ``--csv`` also writes every analysis table as CSV. The PDF is
drawn with Qt on the offscreen platform (no display needed).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mimucap.cli import check_output_path, refuse_to_overwrite_input


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "report", help="clinical PDF report of a session (gait, curves, ROM), or a before/after comparison",
        description="Write a PDF report of a session; with --before, a comparison of two sessions.",
    )
    parser.add_argument("session", type=Path, help="session file (.h5)")
    parser.add_argument("--out", type=Path, required=True, help="output PDF")
    parser.add_argument("--calibration", type=Path, metavar="CAL.json",
                        help="body calibration to apply (default: the one stored with the session)")
    parser.add_argument("--live", action="store_true",
                        help="the forward filter as the live view ran it (default: reprocessed)")
    parser.add_argument("--before", type=Path, help="an earlier session of the same subject to compare with")
    parser.add_argument("--before-calibration", type=Path, metavar="CAL.json",
                        help="body calibration of the --before session (default: the one stored with it)")
    parser.add_argument("--bands", type=Path, help="normative bands of the gait-cycle curves (CSV)")
    parser.add_argument("--notes", default="", help="notes printed in the report")
    parser.add_argument("--csv", type=Path, help="also write the analysis tables as CSV into this folder")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mimucap.cli.gait import session_review
    from mimucap.io.normative_bands import read_normative_bands
    from mimucap.session.analysis import analyse_review, write_analysis_csv

    if args.out.suffix.lower() != ".pdf":
        raise ValueError(f"{args.out}: the report is a PDF; give a .pdf file name")
    if args.before_calibration is not None and args.before is None:
        raise ValueError("--before-calibration applies with --before")
    check_output_path(args.out)
    refuse_to_overwrite_input(args.out, args.session, args.before, args.bands, args.calibration,
                              args.before_calibration)
    for path in (args.session, args.before, args.bands):
        if path is not None and not path.is_file():
            raise OSError(f"{path}: no such file")
    bands = read_normative_bands(args.bands) if args.bands else {}
    from mimucap.cli.session_input import warn_about_magnetometers

    review = session_review(args.session, args.calibration, args.live, False, "a report")
    warn_about_magnetometers("report", review.session, review.calibrations)
    analysis = analyse_review(review)
    before = None
    if args.before:
        earlier = session_review(args.before, args.before_calibration, args.live, False,
                                 "a report (--before-calibration for the earlier session)")
        warn_about_magnetometers("report", earlier.session, earlier.calibrations, str(args.before))
        before = analyse_review(earlier)
    from PyQt5.QtGui import QGuiApplication

    from mimucap.gui.report import write_comparison_report, write_report

    # The PDF needs no screen: Qt's offscreen platform, asked for on the command line of the
    # application object rather than in the environment (which child processes would inherit).
    app = QGuiApplication.instance() or QGuiApplication(["mimucap-report", "-platform", "offscreen"])
    if before is None:
        write_report(args.out, analysis, bands, args.notes)
    else:
        write_comparison_report(args.out, before, analysis, bands, args.notes)
    del app
    print(f"wrote {args.out}")
    if args.csv:
        for path in write_analysis_csv(args.csv, analysis):
            print(f"wrote {path}")
    return 0
