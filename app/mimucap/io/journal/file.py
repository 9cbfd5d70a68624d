"""Crash-safe append-only journal: length-prefixed, CRC-checked records.

The recorder appends every block of samples as it arrives, so a crash (``kill -9``, power
loss) costs at most what was not yet flushed; the writer flushes at least every
``flush_interval_s`` (≤ 1 s) and has the data fsynced right after (in a helper thread). Layout (little-endian)::

    header   8 bytes magic b"MCJRNL\\r\\n", u16 version = 1, u16 reserved
    record   u32 body length L, u32 CRC-32 of the body, body (L bytes):
             u8 kind, then L−1 bytes of payload (meaning defined by the writer's user)

:func:`read_journal` returns every intact record (plausible length, whole body, matching
CRC) and says what it could not read. A damaged stretch in the middle (flipped or garbage
bytes) is stepped over: the reader resynchronises on the next record whose checksum matches
and reports the skipped bytes (:class:`DamagedSpan`); bytes at the end that hold no intact
record are a *torn tail* (the unflushed moment of a crash). A length field inside damaged
bytes is never trusted on its own: a record counts only when its CRC-32 matches, so a wild
length cannot swallow the good records after it. A file without the magic raises
:class:`JournalError` naming the file.
"""

from __future__ import annotations

import os
import struct
import threading
import time
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

import numpy as np

MAGIC = b"MCJRNL\r\n"
VERSION = 1
_HEADER = struct.Struct("<8sHH")
_RECORD = struct.Struct("<II")
#: Records longer than this are treated as corruption by the reader.
MAX_RECORD_BYTES = 256 * 1024 * 1024
#: Bytes scanned per read while searching for the next intact record after damage.
RESYNC_WINDOW_BYTES = 64 * 1024
#: While resynchronising, a candidate record up to this long has its CRC checked at once;
#: a longer one must first start a chain of :data:`RESYNC_CHAIN_RECORDS` plausible record
#: headers (or reach the end of the file exactly), so that random length fields in damaged
#: bytes do not each cost a checksum over megabytes.
RESYNC_DIRECT_CHECK_BYTES = 64 * 1024
RESYNC_CHAIN_RECORDS = 3


class JournalError(ValueError):
    """A file is not a MimuCap journal (or of a newer version)."""


class _Syncer:
    """Background ``fsync`` of one file descriptor, so the caller (a GUI thread) never waits
    for the disk; an error is kept and raised by the writer's next call."""

    def __init__(self, fd: int) -> None:
        self._fd = fd
        self._wake = threading.Event()
        self._stop = False
        self.error: OSError | None = None
        self.last_sync_s = time.monotonic()
        self._thread = threading.Thread(target=self._run, name="journal-fsync", daemon=True)
        self._thread.start()

    def request(self) -> None:
        self._wake.set()

    def _run(self) -> None:
        while True:
            self._wake.wait()
            self._wake.clear()
            if self._stop:
                return
            try:
                os.fsync(self._fd)
                self.last_sync_s = time.monotonic()
            except OSError as error:
                self.error = error

    def close(self) -> None:
        self._stop = True
        self._wake.set()
        self._thread.join(timeout=10.0)


class JournalWriter:
    """Appends records to a new journal file.

    Every ``flush_interval_s`` (≤ 1 s) the buffered records are written to the operating
    system (which keeps them through a crash of this process) and, with ``fsync``, pushed to
    the disk (which keeps them through a power loss). With ``background_fsync`` the disk push
    runs in a helper thread so that ``append`` never waits for the disk; a disk error is raised
    by the next ``append``/``flush``. :meth:`close` always syncs in the calling thread.
    """

    def __init__(self, path: str | os.PathLike[str], flush_interval_s: float = 0.5,
                 fsync: bool = True, buffer_bytes: int = 1 << 20, background_fsync: bool = True) -> None:
        if not 0 < flush_interval_s <= 1.0:
            raise ValueError(f"journal flush interval must be in (0, 1] s, got {flush_interval_s}")
        self.path = Path(path)
        self.flush_interval_s = flush_interval_s
        self.fsync = fsync
        self._file = open(self.path, "xb", buffering=buffer_bytes)  # never overwrite a journal
        self._syncer = _Syncer(self._file.fileno()) if fsync and background_fsync else None
        self.bytes_written = 0
        self.records = 0
        self.last_flush_s = time.monotonic()
        self._write(_HEADER.pack(MAGIC, VERSION, 0))
        self.flush()

    def _check_syncer(self) -> None:
        if self._syncer is not None and self._syncer.error is not None:
            error, self._syncer.error = self._syncer.error, None
            raise error

    def _write(self, data: bytes) -> None:
        self._file.write(data)
        self.bytes_written += len(data)

    def append(self, kind: int, payload: bytes) -> None:
        """Append one record (``kind`` 0..255); flushes if the interval has passed."""
        if not 0 <= kind <= 255:
            raise ValueError(f"journal record kind must be 0..255, got {kind}")
        self._check_syncer()
        body = bytes((kind,)) + payload
        self._write(_RECORD.pack(len(body), zlib.crc32(body)) + body)
        self.records += 1
        self.flush_if_due()

    def flush_if_due(self) -> bool:
        """Flush if ``flush_interval_s`` passed since the last flush."""
        if time.monotonic() - self.last_flush_s >= self.flush_interval_s:
            self.flush()
            return True
        return False

    def flush(self) -> None:
        """Write everything to the operating system and request (or do) the fsync."""
        self._check_syncer()
        self._file.flush()
        if self._syncer is not None:
            self._syncer.request()
        elif self.fsync:
            os.fsync(self._file.fileno())
        self.last_flush_s = time.monotonic()

    def close(self) -> None:
        """Flush, fsync (in this thread) and close; raises the first write error, if any."""
        if self._file.closed:
            return
        try:
            if self._syncer is not None:
                self._syncer.close()
            self._check_syncer()
            self._file.flush()
            if self.fsync:
                os.fsync(self._file.fileno())
        finally:
            self._syncer = None
            self._file.close()

    @property
    def closed(self) -> bool:
        return self._file.closed


@dataclass(frozen=True)
class DamagedSpan:
    """Damaged bytes between two intact records that the reader stepped over."""

    offset: int        #: file offset (bytes) of the first damaged byte
    size: int          #: number of damaged bytes skipped
    next_record: int   #: index (0-based) of the first intact record after the damage


@dataclass
class JournalContents:
    """What :func:`read_journal` found: intact records and what could not be read."""

    path: Path
    records: list[tuple[int, bytes]] = field(default_factory=list)
    valid_bytes: int = 0      #: bytes up to the end of the last intact record
    file_bytes: int = 0
    torn: bool = False        #: True when bytes after ``valid_bytes`` hold no intact record
    skipped: list[DamagedSpan] = field(default_factory=list)   #: damage followed by intact records
    record_count: int = 0     #: intact records read

    @property
    def torn_bytes(self) -> int:
        """Bytes at the end of the file that hold no intact record (the torn tail)."""
        return self.file_bytes - self.valid_bytes

    @property
    def discarded_bytes(self) -> int:
        """Every byte that was not read as part of an intact record (skipped and torn)."""
        return self.torn_bytes + sum(span.size for span in self.skipped)

    @property
    def damaged(self) -> bool:
        """Whether any byte of the file could not be read (skipped damage or a torn tail)."""
        return self.torn or bool(self.skipped)

    def records_after(self, span: DamagedSpan) -> int:
        """Intact records read after ``span`` (up to the end of the file)."""
        return self.record_count - span.next_record


def _plausible_length(length: int, offset: int, size: int) -> bool:
    """Whether a record of body ``length`` bytes can start at ``offset`` of a ``size``-byte file."""
    return 1 <= length <= MAX_RECORD_BYTES and offset + _RECORD.size + length <= size


def _header_at(handle: BinaryIO, offset: int, size: int) -> tuple[int, int] | None:
    """``(body length, CRC)`` of a record header at byte ``offset`` whose length is plausible
    (:func:`_plausible_length`), or ``None``; the handle is left just after the header."""
    handle.seek(offset)
    prefix = handle.read(_RECORD.size)
    if len(prefix) < _RECORD.size:
        return None
    length, crc = _RECORD.unpack(prefix)
    return (length, crc) if _plausible_length(length, offset, size) else None


def _record_at(handle: BinaryIO, offset: int, size: int) -> bytes | None:
    """The body of the intact record starting at byte ``offset``, or ``None`` if there is none
    (short or implausible length, short body, or CRC mismatch)."""
    header = _header_at(handle, offset, size)
    if header is None:
        return None
    length, crc = header
    body = handle.read(length)
    if len(body) < length or zlib.crc32(body) != crc:
        return None
    return body


def _plausible_starts(chunk: bytes, first_offset: int, count: int, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Offsets among ``first_offset + [0, count)`` whose 4 bytes in ``chunk`` (read from
    ``first_offset``) form a plausible record length, and those lengths (both int64 arrays)."""
    raw = np.frombuffer(chunk, dtype=np.uint8).astype(np.int64)
    count = min(count, len(raw) - 3)
    if count <= 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    lengths = (raw[:count] | raw[1:count + 1] << 8 | raw[2:count + 2] << 16 | raw[3:count + 3] << 24)
    offsets = first_offset + np.arange(count, dtype=np.int64)
    plausible = (lengths >= 1) & (lengths <= MAX_RECORD_BYTES) & (offsets + _RECORD.size + lengths <= size)
    return offsets[plausible], lengths[plausible]


def _starts_a_chain(handle: BinaryIO, offset: int, size: int) -> bool:
    """Whether following record lengths from ``offset`` meets :data:`RESYNC_CHAIN_RECORDS`
    plausible record headers in a row, or ends exactly at the end of the file."""
    for _ in range(RESYNC_CHAIN_RECORDS):
        header = _header_at(handle, offset, size)
        if header is None:
            return False
        offset += _RECORD.size + header[0]
        if offset == size:
            return True
    return True


def _next_intact_record(handle: BinaryIO, damaged_at: int, size: int) -> int | None:
    """Offset of the first intact record that starts after ``damaged_at`` (the offset of a
    record that failed), or ``None`` when the rest of the file holds none.

    Every byte offset is a candidate; a candidate counts only if its CRC matches. Short
    candidates are checked at once; long ones (see :data:`RESYNC_DIRECT_CHECK_BYTES`) first
    need a plausible chain of headers, and those without one are checked last, only where they
    end before the first record found (so a length read from damaged bytes never reaches over
    an intact record).
    """
    found = None
    deferred: list[tuple[int, int]] = []     # (offset, body length) of long unchained candidates
    window = damaged_at + 1
    while found is None and window + _RECORD.size <= size:
        handle.seek(window)
        chunk = handle.read(RESYNC_WINDOW_BYTES + 3)
        offsets, lengths = _plausible_starts(chunk, window, RESYNC_WINDOW_BYTES, size)
        for offset, length in zip(offsets.tolist(), lengths.tolist()):
            if length > RESYNC_DIRECT_CHECK_BYTES and not _starts_a_chain(handle, offset, size):
                deferred.append((offset, length))
            elif _record_at(handle, offset, size) is not None:
                found = offset
                break
        window += RESYNC_WINDOW_BYTES
    limit = size if found is None else found
    for offset, length in deferred:
        if offset + _RECORD.size + length <= limit and _record_at(handle, offset, size) is not None:
            return offset
    return found


def iter_journal(path: str | os.PathLike[str], contents: JournalContents | None = None
                 ) -> Iterator[tuple[int, bytes]]:
    """Yield ``(kind, payload)`` of each intact record, stepping over damaged bytes.

    ``contents`` (optional) is updated with ``valid_bytes``, ``file_bytes``, ``torn``,
    ``skipped`` and ``record_count``.
    """
    path = Path(path)
    contents = contents if contents is not None else JournalContents(path)
    with open(path, "rb") as handle:
        size = os.fstat(handle.fileno()).st_size
        contents.file_bytes = size
        header = handle.read(_HEADER.size)
        if len(header) < _HEADER.size or header[:8] != MAGIC:
            raise JournalError(f"{path} is not a MimuCap journal (no journal header)")
        _magic, version, _reserved = _HEADER.unpack(header)
        if version > VERSION:
            raise JournalError(f"{path}: journal version {version} is newer than this MimuCap ({VERSION})")
        position = _HEADER.size
        contents.valid_bytes = position
        while position < size:
            body = _record_at(handle, position, size)
            if body is None:
                resume = _next_intact_record(handle, position, size)
                if resume is None:
                    contents.torn = True
                    return
                contents.skipped.append(DamagedSpan(position, resume - position, contents.record_count))
                position = resume
                continue
            position += _RECORD.size + len(body)
            contents.valid_bytes = position
            contents.record_count += 1
            yield body[0], body[1:]


def read_journal(path: str | os.PathLike[str]) -> JournalContents:
    """Every intact record of the journal at ``path`` (see :func:`iter_journal`)."""
    contents = JournalContents(Path(path))
    contents.records = list(iter_journal(path, contents))
    return contents
