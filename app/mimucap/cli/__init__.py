"""The ``mimucap`` command: the GUI by default, sub-commands for batch work.

Each sub-command lives in its own module of this package and exposes
``register(subparsers)``, which adds its parser and sets ``func`` to a callable taking the
parsed ``argparse.Namespace`` and returning an exit code. Errors a user can act on
(``ValueError``, ``OSError``) are printed as one line with a non-zero exit code.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from mimucap import __version__

#: Sub-command modules, in the order ``--help`` lists them.
COMMAND_MODULES: tuple[str, ...] = ("gui", "magcal", "bodycal", "angles", "emulate", "pair", "record", "recover", "fuse",
                                     "bench", "simulate", "export", "import_", "library", "gait", "report", "protocol",
                                     "stream")

EXIT_USAGE = 2


def refuse_to_overwrite_input(out, *inputs) -> None:
    """``ValueError`` when the output path ``out`` is one of the ``inputs`` (the same file by
    another name too): writing the result would destroy what it was computed from."""
    target = Path(out).expanduser().resolve()
    for item in inputs:
        if item is not None and Path(item).expanduser().resolve() == target:
            raise ValueError(f"{out}: the output would overwrite the input {item}; choose another --out")


def check_output_path(out) -> Path:
    """``OSError`` unless a file can be created at ``out``: its folder must exist (and be a
    folder) and ``out`` must not be a folder. Commands call this before their computation, so
    a mistyped ``--out`` costs nothing."""
    target = Path(out).expanduser()
    folder = target.parent
    if target.is_dir():
        raise OSError(f"cannot write {out}: it is a folder; give a file name")
    if folder.exists() and not folder.is_dir():
        raise OSError(f"cannot write {out}: {folder} is a file, not a folder")
    if not folder.is_dir():
        raise OSError(f"cannot write {out}: folder {folder} does not exist")
    return target


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command registered."""
    parser = argparse.ArgumentParser(
        prog="mimucap",
        description=(
            "MimuCap: motion capture with magnetic-inertial sensors. "
            "Without a sub-command the desktop application starts."
        ),
    )
    parser.add_argument("--version", action="version", version=f"mimucap {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        module = importlib.import_module(f"mimucap.cli.{name}")
        module.register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``mimucap`` with ``argv`` (default: ``sys.argv[1:]``); return the exit code."""
    args_list = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    if not args_list:
        args_list = ["gui"]
    args = parser.parse_args(args_list)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return EXIT_USAGE
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("mimucap: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of our output went away (e.g. `| head`): not an error of ours
        _quiet_stdout()
        return 0
    except (MemoryError, OSError, ValueError) as error:  # UnicodeError is a ValueError
        print(f"mimucap {args.command}: error: {_in_words(error)}", file=sys.stderr)
        return 1


def _in_words(error: Exception) -> str:
    """One sentence for an error a user can act on, without Python's own exception text."""
    if isinstance(error, MemoryError):
        return ("not enough memory for this request; ask for less (a shorter duration, fewer sensors "
                "or a lower rate)")
    if isinstance(error, OSError):
        from mimucap.io.json_document import describe_os_error

        return describe_os_error(error)
    if isinstance(error, UnicodeError):
        return "an input file is not the text file expected (a binary file given where a CSV or JSON file belongs?)"
    return str(error)

def _quiet_stdout() -> None:
    """Point stdout at /dev/null, so that Python's flush at exit does not report the broken pipe
    again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass
