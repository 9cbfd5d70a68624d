"""``mimucap protocol``: a standard clinical test's result from a session's sensors.

``mimucap protocol tug|10mwt|2mwt|6mwt|chair-stand SESSION.h5 [--calibration CAL.json]
[--result live|reprocessed] [--walkway M] [--mag-calibration FILE] --out RESULT.json``

The session goes through the one processing path (its raw samples, the magnetometer
calibrations of ``--mag-calibration``, the session or the user's store, the orientation
filter, the body calibration of ``--calibration`` or the one the session recorded); the test is
found in the sensors' data (:mod:`mimucap.session.clinical_tests`), never in the phase markers
or a simulator's truth. Markers labelled ``test start`` and ``test stop`` override where the
test starts and stops. A session without a body calibration is refused.

RESULT.json holds the test's keys (tug: ``total_s``, ``sit_to_stand_s``, ``walk_out_s``,
``turn_s``, ``walk_back_s``, ``turn_to_sit_s``; 10mwt: ``speed_m_s``, ``cadence_steps_min``;
2mwt and 6mwt: ``distance_m``, ``speed_m_s``; chair-stand: ``stands``, ``cycle_s``), the
published reference for the subject's age and sex where one exists (``reference``, or
``reference_note`` saying why not), ``details``, the ``calibration`` and ``result`` used, the
``software_version`` and the ``source_file``. Values that cannot be measured are null.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from mimucap.cli import check_output_path, refuse_to_overwrite_input
from mimucap.cli.session_input import add_session_options

TESTS = ("tug", "10mwt", "2mwt", "6mwt", "chair-stand")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "protocol", help="a standard clinical test (TUG, 10-m walk, 2- and 6-min walks, 30-s chair stand) "
                         "from a session's sensors",
        description=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("test", choices=TESTS, help="the test")
    parser.add_argument("session", type=Path, help="session file (.h5)")
    parser.add_argument("--calibration", metavar="CAL.json", help="body calibration from mimucap bodycal "
                        "(default: the one the session recorded)")
    parser.add_argument("--result", choices=("live", "reprocessed"), default="reprocessed",
                        help="as seen live (the forward filter) or reprocessed (smoothed; default)")
    parser.add_argument("--walkway", type=float, metavar="M", help="10mwt: the walkway's length (default 10 m; "
                        "its middle 60 %% is timed)")
    parser.add_argument("--accept-poor", action="store_true", help="use a body calibration whose verdict is poor")
    add_session_options(parser)
    parser.add_argument("--out", type=Path, required=True, metavar="RESULT.json", help="result file to write")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mimucap.cli.session_input import is_session
    from mimucap.core.pipeline import RESULT_LIVE, RESULT_REPROCESSED
    from mimucap.session.clinical_tests import run_clinical_test

    if args.out.suffix.lower() != ".json":
        raise ValueError(f"{args.out}: the result is a JSON file; name it .json")
    check_output_path(args.out)
    refuse_to_overwrite_input(args.out, args.session, args.calibration)
    if not args.session.is_file():
        raise OSError(f"{args.session}: no such file")
    if not is_session(args.session):
        raise ValueError(f"{args.session}: not a MimuCap session")
    if args.walkway is not None and args.test != "10mwt":
        raise ValueError(f"--walkway applies to the 10-metre walk only, not {args.test}")
    if args.calibration is not None:
        _check_verdict(args)
    result = RESULT_LIVE if args.result == "live" else RESULT_REPROCESSED
    found = run_clinical_test(args.session, args.test, calibration_file=args.calibration,
                              mag_files=args.mag_calibration or (), result=result, walkway_m=args.walkway)
    document = found.to_dict()
    args.out.write_text(json.dumps(document, indent=2, allow_nan=False) + "\n", encoding="utf-8")
    shown = ", ".join(f"{key} {_shown(document[key])}" for key in found.values)
    print(f"{found.test}: {shown} ({document['result']}); wrote {args.out}")
    if found.reference is None:
        print(f"  no reference: {found.reference_note}")
    if args.calibration is None and not args.mag_calibration:
        # A result of the session as stored is the one the library's trend follows (a result
        # computed with other calibrations given here is the user's own, kept in the file only).
        from mimucap.session.clinical_test_results import store_in_library

        stored = store_in_library(args.session, found)
        if stored:
            print(f"  {stored}")
    return 0


def _check_verdict(args: argparse.Namespace) -> None:
    """A body calibration file whose verdict is poor is refused unless ``--accept-poor``."""
    from mimucap.io.body_calibration_file import read_body_calibration

    calibration, _document = read_body_calibration(args.calibration)
    if calibration.quality.verdict == "poor" and not args.accept_poor:
        problems = "; ".join(calibration.quality.problems) or "see the calibration file"
        raise ValueError(f"{args.calibration}: the calibration's verdict is poor ({problems}); redo it, "
                         "or pass --accept-poor to use it anyway")


def _shown(value) -> str:
    if value is None:
        return "not measurable"
    return f"{value:g}" if float(value).is_integer() else f"{value:.3f}"
