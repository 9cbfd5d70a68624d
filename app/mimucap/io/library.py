"""The library of recordings: one folder holding every session file, and an SQLite index of it.

The session files are the truth. Everything the index holds about a session is read from its
file (subject record, date, condition, tags, trial, duration, sensors, calibration verdicts,
markers: the metadata keys of ``docs/session-format.md``), so the index can be thrown away and
rebuilt (:meth:`Library.rebuild`), and a file copied into the folder by hand (anywhere below it)
appears at the next :meth:`Library.scan`. Changes made through the library (trial name,
condition, tags) are written into the file first (:func:`mimucap.io.session.update_metadata`),
then into the index. Only analysis results (:meth:`Library.store_result`) live in the index
alone: they are computed from the files and can be computed again.

Layout of a library folder::

    LIBRARY/
      mimucap-library.sqlite      the index (SQLite, Python's own sqlite3)
      P042_2026-11-25_trial01.h5  recordings, <subject>_<date>_<trial>.h5 (subfolders allowed)
      trash/                      files moved out of the library (never scanned, never deleted)

Safety of the index:

* every write is one transaction (``BEGIN IMMEDIATE`` … ``COMMIT``) in SQLite's rollback-journal
  mode with ``synchronous=FULL``: a process killed while writing leaves the index as it was
  after its last commit (SQLite rolls the hot journal back on the next open);
* several processes may use one library: SQLite's file locks serialise the writers, and a
  writer that finds the index locked waits up to :data:`BUSY_TIMEOUT_S` (the rollback journal,
  unlike write-ahead logging, also works on network file systems);
* the index schema version is SQLite's ``PRAGMA user_version``; an index written by a newer
  MimuCap is refused (:class:`LibraryVersionError`) and never changed, not even by a rebuild.

A scan reads what describes each new or changed file (:func:`mimucap.io.session.read_summary`:
attributes, markers, calibrations and each sensor's first and last time stamp), not its samples. A file that cannot be read so is listed with ``status = "damaged"``
and the reason; it never hides the other sessions. Sample values are checked when a file is
opened for review or export.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import sqlite3
from collections.abc import Callable, Iterator, Mapping
from contextlib import closing, contextmanager
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from mimucap import __version__
from mimucap.io.session import (
    SessionFormatError, read_metadata, read_summary, update_metadata,
)

#: The index's file name inside the library folder.
INDEX_NAME = "mimucap-library.sqlite"
#: Folder inside the library that deleted sessions are moved to (never scanned).
TRASH_NAME = "trash"
#: The index schema this module writes (``PRAGMA user_version``); newer indexes are refused.
SCHEMA_VERSION = 1
#: How long a writer waits for another process's transaction to end (s).
BUSY_TIMEOUT_S = 30.0
#: Top-level metadata key of a session file holding its library fields.
METADATA_KEY = "library"
#: Status of a session whose file reads.
STATUS_OK = "ok"
#: Status of a session whose file cannot be read (the reason is in ``problem``).
STATUS_DAMAGED = "damaged"

_NAME_RE = re.compile(r"^[A-Za-z0-9_.-]{1,40}$")
_TAG_RE = re.compile(r"^[^,;\n\r\t]{1,40}$")

_SCHEMA = (
    """CREATE TABLE IF NOT EXISTS sessions (
        path TEXT PRIMARY KEY,          -- relative to the library folder, '/' separated
        subject_id TEXT NOT NULL,
        recorded_utc TEXT NOT NULL,     -- ISO 8601, '' when unknown
        condition TEXT NOT NULL,
        tags_json TEXT NOT NULL,        -- JSON list of strings
        trial TEXT NOT NULL,
        duration_s REAL,
        sensors_json TEXT NOT NULL,     -- JSON object sensor id -> segment (or null)
        verdicts_json TEXT NOT NULL,    -- JSON object calibration -> verdict
        markers_json TEXT NOT NULL,     -- JSON list of [t_s, label]
        height_m REAL,
        dominance TEXT NOT NULL,
        notes TEXT NOT NULL,
        status TEXT NOT NULL,           -- 'ok' or 'damaged'
        problem TEXT NOT NULL,          -- why a damaged file cannot be read
        file_size INTEGER NOT NULL,
        file_mtime_ns INTEGER NOT NULL
    )""",
    "CREATE INDEX IF NOT EXISTS sessions_subject ON sessions (subject_id)",
    """CREATE TABLE IF NOT EXISTS subjects (
        subject_id TEXT PRIMARY KEY,
        height_m REAL,
        dominance TEXT NOT NULL,
        notes TEXT NOT NULL,
        sessions INTEGER NOT NULL
    )""",
    """CREATE TABLE IF NOT EXISTS results (
        session_path TEXT NOT NULL,
        name TEXT NOT NULL,
        value_json TEXT NOT NULL,
        computed_utc TEXT NOT NULL,
        PRIMARY KEY (session_path, name)
    )""",
    """CREATE TABLE IF NOT EXISTS about (
        key TEXT PRIMARY KEY,
        value TEXT NOT NULL
    )""",
)

_SESSION_COLUMNS = ("path", "subject_id", "recorded_utc", "condition", "tags_json", "trial", "duration_s",
                    "sensors_json", "verdicts_json", "markers_json", "height_m", "dominance", "notes",
                    "status", "problem", "file_size", "file_mtime_ns")


class LibraryError(OSError):
    """The library folder or its index cannot be used (the message says why and what to do)."""


class LibraryVersionError(LibraryError):
    """The index was written by a newer MimuCap: refused, and left unchanged."""


@dataclass(frozen=True)
class SessionEntry:
    """One session file of the library, as the index lists it.

    ``path`` is relative to the library folder ('/' separated); ``recorded_utc`` ISO 8601 (the
    recording's start, else the file's creation; '' when unknown); ``duration_s`` the time span
    of the sensor streams in s (None when damaged); ``sensors`` sensor id → segment (None when
    unassigned); ``verdicts`` calibration → verdict (``"body"``, ``"magnetometer S01"``...);
    ``markers`` (t_s, label) pairs, t_s in s since the recording started; ``status``
    :data:`STATUS_OK` or :data:`STATUS_DAMAGED` with the reason in ``problem``.
    """

    path: str
    subject_id: str
    recorded_utc: str = ""
    condition: str = ""
    tags: tuple[str, ...] = ()
    trial: str = ""
    duration_s: float | None = None
    sensors: dict[str, str | None] = field(default_factory=dict)
    verdicts: dict[str, str] = field(default_factory=dict)
    markers: tuple[tuple[float, str], ...] = ()
    height_m: float | None = None
    dominance: str = ""
    notes: str = ""
    status: str = STATUS_OK
    problem: str = ""
    file_size: int = 0
    file_mtime_ns: int = 0

    @property
    def ok(self) -> bool:
        return self.status == STATUS_OK

    @property
    def date(self) -> str:
        """The recording's local date ``YYYY-MM-DD`` ('' when unknown)."""
        recorded = parse_utc(self.recorded_utc)
        return "" if recorded is None else recorded.astimezone().strftime("%Y-%m-%d")

    @property
    def file_name(self) -> str:
        return self.path.rsplit("/", 1)[-1]

    def verdicts_text(self) -> str:
        """The verdicts on one line, e.g. ``"body good; magnetometer S01 warn"``."""
        return "; ".join(f"{name} {verdict}" for name, verdict in self.verdicts.items())

    def sensors_text(self) -> str:
        """The sensors on one line, e.g. ``"S01=pelvis S02=thorax S03"``."""
        return " ".join(sid if segment is None else f"{sid}={segment}" for sid, segment in self.sensors.items())


@dataclass(frozen=True)
class SubjectEntry:
    """A subject of the library: its record as in its newest readable session, and how many
    session files (readable or not) name it."""

    subject_id: str
    height_m: float | None
    dominance: str
    notes: str
    sessions: int


@dataclass(frozen=True)
class ScanReport:
    """What a scan changed in the index (file paths relative to the library folder)."""

    added: tuple[str, ...] = ()
    updated: tuple[str, ...] = ()
    removed: tuple[str, ...] = ()
    damaged: tuple[str, ...] = ()
    unchanged: int = 0


def parse_utc(text: str) -> datetime | None:
    """An ISO 8601 time (a naive one is taken as UTC), or None when empty or unreadable."""
    if not text:
        return None
    try:
        moment = datetime.fromisoformat(str(text).replace("Z", "+00:00"))
    except ValueError:
        return None
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=timezone.utc)


def check_trial_name(trial: str) -> str:
    """``trial`` stripped, or ``ValueError``: it becomes part of a file name (1-40 letters,
    digits, '_', '.' or '-')."""
    trial = str(trial).strip()
    if not _NAME_RE.match(trial):
        raise ValueError(f"trial name {trial!r}: use 1-40 letters, digits, '_', '.' or '-'")
    return trial


def check_tags(tags) -> tuple[str, ...]:
    """Tags stripped, empty ones dropped, duplicates removed (order kept), or ``ValueError`` for a
    tag longer than 40 characters or holding a comma, semicolon, tab or line break (they
    separate tags in lists and CSV files)."""
    cleaned: list[str] = []
    for tag in tags:
        tag = str(tag).strip()
        if not tag:
            continue
        if not _TAG_RE.match(tag):
            raise ValueError(f"tag {tag!r}: at most 40 characters, no comma, semicolon, tab or line break")
        if tag not in cleaned:
            cleaned.append(tag)
    return tuple(cleaned)


def library_fields(condition: str = "", tags=(), trial: str = "") -> dict[str, Any]:
    """The session metadata record ``metadata["library"]``: ``condition`` (free text such as
    ``"pre-op"`` or ``"6 weeks"``), ``tags`` (list of strings), ``trial`` (the trial name)."""
    return {"condition": str(condition).strip(), "tags": list(check_tags(tags)),
            "trial": check_trial_name(trial) if trial else ""}


def session_file_name(subject_id: str, date: str, trial: str) -> str:
    """``<subject>_<YYYY-MM-DD>_<trial>.h5``."""
    return f"{subject_id}_{date}_{trial}.h5"


def recording_path(root: str | os.PathLike[str], subject_id: str, trial: str | None = None,
                   now: datetime | None = None) -> Path:
    """Where a new recording of ``subject_id`` goes: ``<subject>_<YYYY-MM-DD>_<trial>.h5`` in the
    library folder ``root`` (local date of ``now``); without ``trial`` the next free
    ``trialNN`` of that day. ``FileExistsError`` when a named trial's file (or journal) exists."""
    if not _NAME_RE.match(subject_id or ""):
        raise ValueError(f"subject id {subject_id!r}: use 1-40 letters, digits, '_', '.' or '-'")
    folder = Path(root)
    date = (now or datetime.now()).strftime("%Y-%m-%d")
    taken = lambda p: p.exists() or Path(str(p) + ".journal").exists()  # noqa: E731
    if trial is not None:
        path = folder / session_file_name(subject_id, date, check_trial_name(trial))
        if taken(path):
            raise FileExistsError(f"{path} exists already: choose another trial name")
        return path
    number = 1
    while taken(path := folder / session_file_name(subject_id, date, f"trial{number:02d}")):
        number += 1
    return path


def _verdicts(metadata: Mapping[str, Any], calibrations: Mapping[str, Any]) -> dict[str, str]:
    """Calibration → verdict from a session's metadata and stored calibrations."""
    verdicts: dict[str, str] = {}
    body = calibrations.get("body") or metadata.get("body_calibration")
    if isinstance(body, Mapping):
        verdict = body.get("verdict") or (body.get("quality") or {}).get("verdict")
        verdicts["body"] = str(verdict or "applied")
    magnetometers = calibrations.get("magnetometer")
    # what the recording judged of its calibrations when it started (their standing: verdict,
    # device, local field, age), else their fits' verdicts
    readiness = metadata.get("magnetometer_readiness")
    readiness = readiness if isinstance(readiness, Mapping) else {}
    if isinstance(magnetometers, Mapping):
        for sensor_id, calibration in sorted(magnetometers.items()):
            quality = calibration.get("quality") if isinstance(calibration, Mapping) else None
            verdict = quality.get("verdict") if isinstance(quality, Mapping) else None
            standing = readiness.get(sensor_id)
            if isinstance(standing, Mapping) and standing.get("level"):
                verdict = standing["level"]
            verdicts[f"magnetometer {sensor_id}"] = str(verdict or "applied")
    for sensor_id, standing in sorted(readiness.items()):
        if isinstance(standing, Mapping) and standing.get("level") == "not calibrated":
            verdicts.setdefault(f"magnetometer {sensor_id}", "not calibrated")
    for sensor_id in metadata.get("mag_calibrated_sensors") or ():
        verdicts.setdefault(f"magnetometer {sensor_id}", "applied")
    return verdicts


def recorded_utc(metadata: Mapping[str, Any]) -> str:
    """When a session was recorded (ISO 8601): the recording's start, else the file's creation;
    '' when unknown."""
    recording = metadata.get("recording")
    started = recording.get("started_utc") if isinstance(recording, Mapping) else None
    return str(started or metadata.get("created_utc") or "")


def _subject_of(metadata: Mapping[str, Any]) -> dict[str, Any]:
    subject = metadata.get("subject")
    return dict(subject) if isinstance(subject, Mapping) else {}


_FILE_NAME_RE = re.compile(r"^(?P<subject>[A-Za-z0-9.-][A-Za-z0-9_.-]*?)_(?P<date>\d{4}-\d{2}-\d{2})_"
                           r"(?P<trial>[A-Za-z0-9_.-]+)\.h5(\.journal)?$")


def _guess_subject(relative: str) -> str:
    """The subject id a damaged file's name suggests (``<subject>_...``), '' if none."""
    name = relative.rsplit("/", 1)[-1]
    match = _FILE_NAME_RE.match(name)
    if match:
        return match["subject"]
    head = name.split("_", 1)[0] if "_" in name else ""
    return head if _NAME_RE.match(head or "") else ""


def _named(relative: str) -> dict[str, str]:
    """Date (``recorded_utc``, the day's local noon) and trial that a library file name tells
    (``<subject>_<YYYY-MM-DD>_<trial>.h5``): shown for a file that cannot be read."""
    match = _FILE_NAME_RE.match(relative.rsplit("/", 1)[-1])
    if not match:
        return {}
    try:
        noon = datetime.fromisoformat(match["date"] + "T12:00:00").astimezone().astimezone(timezone.utc)
    except ValueError:
        return {"trial": match["trial"]}
    return {"recorded_utc": noon.isoformat(timespec="seconds"), "trial": match["trial"]}


def read_entry(root: str | os.PathLike[str], relative: str) -> SessionEntry:
    """The index entry of the file ``root/relative``, read from the file itself.

    Never raises for a file that cannot be read: the entry then has ``status`` damaged and
    the reason (the subject from the metadata when that part still reads, else from the file
    name). A ``.h5.journal`` without its session file is an unfinished recording.
    """
    path = Path(root) / relative
    stat = path.stat()
    signature = {"file_size": int(stat.st_size), "file_mtime_ns": int(stat.st_mtime_ns)}
    if relative.endswith(".journal"):
        return SessionEntry(path=relative, subject_id=_guess_subject(relative), **_named(relative), status=STATUS_DAMAGED,
                            problem=("recording not finished (only its journal is here: in progress, or "
                                     f"interrupted; `mimucap recover {relative[:-len('.journal')]}` rebuilds it)"),
                            **signature)
    try:
        summary = read_summary(path)
    except (SessionFormatError, OSError, ValueError) as error:
        try:
            subject = _subject_of(read_metadata(path)).get("id", "")
        except (SessionFormatError, OSError, ValueError):
            subject = ""
        reason = str(error).removeprefix(f"{path}: ")
        return SessionEntry(path=relative, subject_id=str(subject or _guess_subject(relative)), **_named(relative),
                            status=STATUS_DAMAGED, problem=reason, **signature)
    metadata = summary.metadata
    subject = _subject_of(metadata)
    fields = metadata.get(METADATA_KEY) if isinstance(metadata.get(METADATA_KEY), Mapping) else {}
    try:
        tags = check_tags(fields.get("tags") or ())
    except (TypeError, ValueError):
        tags = ()
    height = subject.get("height_m", metadata.get("height_m"))
    return SessionEntry(
        path=relative, subject_id=str(subject.get("id") or _guess_subject(relative)),
        recorded_utc=recorded_utc(metadata), condition=str(fields.get("condition") or ""), tags=tags,
        trial=str(fields.get("trial") or ""), duration_s=summary.duration_s,
        sensors=dict(sorted(summary.segments.items())),
        verdicts=_verdicts(metadata, summary.calibrations),
        markers=tuple((float(m.t_s), m.label) for m in summary.markers),
        height_m=None if height is None else float(height), dominance=str(subject.get("dominance") or ""),
        notes=str(subject.get("notes") or ""), **signature)


def _row(entry: SessionEntry) -> tuple:
    return (entry.path, entry.subject_id, entry.recorded_utc, entry.condition, json.dumps(list(entry.tags)),
            entry.trial, entry.duration_s, json.dumps(entry.sensors), json.dumps(entry.verdicts),
            json.dumps([list(m) for m in entry.markers]), entry.height_m, entry.dominance, entry.notes,
            entry.status, entry.problem, entry.file_size, entry.file_mtime_ns)


def _entry(row: sqlite3.Row) -> SessionEntry:
    return SessionEntry(
        path=row["path"], subject_id=row["subject_id"], recorded_utc=row["recorded_utc"],
        condition=row["condition"], tags=tuple(json.loads(row["tags_json"])), trial=row["trial"],
        duration_s=row["duration_s"], sensors=json.loads(row["sensors_json"]),
        verdicts=json.loads(row["verdicts_json"]),
        markers=tuple((float(t), str(label)) for t, label in json.loads(row["markers_json"])),
        height_m=row["height_m"], dominance=row["dominance"], notes=row["notes"], status=row["status"],
        problem=row["problem"], file_size=row["file_size"], file_mtime_ns=row["file_mtime_ns"])


def _now_utc() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def _result_json(name: str, value: Any) -> str:
    try:
        return json.dumps(value, sort_keys=True, allow_nan=False)
    except (TypeError, ValueError) as error:
        raise ValueError(f"result {name!r} is not JSON-serialisable (plain numbers, strings, lists, "
                         f"dicts; no NaN): {error}") from error


class Library:
    """The library in folder ``root`` (created when missing, with its index).

    Every method opens the index for its own work and closes it again, so a ``Library`` may be
    kept for as long as a window is open while other processes use the same folder.
    ``LibraryVersionError`` when the index comes from a newer MimuCap; ``LibraryError`` when
    the folder cannot be made, or at first use when the index is damaged (:meth:`rebuild` sets
    that right).
    """

    def __init__(self, root: str | os.PathLike[str]) -> None:
        self.root = Path(root).expanduser()
        try:
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise LibraryError(f"cannot use {self.root} as the library folder: {error}") from error
        if not self.root.is_dir():
            raise LibraryError(f"library folder {self.root} is not a folder")
        self.index_path = self.root / INDEX_NAME
        self.trash = self.root / TRASH_NAME
        try:
            with self._connection():
                pass  # creates the index, or refuses a newer one, now rather than at first use
        except LibraryVersionError:
            raise
        except LibraryError:
            pass  # a damaged index: said at first use, made again by rebuild()

    # -- the index ---------------------------------------------------------------------------
    @contextmanager
    def _connection(self) -> Iterator[sqlite3.Connection]:
        try:
            connection = sqlite3.connect(str(self.index_path), timeout=BUSY_TIMEOUT_S, isolation_level=None)
        except sqlite3.Error as error:
            raise LibraryError(f"cannot open the library index {self.index_path}: {error}") from error
        with closing(connection):
            connection.row_factory = sqlite3.Row
            try:
                connection.execute("PRAGMA synchronous = FULL")
                self._check_version(connection)
                yield connection
            except sqlite3.DatabaseError as error:
                if isinstance(error, sqlite3.OperationalError) and "locked" in str(error):
                    raise LibraryError(f"the library index {self.index_path} stayed locked by another "
                                       f"MimuCap for {BUSY_TIMEOUT_S:.0f} s; try again") from error
                raise LibraryError(f"the library index {self.index_path} is damaged ({error}); "
                                   f"`mimucap library rebuild` makes it again from the session files") from error

    def _check_version(self, connection: sqlite3.Connection) -> None:
        version = connection.execute("PRAGMA user_version").fetchone()[0]
        if version > SCHEMA_VERSION:
            raise LibraryVersionError(self._newer_message(connection, version))
        if version == SCHEMA_VERSION:
            return
        connection.execute("BEGIN IMMEDIATE")
        try:
            version = connection.execute("PRAGMA user_version").fetchone()[0]  # another process may have won
            if version > SCHEMA_VERSION:
                raise LibraryVersionError(self._newer_message(connection, version))
            if version < SCHEMA_VERSION:
                for statement in _SCHEMA:
                    connection.execute(statement)
                connection.execute("INSERT OR REPLACE INTO about VALUES ('written_by', ?)", (f"MimuCap {__version__}",))
                connection.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
            connection.execute("COMMIT")
        except BaseException:
            connection.execute("ROLLBACK")
            raise

    def _newer_message(self, connection: sqlite3.Connection, version: int) -> str:
        try:
            row = connection.execute("SELECT value FROM about WHERE key = 'written_by'").fetchone()
            writer = f" by {row[0]}" if row else ""
        except sqlite3.Error:
            writer = ""
        return (f"the library index {self.index_path} was written{writer} with index version {version}; "
                f"this MimuCap ({__version__}) reads up to version {SCHEMA_VERSION}. Update MimuCap to "
                f"use this library (the index was left unchanged).")

    @contextmanager
    def _write(self) -> Iterator[sqlite3.Connection]:
        """One write transaction: committed whole, or not at all."""
        with self._connection() as connection:
            connection.execute("BEGIN IMMEDIATE")
            try:
                yield connection
            except BaseException:
                connection.execute("ROLLBACK")
                raise
            connection.execute("COMMIT")

    @staticmethod
    def _refresh_subjects(connection: sqlite3.Connection) -> None:
        """The subjects table from the sessions: each subject's record as in its newest readable
        session (any session when none reads)."""
        connection.execute("DELETE FROM subjects")
        rows = connection.execute(
            "SELECT subject_id, height_m, dominance, notes, status, recorded_utc FROM sessions "
            "ORDER BY subject_id, (status = 'ok'), recorded_utc").fetchall()
        subjects: dict[str, list] = {}
        for row in rows:
            record = subjects.setdefault(row["subject_id"], [None, "", "", 0])
            record[3] += 1
            if row["status"] == STATUS_OK or record[3] == 1:
                record[:3] = [row["height_m"], row["dominance"], row["notes"]]
        connection.executemany("INSERT INTO subjects VALUES (?, ?, ?, ?, ?)",
                               [(sid, *record) for sid, record in subjects.items()])

    # -- scanning ----------------------------------------------------------------------------
    def files(self) -> list[str]:
        """Session files below the folder (relative, sorted): ``*.h5``, and ``*.h5.journal``
        without their session file; the trash and hidden files (a session being written) left out."""
        found = []
        for folder, subfolders, names in os.walk(self.root):
            here = Path(folder)
            subfolders[:] = sorted(d for d in subfolders if not d.startswith(".")
                                   and not (here == self.root and d == TRASH_NAME))
            for name in names:
                if name.startswith("."):
                    continue
                if name.endswith(".h5") or (name.endswith(".h5.journal") and name[:-len(".journal")] not in names):
                    found.append((here / name).relative_to(self.root).as_posix())
        return sorted(found)

    def scan(self, progress: Callable[[float], None] | None = None) -> ScanReport:
        """Bring the index up to date with the files: new and changed files are read, the
        entries of files gone are removed (with their results). Files are read before the
        index is locked; the changes are written in one transaction."""
        report = progress or (lambda fraction: None)
        files = self.files()
        with self._connection() as connection:
            known = {row["path"]: (row["file_size"], row["file_mtime_ns"])
                     for row in connection.execute("SELECT path, file_size, file_mtime_ns FROM sessions")}
        entries: list[SessionEntry] = []
        unchanged = 0
        for index, relative in enumerate(files):
            try:
                stat = (self.root / relative).stat()
            except OSError:
                continue  # gone since the listing
            if known.get(relative) == (stat.st_size, stat.st_mtime_ns):
                unchanged += 1
            else:
                try:
                    entries.append(read_entry(self.root, relative))
                except OSError:
                    continue
            report((index + 1) / max(len(files), 1))
        removed = sorted(set(known) - set(files))
        if entries or removed:
            with self._write() as connection:
                self._put(connection, entries)
                for relative in removed:
                    connection.execute("DELETE FROM sessions WHERE path = ?", (relative,))
                    connection.execute("DELETE FROM results WHERE session_path = ?", (relative,))
                self._refresh_subjects(connection)
        return ScanReport(added=tuple(e.path for e in entries if e.path not in known),
                          updated=tuple(e.path for e in entries if e.path in known),
                          removed=tuple(removed), damaged=tuple(e.path for e in entries if not e.ok),
                          unchanged=unchanged)

    @staticmethod
    def _put(connection: sqlite3.Connection, entries: list[SessionEntry]) -> None:
        placeholders = ", ".join("?" * len(_SESSION_COLUMNS))
        connection.executemany(f"INSERT OR REPLACE INTO sessions ({', '.join(_SESSION_COLUMNS)}) "
                               f"VALUES ({placeholders})", [_row(e) for e in entries])

    def add_file(self, path: str | os.PathLike[str]) -> SessionEntry:
        """Index (again) the session file ``path``, which must lie inside the library folder."""
        relative = self.relative(path)
        entry = read_entry(self.root, relative)
        with self._write() as connection:
            self._put(connection, [entry])
            self._refresh_subjects(connection)
        return entry

    def rebuild(self, progress: Callable[[float], None] | None = None) -> ScanReport:
        """Make the index again from the files alone (every file read). Results of sessions
        whose file is still there are kept. A damaged index file is moved aside
        (``mimucap-library.sqlite.damaged-<time>``) and a new one made; an index from a newer
        MimuCap is refused (:class:`LibraryVersionError`)."""
        try:
            with self._connection() as connection:
                connection.execute("SELECT count(*) FROM sessions").fetchone()
                integrity = connection.execute("PRAGMA quick_check").fetchone()[0]
            if integrity != "ok":
                raise LibraryError(f"integrity check: {integrity}")
        except LibraryVersionError:
            raise
        except LibraryError:
            stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
            aside = self.index_path.with_name(f"{INDEX_NAME}.damaged-{stamp}")
            os.replace(self.index_path, aside)
            for suffix in ("-journal", "-wal", "-shm"):
                Path(str(self.index_path) + suffix).unlink(missing_ok=True)
        report = progress or (lambda fraction: None)
        files = self.files()
        entries = []
        for index, relative in enumerate(files):
            try:
                entries.append(read_entry(self.root, relative))
            except OSError:
                continue
            report((index + 1) / max(len(files), 1))
        with self._write() as connection:
            connection.execute("DELETE FROM sessions")
            self._put(connection, entries)
            connection.execute("DELETE FROM results WHERE session_path NOT IN (SELECT path FROM sessions)")
            self._refresh_subjects(connection)
        return ScanReport(added=tuple(e.path for e in entries), damaged=tuple(e.path for e in entries if not e.ok))

    # -- reading -----------------------------------------------------------------------------
    def relative(self, path: str | os.PathLike[str]) -> str:
        """``path`` (absolute, or relative to the library) as the index names it; ``ValueError``
        when it lies outside the library folder."""
        candidate = Path(path)
        if not candidate.is_absolute():
            candidate = self.root / candidate
        try:
            return candidate.resolve().relative_to(self.root.resolve()).as_posix()
        except ValueError:
            raise ValueError(f"{path} is not inside the library folder {self.root}") from None

    def file(self, entry: SessionEntry | str) -> Path:
        """The absolute path of a session (an entry or its relative path)."""
        return self.root / (entry.path if isinstance(entry, SessionEntry) else entry)

    def sessions(self, subject_id: str | None = None) -> list[SessionEntry]:
        """Every session (or a subject's), oldest first."""
        query = "SELECT * FROM sessions"
        arguments: tuple = ()
        if subject_id is not None:
            query += " WHERE subject_id = ?"
            arguments = (subject_id,)
        with self._connection() as connection:
            rows = connection.execute(query + " ORDER BY recorded_utc, path", arguments).fetchall()
        return [_entry(row) for row in rows]

    def session(self, path: str | os.PathLike[str]) -> SessionEntry:
        """The entry of one session (``KeyError`` when the index does not list it)."""
        relative = self.relative(path)
        with self._connection() as connection:
            row = connection.execute("SELECT * FROM sessions WHERE path = ?", (relative,)).fetchone()
        if row is None:
            raise KeyError(f"{relative} is not in the library {self.root} (rescan?)")
        return _entry(row)

    def subjects(self) -> list[SubjectEntry]:
        """Every subject named by a session file, by id."""
        with self._connection() as connection:
            rows = connection.execute("SELECT * FROM subjects ORDER BY subject_id").fetchall()
        return [SubjectEntry(row["subject_id"], row["height_m"], row["dominance"], row["notes"], row["sessions"])
                for row in rows]

    def subject(self, subject_id: str) -> SubjectEntry | None:
        return next((s for s in self.subjects() if s.subject_id == subject_id), None)

    def index_rows(self) -> dict[str, list[tuple]]:
        """The index's subjects and sessions tables as sorted plain rows (to compare indexes)."""
        with self._connection() as connection:
            return {table: sorted(tuple(row) for row in connection.execute(f"SELECT * FROM {table}"))
                    for table in ("subjects", "sessions")}

    # -- changing sessions -------------------------------------------------------------------
    def _checked_entry(self, path: str | os.PathLike[str]) -> SessionEntry:
        entry = self.session(path)
        if not entry.ok:
            raise ValueError(f"{entry.path} cannot be changed: the file is damaged ({entry.problem})")
        return entry

    def _update_fields(self, entry: SessionEntry, **changes) -> SessionEntry:
        fields = {"condition": entry.condition, "tags": list(entry.tags), "trial": entry.trial, **changes}
        update_metadata(self.file(entry), {METADATA_KEY: fields})
        return self.add_file(self.file(entry))

    def set_condition(self, path: str | os.PathLike[str], condition: str) -> SessionEntry:
        """Set a session's condition (written into its file, then indexed)."""
        return self._update_fields(self._checked_entry(path), condition=str(condition).strip())

    def set_tags(self, path: str | os.PathLike[str], tags) -> SessionEntry:
        """Set a session's tags (see :func:`check_tags`; written into its file, then indexed)."""
        return self._update_fields(self._checked_entry(path), tags=list(check_tags(tags)))

    def rename_trial(self, path: str | os.PathLike[str], trial: str) -> SessionEntry:
        """Name a session's trial ``trial``: written into its file, which is renamed
        ``<subject>_<date>_<trial>.h5`` in its folder (``FileExistsError`` when taken);
        its results follow it."""
        entry = self._checked_entry(path)
        trial = check_trial_name(trial)
        source = self.file(entry)
        date = entry.date or datetime.now().strftime("%Y-%m-%d")
        target = source.with_name(session_file_name(entry.subject_id or "unknown", date, trial))
        if target != source and (target.exists() or Path(str(target) + ".journal").exists()):
            raise FileExistsError(f"cannot name the trial {trial!r}: {self.relative(target)} exists already")
        update_metadata(source, {METADATA_KEY: {"condition": entry.condition, "tags": list(entry.tags),
                                                "trial": trial}})
        os.replace(source, target)
        new = read_entry(self.root, self.relative(target))
        with self._write() as connection:
            connection.execute("DELETE FROM sessions WHERE path = ?", (entry.path,))
            self._put(connection, [new])
            connection.execute("UPDATE results SET session_path = ? WHERE session_path = ?", (new.path, entry.path))
            self._refresh_subjects(connection)
        return new

    def move_to_trash(self, path: str | os.PathLike[str]) -> Path:
        """Move a session file (damaged ones too) into the library's trash folder, keeping its
        sub-path (a numbered name when taken); its index entry and results go. Returns where it is now."""
        relative = self.relative(path)
        source = self.root / relative
        target = self.trash / relative
        index = 2
        while target.exists():
            target = (self.trash / relative).with_name(f"{Path(relative).stem}.{index}{Path(relative).suffix}")
            index += 1
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.move(str(source), str(target))
        with self._write() as connection:
            connection.execute("DELETE FROM sessions WHERE path = ?", (relative,))
            connection.execute("DELETE FROM results WHERE session_path = ?", (relative,))
            self._refresh_subjects(connection)
        return target

    def recording_path(self, subject_id: str, trial: str | None = None, now: datetime | None = None) -> Path:
        """Where a new recording goes (:func:`recording_path` in this library's folder)."""
        return recording_path(self.root, subject_id, trial, now)

    # -- analysis results --------------------------------------------------------------------
    def store_result(self, path: str | os.PathLike[str], name: str, value: Any) -> None:
        """Keep the analysis result ``name`` of a session (any JSON value; replaces an older one)."""
        self.store_results(path, {name: value})

    def store_results(self, path: str | os.PathLike[str], values: Mapping[str, Any]) -> None:
        """Keep several results of a session in one transaction (all or none)."""
        relative = self.relative(path)
        when = _now_utc()
        with self._write() as connection:
            if connection.execute("SELECT 1 FROM sessions WHERE path = ?", (relative,)).fetchone() is None:
                raise KeyError(f"{relative} is not in the library {self.root} (rescan?)")
            for name, value in values.items():
                if not isinstance(name, str) or not name:
                    raise ValueError(f"result name {name!r} must be a non-empty string")
                connection.execute("INSERT OR REPLACE INTO results VALUES (?, ?, ?, ?)",
                                   (relative, name, _result_json(name, value), when))

    def results(self, path: str | os.PathLike[str]) -> dict[str, Any]:
        """A session's stored results, name → value."""
        relative = self.relative(path)
        with self._connection() as connection:
            rows = connection.execute("SELECT name, value_json FROM results WHERE session_path = ? ORDER BY name",
                                      (relative,)).fetchall()
        return {row["name"]: json.loads(row["value_json"]) for row in rows}

    def result(self, path: str | os.PathLike[str], name: str, default: Any = None) -> Any:
        return self.results(path).get(name, default)


__all__ = [
    "INDEX_NAME", "TRASH_NAME", "SCHEMA_VERSION", "BUSY_TIMEOUT_S", "METADATA_KEY", "STATUS_OK", "STATUS_DAMAGED",
    "LibraryError", "LibraryVersionError", "SessionEntry", "SubjectEntry", "ScanReport", "Library",
    "read_entry", "recording_path", "library_fields", "check_tags", "check_trial_name", "session_file_name", "parse_utc",
    "recorded_utc",
]
