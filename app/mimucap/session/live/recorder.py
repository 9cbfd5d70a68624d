"""The recorder: sample blocks → crash-safe journal → session file.

Used by ``mimucap record`` and by the GUI's record button. While recording, every block is
appended to a journal beside the output (``SESSION.h5.journal``; its format is
:mod:`mimucap.io.journal`), flushed and fsynced at least every ``flush_interval_s``; at
:meth:`Recorder.stop` the journal is converted into the session file
(:func:`mimucap.io.session.write_session`) and removed. After a crash the journal is still
there: :func:`recover` (``mimucap recover FILE``) or :func:`open_session` rebuilds the
session from every intact record, so a ``kill -9`` loses at most the last flush interval.
Damaged bytes in the middle of a journal cost only the records they hit: reading resumes at
the next intact record, and the result's message says which bytes were skipped.

While the simulated suit is shown, the simulator's ground truth (true segment orientations,
joint angles, root position) is journaled beside the samples (:meth:`Recorder.add_truth`), so a
recovered recording keeps it too.

A write error (disk full, storage removed) stops the recording with a message naming the
file and what to do; whatever reached the disk stays readable through :func:`recover`.

Times: blocks carry host monotonic times ``t_s`` (``time.monotonic()``, s); the session's
samples count from the start of the recording (``t_s − start_host_s``). The session file
keeps the battery charge as a fraction and the calibration status (system, gyr, acc, mag;
0..3) as the extra channel ``calibration_status`` (see :mod:`mimucap.io.session`).
"""

from __future__ import annotations

import errno
import os
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from mimucap.core.sensor_samples import SensorSamples, join_per_sensor
from mimucap.io.journal.file import JournalWriter
from mimucap.io.journal.records import (
    DAMAGED_SUFFIX, JOURNAL_SUFFIX, KIND_BLOCK, KIND_END, KIND_MARKER, KIND_START, KIND_STATUS, KIND_TRUTH,
    encode_block, encode_end, encode_json, encode_marker, encode_start, encode_truth, journal_path_for,
)
from mimucap.io.journal.to_session import damage_report, session_from_journal
from mimucap.io.session import Session, read_session, write_session


@dataclass(frozen=True)
class RecorderSettings:
    """Settings of :class:`Recorder`."""

    flush_interval_s: float = 0.5   #: s between journal flush+fsync (must be ≤ 1 s)
    fsync: bool = True              #: force data to the disk at each flush


@dataclass
class RecordingResult:
    """What a recording (or a recovery) produced."""

    session_path: Path | None          #: the session file, ``None`` if it could not be written
    journal_path: Path
    samples: dict[str, int] = field(default_factory=dict)   #: sensor → samples stored
    complete: bool = True              #: False if the recording ended by an error or a crash
    message: str = ""


def _describe_os_error(error: OSError) -> str:
    if error.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        return f"the disk is full ({error.strerror or error})"
    if error.errno in (errno.EIO, errno.ENODEV, errno.ENXIO, errno.ENOENT, errno.EROFS):
        return f"the storage device is gone or read-only ({error.strerror or error})"
    return str(error.strerror or error)


class Recorder:
    """Records sample blocks into ``out_path`` (see the module docstring)."""

    def __init__(self, out_path: str | os.PathLike[str], metadata: Mapping[str, Any] | None = None,
                 settings: RecorderSettings = RecorderSettings()) -> None:
        self.out_path = Path(out_path)
        self.journal_path = journal_path_for(self.out_path)
        self.metadata = dict(metadata or {})
        self.settings = settings
        self.start_host_s: float | None = None
        self.samples: dict[str, int] = {}
        self.failure: str | None = None
        self._journal: JournalWriter | None = None
        self._closed = False

    @property
    def recording(self) -> bool:
        return self._journal is not None and self.failure is None

    def start(self, start_host_s: float | None = None) -> None:
        """Create the journal; ``start_host_s`` (host monotonic s) is ``t_s = 0``."""
        if self.journal_path.exists():
            raise ValueError(f"{self.journal_path} exists (an interrupted recording?): "
                             f"run `mimucap recover {self.out_path}` or remove it first")
        if self.out_path.exists():
            raise ValueError(f"{self.out_path} exists: a recording never replaces a file; choose another name")
        if not self.out_path.parent.is_dir():
            raise OSError(f"cannot record to {self.out_path}: folder {self.out_path.parent} does not exist")
        self.start_host_s = time.monotonic() if start_host_s is None else float(start_host_s)
        self._journal = JournalWriter(self.journal_path, self.settings.flush_interval_s, self.settings.fsync)
        self._append(KIND_START, encode_start(self.metadata, self.start_host_s,
                                              datetime.now(timezone.utc).isoformat(timespec="seconds"),
                                              self.settings.flush_interval_s))

    def _append(self, kind: int, payload: bytes) -> bool:
        if self._journal is None or self.failure is not None:
            return False
        try:
            self._journal.append(kind, payload)
            return True
        except OSError as error:
            self._fail(error)
            return False

    def _fail(self, error: OSError) -> None:
        kept = sum(self.samples.values())
        self.failure = (f"recording stopped: {_describe_os_error(error)} while writing "
                        f"{self.journal_path}; {kept} samples received so far, everything flushed "
                        f"before the error is kept in the journal: free space or reconnect the "
                        f"storage, then run `mimucap recover {self.out_path}`")

    def add_blocks(self, blocks: Iterable[SensorSamples]) -> bool:
        """Append blocks to the journal; ``False`` once the recording has failed.

        Blocks of the same sensor and channels within one call are merged into one record.
        """
        for merged in join_per_sensor(blocks):
            if not self._append(KIND_BLOCK, encode_block(merged)):
                return False
            self.samples[merged.sensor_id] = self.samples.get(merged.sensor_id, 0) + len(merged)
        return self.tick()

    def add_marker(self, label: str, host_s: float | None = None) -> bool:
        """Mark an instant (host monotonic s, default now) with ``label``."""
        host_s = time.monotonic() if host_s is None else float(host_s)
        return self._append(KIND_MARKER, encode_marker(host_s, label))

    def add_truth(self, host_s: np.ndarray, q_world_from_segment: Mapping[str, np.ndarray],
                  joint_angles_deg: Mapping[str, np.ndarray], root_position_m: np.ndarray,
                  note: str = "") -> bool:
        """Append a block of the simulator's ground truth: at host monotonic times ``host_s``
        (n,) s, each segment's ``q_world_from_segment`` (n, 4) (scalar first), each joint-angle
        column's ``joint_angles_deg`` (n,) and the root's ``root_position_m`` (n, 3) (world
        ENU, m). ``note`` says where it came from (stored once with the truth)."""
        if len(host_s) == 0:
            return self.failure is None
        return self._append(KIND_TRUTH, encode_truth(host_s, q_world_from_segment, joint_angles_deg,
                                                     root_position_m, note))

    def tick(self) -> bool:
        """Flush the journal if due (call it regularly, also when no data arrives)."""
        if self._journal is None or self.failure is not None:
            return self.failure is None
        try:
            self._journal.flush_if_due()
        except OSError as error:
            self._fail(error)
        return self.failure is None

    def stop(self, status: Mapping[str, Any] | None = None, reason: str = "stopped",
             devices: Mapping[str, Any] | None = None) -> RecordingResult:
        """End the recording and write the session file (the journal is then removed):
        :meth:`close` then :meth:`write_session`."""
        self.close(status, reason, devices)
        return self.write_session()

    def close(self, status: Mapping[str, Any] | None = None, reason: str = "stopped",
              devices: Mapping[str, Any] | None = None) -> None:
        """End the recording: the last records go to the journal, which is closed (fast;
        nothing more is recorded). ``status`` (JSON-serialisable, e.g. per-sensor
        statistics) lands in the session metadata under ``"acquisition"``; ``devices`` (sensor
        id → :meth:`~mimucap.core.device_identity.SensorDevice.to_json`) what the sources told of
        their sensors' devices by the end, which completes the metadata's ``"devices"`` (a
        sensor first heard, or identified, after the start)."""
        if self._journal is None:
            raise ValueError("the recorder was not started")
        if status is not None:
            self._append(KIND_STATUS, encode_json(status))
        self._append(KIND_END, encode_end(reason if self.failure is None else "write error", time.monotonic(), devices))
        try:
            self._journal.close()
        except OSError as error:
            if self.failure is None:
                self._fail(error)
        self._journal = None
        self._closed = True

    def write_session(self, progress: Callable[[float], None] | None = None) -> RecordingResult:
        """Turn the closed journal into the session file and remove the journal (slow for
        long recordings; may run in any thread; ``progress`` is called with the fraction done,
        0..1). On a write error the journal is kept and the result's ``message`` says how to
        recover it."""
        if not self._closed:
            raise ValueError("close the recording before writing its session file")
        try:
            result = _convert(self.journal_path, self.out_path, progress)
        except OSError as error:
            message = self.failure or (f"recording kept in {self.journal_path}: the session file "
                                       f"could not be written ({_describe_os_error(error)})")
            return RecordingResult(None, self.journal_path, dict(self.samples), False,
                                   f"{message}; the session file could not be written "
                                   f"({_describe_os_error(error)}), run `mimucap recover {self.out_path}` later")
        if self.failure is not None:
            result.complete = False
            result.message = (self.failure.split(";")[0] + f"; the samples flushed before the error are in "
                              f"{result.session_path}")
        return result


# ------------------------------------------------------------------ journal → session

#: Share of a conversion's time its reading of the journal takes (the rest writes the file):
#: how :func:`_convert` divides its progress.
READING_SHARE = 0.8


def _convert(journal_path: Path, session_path: Path,
             progress: Callable[[float], None] | None = None) -> RecordingResult:
    """Write the session of ``journal_path`` to ``session_path``; the journal is then removed,
    unless some of its bytes could not be read (damage or a torn tail): then nothing is thrown
    away, the journal is kept as ``<journal>.damaged``. ``progress`` (optional) is called with
    the fraction (0..1) of the conversion done."""
    report = progress or (lambda _fraction: None)
    session, contents = session_from_journal(journal_path, lambda f: report(READING_SHARE * f))
    write_session(session_path, session, lambda f: report(READING_SHARE + (1.0 - READING_SHARE) * f))
    message = ""
    if contents.damaged:
        kept = journal_path.with_name(journal_path.name + DAMAGED_SUFFIX)
        os.replace(journal_path, kept)
        message = (f"{journal_path} is damaged: {damage_report(contents)}; the session holds every intact "
                   f"record and the whole journal is kept as {kept}")
        if session.metadata["recording"]["start_record_lost"]:
            message += ("; the recording's start record was damaged: its metadata (source, subject, sensor "
                        "segments) is lost and times count from the first sample")
    else:
        os.unlink(journal_path)
    ended = session.metadata["recording"]["ended"]
    complete = not contents.damaged and not ended.startswith("crash") and ended != "write error"
    return RecordingResult(session_path, journal_path,
                           {k: len(v) for k, v in session.sensors.items()}, complete, message)


def recover(path: str | os.PathLike[str]) -> RecordingResult:
    """Rebuild ``SESSION.h5`` from ``SESSION.h5.journal`` (``path`` may name either).

    Raises ``ValueError`` when there is nothing to recover (no journal beside the file).
    """
    path = Path(path)
    if path.name.endswith(JOURNAL_SUFFIX):
        journal, session_path = path, path.with_name(path.name[: -len(JOURNAL_SUFFIX)])
    else:
        journal, session_path = journal_path_for(path), path
    if not journal.exists():
        if session_path.exists():
            read_session(session_path)  # raises SessionFormatError (a ValueError) if damaged
            raise ValueError(f"{session_path} is complete: there is no journal to recover")
        raise ValueError(f"nothing to recover: neither {session_path} nor {journal} exists")
    return _convert(journal, session_path)


def open_session(path: str | os.PathLike[str]) -> Session:
    """Read a session file, first recovering it from its journal after a crash."""
    if journal_path_for(path).exists():
        recover(path)
    return read_session(path)
