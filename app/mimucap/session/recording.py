"""The recorder: sample blocks → crash-safe journal → session file.

Used by ``mimucap record`` and by the GUI's record button. While recording, every block is
appended to a journal beside the output (``SESSION.h5.journal``, see
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
import json
import math
import os
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from mimucap.acquisition.block_codec import decode_arrays, decode_block, encode_arrays, encode_block
from mimucap.core.samples import SensorSamples, concatenate_samples, join_per_sensor
from mimucap.io.journal import JournalContents, JournalWriter, iter_journal
from mimucap.io.session import Marker, Session, SessionTruth, read_session, write_session

JOURNAL_SUFFIX = ".journal"
#: A damaged journal is kept under its name plus this after recovery (nothing is thrown away).
DAMAGED_SUFFIX = ".damaged"
KIND_START = 1     #: JSON: metadata and start time
KIND_BLOCK = 2     #: a sample block (mimucap.acquisition.block_codec)
KIND_MARKER = 3    #: JSON: {"t_s": host time, "label": ...}
KIND_STATUS = 4    #: JSON: acquisition statistics at the end
KIND_END = 5       #: JSON: why the recording ended
KIND_TRUTH = 6     #: a block of the simulator's ground truth (:func:`encode_truth`)


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


def _json_safe(value: Any) -> Any:
    """``value`` with NaN/infinite floats replaced by ``None`` (session metadata is strict JSON)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    return value


def journal_path_for(session_path: str | os.PathLike[str]) -> Path:
    """``SESSION.h5`` → ``SESSION.h5.journal``."""
    path = Path(session_path)
    return path.with_name(path.name + JOURNAL_SUFFIX)


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
        start = {"metadata": self.metadata, "start_host_s": self.start_host_s,
                 "started_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                 "flush_interval_s": self.settings.flush_interval_s}
        self._append(KIND_START, json.dumps(start).encode("utf-8"))

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
        return self._append(KIND_MARKER, json.dumps({"host_s": host_s, "label": str(label)}).encode("utf-8"))

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
            self._append(KIND_STATUS, json.dumps(_json_safe(status), default=str).encode("utf-8"))
        end = {"reason": reason if self.failure is None else "write error", "stopped_host_s": time.monotonic()}
        if devices:
            end["devices"] = dict(devices)
        self._append(KIND_END, json.dumps(end).encode("utf-8"))
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

#: Journal records read between two progress reports of :func:`session_from_journal`.
PROGRESS_EVERY_RECORDS = 4096
#: Share of a conversion's time its reading of the journal takes (the rest writes the file):
#: how :func:`_convert` divides its progress.
READING_SHARE = 0.8


def session_from_journal(journal_path: str | os.PathLike[str],
                         progress: Callable[[float], None] | None = None) -> tuple[Session, JournalContents]:
    """Rebuild the session from every intact record of a recorder journal. ``progress``
    (optional) is called with the fraction (0..1) of the journal's bytes read so far."""
    journal_path = Path(journal_path)
    contents = JournalContents(journal_path)
    start: dict[str, Any] | None = None
    status: Any = None
    end: dict[str, Any] | None = None
    markers: list[Any] = []
    per_sensor: dict[str, list[SensorSamples]] = {}
    truth_parts: list[_TruthPart] = []
    for index, (kind, payload) in enumerate(iter_journal(journal_path, contents)):
        if progress is not None and index % PROGRESS_EVERY_RECORDS == 0 and contents.file_bytes:
            progress(contents.valid_bytes / contents.file_bytes)
        try:
            if kind == KIND_START:
                start = json.loads(payload)
            elif kind == KIND_BLOCK:
                block = decode_block(payload)
                per_sensor.setdefault(block.sensor_id, []).append(block)
            elif kind == KIND_MARKER:
                markers.append(json.loads(payload))
            elif kind == KIND_STATUS:
                status = json.loads(payload)
            elif kind == KIND_END:
                end = json.loads(payload)
            elif kind == KIND_TRUTH:
                truth_parts.append(decode_truth(payload))
        except ValueError as error:
            raise ValueError(f"{journal_path}: record {index + 1} is damaged: {error}") from None
    if start is None:
        start = _start_from_samples(per_sensor)
        if start is None:
            raise ValueError(f"{journal_path}: the journal holds no recording start (nothing to recover)")
    try:
        t0 = float(start["start_host_s"])
        metadata = dict(start.get("metadata") or {})
        markers = [(float(m["host_s"]) - t0, str(m["label"])) for m in markers]
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise ValueError(f"{journal_path}: the start or a marker record is damaged: {error!r}") from None
    segments = metadata.pop("sensor_segments", {}) or {}
    calibrations = metadata.pop("calibrations", {}) or {}
    recording = {"started_utc": start.get("started_utc"), "start_host_monotonic_s": t0,
                 "start_record_lost": bool(start.get("lost", False)),
                 "journal_flush_interval_s": start.get("flush_interval_s"),
                 "ended": (end or {}).get("reason", "crash (recovered from the journal)"),
                 "journal_discarded_bytes": contents.discarded_bytes,
                 "journal_skipped_bytes": [[span.offset, span.size] for span in contents.skipped]}
    metadata["recording"] = recording
    told_at_end = (end or {}).get("devices")
    if isinstance(told_at_end, dict) and told_at_end:
        # the devices known at the start stand (their calibrations were chosen for them)
        metadata["devices"] = {**told_at_end, **(metadata.get("devices") or {})}
    if status is not None:
        metadata["acquisition"] = status
    sensors = {sensor_id: _recorded(blocks, t0, segments.get(sensor_id))
               for sensor_id, blocks in sorted(per_sensor.items())}
    session = Session(metadata=metadata, sensors=sensors,
                      markers=[Marker(t, label) for t, label in markers],
                      truth=_joined_truth(truth_parts, t0), calibrations=dict(calibrations))
    return session, contents


@dataclass
class _TruthPart:
    """One decoded :data:`KIND_TRUTH` record (see :func:`encode_truth`)."""

    host_s: np.ndarray
    q_world_from_segment: dict[str, np.ndarray]
    joint_angles_deg: dict[str, np.ndarray]
    root_position_m: np.ndarray
    note: str


#: Prefixes of a truth record's per-segment and per-column array names.
_SEGMENT_PREFIX, _ANGLE_PREFIX = "q_world_from_segment:", "joint_angles_deg:"


def encode_truth(host_s, q_world_from_segment: Mapping[str, np.ndarray], joint_angles_deg: Mapping[str, np.ndarray],
                 root_position_m, note: str = "") -> bytes:
    """A truth block as a journal payload (:func:`~mimucap.acquisition.block_codec.encode_arrays`,
    header field ``note``): float64 arrays ``host_s`` (n,), ``q_world_from_segment:<segment>``
    (n, 4), ``joint_angles_deg:<column>`` (n,) and ``root_position_m`` (n, 3)."""
    host = np.asarray(host_s, dtype=np.float64).reshape(-1)
    n = len(host)
    arrays = [("host_s", host)]
    arrays += [(_SEGMENT_PREFIX + name, np.asarray(q, dtype=np.float64).reshape(n, 4))
               for name, q in q_world_from_segment.items()]
    arrays += [(_ANGLE_PREFIX + name, np.asarray(a, dtype=np.float64).reshape(n))
               for name, a in joint_angles_deg.items()]
    arrays.append(("root_position_m", np.asarray(root_position_m, dtype=np.float64).reshape(n, 3)))
    return encode_arrays({"note": str(note)}, n, arrays)


def decode_truth(payload: bytes) -> _TruthPart:
    """The inverse of :func:`encode_truth`; ``ValueError`` when the payload does not add up."""
    header, arrays = decode_arrays(payload, "truth record")
    if "host_s" not in arrays or "root_position_m" not in arrays:
        raise ValueError("truth record lacks its host times or root positions")

    def named(prefix: str) -> dict[str, np.ndarray]:
        return {name[len(prefix):]: value for name, value in arrays.items() if name.startswith(prefix)}

    return _TruthPart(arrays["host_s"], named(_SEGMENT_PREFIX), named(_ANGLE_PREFIX), arrays["root_position_m"],
                      str(header.get("note", "")))


def _joined_truth(parts: list[_TruthPart], t0: float) -> SessionTruth | None:
    """The truth blocks of a recording as one :class:`SessionTruth` on session time (``t_s =
    host − t0``, rows before the start dropped, sorted, a repeated instant kept once);
    ``None`` when there is none. Blocks whose names differ from the first one's are left out
    (one recording shows one simulated suit)."""
    parts = [p for p in parts if p.q_world_from_segment.keys() == parts[0].q_world_from_segment.keys()
             and p.joint_angles_deg.keys() == parts[0].joint_angles_deg.keys()] if parts else []
    if not parts:
        return None
    t = np.concatenate([p.host_s for p in parts]) - t0
    order = np.argsort(t, kind="stable")
    keep = order[t[order] >= 0.0]
    if len(keep):
        keep = keep[np.r_[True, np.diff(t[keep]) > 0.0]]

    def joined(pick) -> np.ndarray:
        return np.concatenate([pick(p) for p in parts])[keep]

    return SessionTruth(
        t_s=t[keep],
        q_world_from_segment={name: joined(lambda p, k=name: p.q_world_from_segment[k])
                              for name in parts[0].q_world_from_segment},
        joint_angles_deg={name: joined(lambda p, k=name: p.joint_angles_deg[k]) for name in parts[0].joint_angles_deg},
        extra={"root_position_m": joined(lambda p: p.root_position_m)},
        attributes={"origin": parts[0].note} if parts[0].note else {},
    )


def _start_from_samples(per_sensor: Mapping[str, list[SensorSamples]]) -> dict[str, Any] | None:
    """A stand-in for a damaged start record: time zero at the first sample (host monotonic
    s), no metadata (source, subject and sensor segments are lost with the record); ``None``
    when there is no sample either."""
    first = min((float(np.min(b.t_s)) for blocks in per_sensor.values() for b in blocks if len(b)),
                default=None)
    if first is None:
        return None
    return {"metadata": {}, "start_host_s": first, "started_utc": None, "flush_interval_s": None, "lost": True}


def _recorded(blocks: list[SensorSamples], t0: float, segment: str | None) -> SensorSamples:
    """One sensor's journaled blocks as the session keeps them: rows in host-time order, ``t_s``
    since the recording started (host monotonic ``t0`` s), a channel that some blocks lacked
    NaN (−1 for the calibration status) in their rows: every sample is kept, and what it did
    not send stays recognisable."""
    joined = concatenate_samples(blocks, missing="fill")
    joined = joined.rows(np.argsort(joined.t_s, kind="stable"))
    return replace(joined, t_s=joined.t_s - t0, receive_time_s=None, source="", segment=segment)


def damage_report(contents: JournalContents) -> str:
    """What reading a journal could not use, one clause per damaged stretch: skipped bytes in
    the middle (offset, size and the records recovered after them) and a torn tail."""
    parts = [f"skipped {span.size} damaged bytes at offset {span.offset}; "
             f"{contents.records_after(span)} records after it recovered" for span in contents.skipped]
    if contents.torn:
        parts.append(f"the last {contents.torn_bytes} bytes (from offset {contents.valid_bytes}) are a torn "
                     f"tail holding no intact record (the unflushed moment of a crash)")
    return "; ".join(parts)


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
