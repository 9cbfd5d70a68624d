"""``mimucap library``: the library of recordings from the command line.

    mimucap library list [--library DIR]
    mimucap library show SUBJECT [--library DIR]
    mimucap library rebuild [--library DIR]
    mimucap library export-csv --out FILE.csv [--library DIR]

``--library`` defaults to the configured folder: the ``MIMUCAP_LIBRARY`` environment variable,
else the folder chosen in the application (``$XDG_CONFIG_HOME/mimucap/library.json``), else
``~/Documents/MimuCap Library``. ``list``, ``show`` and ``export-csv`` rescan the folder first,
so files copied in by hand are listed; ``rebuild`` makes the index again from the files alone.
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path
from typing import TYPE_CHECKING

from mimucap.cli import check_output_path

if TYPE_CHECKING:  # the library (numpy, h5py) is loaded when a command runs
    from mimucap.io.library import Library, SessionEntry

#: Columns of ``export-csv``, one row per session file.
CSV_COLUMNS = ("subject", "date", "recorded_utc", "condition", "tags", "trial", "file", "duration_s", "sensors",
               "verdicts", "markers", "status", "problem")


def register(subparsers) -> None:
    parser = subparsers.add_parser("library", help="list, show, rebuild or export the library of recordings",
                                   description=__doc__.split("\n\n")[0].replace("``", ""))
    commands = parser.add_subparsers(dest="library_command", metavar="ACTION", required=True)

    def action(name: str, help_text: str) -> argparse.ArgumentParser:
        sub = commands.add_parser(name, help=help_text, description=help_text)
        sub.add_argument("--library", type=Path, metavar="DIR",
                         help="library folder (default: MIMUCAP_LIBRARY, else the folder chosen in the application)")
        return sub

    action("list", "every session of the library, one line each").set_defaults(func=run_list)
    show = action("show", "a subject's record and sessions in detail")
    show.add_argument("subject", metavar="SUBJECT", help="subject id")
    show.set_defaults(func=run_show)
    action("rebuild", "make the index again from the session files").set_defaults(func=run_rebuild)
    export = action("export-csv", "one CSV row per session (for statistics)")
    export.add_argument("--out", required=True, type=Path, metavar="FILE.csv", help="CSV file to write")
    export.set_defaults(func=run_export)


def _library(args: argparse.Namespace, scan: bool = True) -> Library:
    from mimucap.io.library import Library
    from mimucap.io.library_settings import configured_library_folder

    folder = args.library if args.library is not None else configured_library_folder()
    if not Path(folder).expanduser().is_dir():
        raise OSError(f"library folder {folder} does not exist (give --library DIR, or set MIMUCAP_LIBRARY)")
    library = Library(folder)
    if scan:
        library.scan()
    return library


def _duration(entry: SessionEntry) -> str:
    return "" if entry.duration_s is None else f"{entry.duration_s:.1f}"


def _status(entry: SessionEntry) -> str:
    return "ok" if entry.ok else f"DAMAGED: {entry.problem}"


def run_list(args: argparse.Namespace) -> int:
    library = _library(args)
    sessions = library.sessions()
    print(f"library {library.root}: {len(library.subjects())} subjects, {len(sessions)} sessions"
          + (f" ({sum(not s.ok for s in sessions)} damaged)" if any(not s.ok for s in sessions) else ""))
    header = ("subject", "date", "condition", "tags", "trial", "duration s", "file", "status")
    rows = [(s.subject_id or "?", s.date, s.condition, ",".join(s.tags), s.trial, _duration(s), s.path, _status(s))
            for s in sorted(sessions, key=lambda s: (s.subject_id, s.recorded_utc, s.path))]
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header) - 1)]
    for row in [header, *rows]:
        print("  ".join(str(cell).ljust(width) for cell, width in zip(row, widths)) + "  " + row[-1])
    return 0


def run_show(args: argparse.Namespace) -> int:
    library = _library(args)
    subject = library.subject(args.subject)
    if subject is None:
        known = ", ".join(s.subject_id for s in library.subjects()) or "none"
        raise ValueError(f"no subject {args.subject!r} in the library {library.root} (subjects: {known})")
    height = "" if subject.height_m is None else f"{subject.height_m:.2f} m"
    print(f"subject {subject.subject_id}: height {height or 'unknown'}, dominant side {subject.dominance or 'unknown'}, "
          f"{subject.sessions} session(s)")
    if subject.notes:
        print(f"notes: {subject.notes}")
    for entry in library.sessions(subject.subject_id):
        print()
        print(f"{entry.path}: {_status(entry)}")
        if not entry.ok:
            continue
        print(f"  date {entry.date} ({entry.recorded_utc}), condition {entry.condition or '-'}, "
              f"tags {', '.join(entry.tags) or '-'}, trial {entry.trial or '-'}, {entry.duration_s:.1f} s")
        print(f"  sensors ({len(entry.sensors)}): {entry.sensors_text() or '-'}")
        print(f"  calibrations: {entry.verdicts_text() or 'none'}")
        print(f"  markers: {', '.join(f'{label} at {t:.2f} s' for t, label in entry.markers) or 'none'}")
        results = library.results(entry.path)
        if results:
            print(f"  results: {', '.join(sorted(results))}")
    return 0


def run_rebuild(args: argparse.Namespace) -> int:
    library = _library(args, scan=False)
    report = library.rebuild()
    from mimucap.core.wording import plural

    print(f"rebuilt {library.index_path} from {plural(len(report.added), 'session file')}"
          + (f", {len(report.damaged)} damaged: {', '.join(report.damaged)}" if report.damaged else ""))
    return 0


def export_rows(library: Library) -> list[dict[str, str]]:
    """The ``export-csv`` rows (:data:`CSV_COLUMNS`) of every session, by subject and date."""
    rows = []
    for entry in sorted(library.sessions(), key=lambda s: (s.subject_id, s.recorded_utc, s.path)):
        rows.append({
            "subject": entry.subject_id, "date": entry.date, "recorded_utc": entry.recorded_utc,
            "condition": entry.condition, "tags": ";".join(entry.tags), "trial": entry.trial, "file": entry.path,
            "duration_s": "" if entry.duration_s is None else f"{entry.duration_s:.3f}",
            "sensors": entry.sensors_text(), "verdicts": entry.verdicts_text(),
            "markers": json.dumps([[round(t, 3), label] for t, label in entry.markers], ensure_ascii=False),
            "status": entry.status, "problem": entry.problem})
    return rows


def run_export(args: argparse.Namespace) -> int:
    target = check_output_path(args.out)
    library = _library(args)
    rows = export_rows(library)
    with open(target, "w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=CSV_COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    damaged = sum(row["status"] != "ok" for row in rows)
    print(f"wrote {target}: {len(rows)} session(s)" + (f", {damaged} damaged" if damaged else ""))
    return 0


__all__ = ["register", "CSV_COLUMNS", "export_rows"]
