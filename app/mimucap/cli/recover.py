"""``mimucap recover FILE``: rebuild a session from the journal of an interrupted recording.

FILE is the session path (``SESSION.h5``) or its journal (``SESSION.h5.journal``). Every
intact record is kept; a torn tail (the last, unflushed moment before a crash) is dropped.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def register(subparsers) -> None:
    parser = subparsers.add_parser("recover", help="rebuild a session after a crash",
                                   description=__doc__.split("\n\n")[0].replace("``", ""))
    parser.add_argument("file", type=Path, metavar="FILE", help="SESSION.h5 or SESSION.h5.journal")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mimucap.session.live.recorder import recover

    result = recover(args.file)
    print(f"recovered {result.session_path}: {sum(result.samples.values())} samples from "
          f"{len(result.samples)} sensors")
    for name, count in result.samples.items():
        print(f"  {name}: {count}")
    if result.message:
        print(result.message)
    return 0
