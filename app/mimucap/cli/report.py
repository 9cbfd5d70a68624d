"""``mimucap report``: the clinical PDF report of a session, or a before/after comparison.

``mimucap report SESSION.h5 --out REPORT.pdf [--before EARLIER.h5] [--bands BANDS.csv]
[--notes TEXT] [--csv DIR]``

The session is processed as the review does; the report holds the subject id, date, sensors
and calibration quality, the gait table, the gait-cycle curves of every joint angle (with the
normative band of ``--bands``, format in :mod:`mimucap.io.normative_bands`), the ROM table,
the markers and the notes. ``--before`` makes a comparison report (the earlier session beside
this one, with the differences). ``--csv`` also writes every analysis table as CSV. The PDF is
drawn with Qt on the offscreen platform (no display needed).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from mimucap.cli import check_output_path, refuse_to_overwrite_input


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "report", help="clinical PDF report of a session (gait, curves, ROM), or a before/after comparison",
        description="Write a PDF report of a session; with --before, a comparison of two sessions.",
    )
    parser.add_argument("session", type=Path, help="session file (.h5)")
    parser.add_argument("--out", type=Path, required=True, help="output PDF")
    parser.add_argument("--before", type=Path, help="an earlier session of the same subject to compare with")
    parser.add_argument("--bands", type=Path, help="normative bands of the gait-cycle curves (CSV)")
    parser.add_argument("--notes", default="", help="notes printed in the report")
    parser.add_argument("--csv", type=Path, help="also write the analysis tables as CSV into this folder")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mimucap.io.normative_bands import read_normative_bands
    from mimucap.session.analysis import analyse_review, write_analysis_csv
    from mimucap.session.review import load_review

    if args.out.suffix.lower() != ".pdf":
        raise ValueError(f"{args.out}: the report is a PDF; give a .pdf file name")
    check_output_path(args.out)
    refuse_to_overwrite_input(args.out, args.session, args.before, args.bands)
    for path in (args.session, args.before, args.bands):
        if path is not None and not path.is_file():
            raise OSError(f"{path}: no such file")
    bands = read_normative_bands(args.bands) if args.bands else {}
    from mimucap.cli.session_input import warn_about_recorded_magnetometers

    review = load_review(args.session)
    warn_about_recorded_magnetometers("report", review.session)
    analysis = analyse_review(review)
    before = None
    if args.before:
        earlier = load_review(args.before)
        warn_about_recorded_magnetometers("report", earlier.session, str(args.before))
        before = analyse_review(earlier)
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from PyQt5.QtGui import QGuiApplication

    from mimucap.gui.report import write_comparison_report, write_report

    app = QGuiApplication.instance() or QGuiApplication(["mimucap-report"])
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
