"""Crash-safe append-only journal: length-prefixed, CRC-checked records.

The recorder appends every block of samples as it arrives, so a crash (``kill -9``, power
loss) costs at most what was not yet flushed; the writer flushes at least every
``flush_interval_s`` (≤ 1 s) and has the data fsynced right after (in a helper thread). Layout (little-endian)::

    header   8 bytes magic b"MCJRNL\\r\\n", u16 version = 1, u16 reserved
    record   u32 body length L, u32 CRC-32 of the body, body (L bytes):
             u8 kind, then L−1 bytes of payload (meaning defined by the writer's user)

:func:`read_journal` returns every intact record up to the first torn one (short length,
short body, or CRC mismatch) and says where it stopped; nothing after a torn record is
trusted. A file without the magic raises :class:`JournalError` naming the file.
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

MAGIC = b"MCJRNL\r\n"
VERSION = 1
_HEADER = struct.Struct("<8sHH")
_RECORD = struct.Struct("<II")
#: Records longer than this are treated as corruption by the reader.
MAX_RECORD_BYTES = 256 * 1024 * 1024


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


@dataclass
class JournalContents:
    """What :func:`read_journal` found: intact records and where reading stopped."""

    path: Path
    records: list[tuple[int, bytes]] = field(default_factory=list)
    valid_bytes: int = 0      #: bytes up to the end of the last intact record
    file_bytes: int = 0
    torn: bool = False        #: True when bytes after ``valid_bytes`` were not a valid record

    @property
    def discarded_bytes(self) -> int:
        return self.file_bytes - self.valid_bytes


def iter_journal(path: str | os.PathLike[str], contents: JournalContents | None = None
                 ) -> Iterator[tuple[int, bytes]]:
    """Yield ``(kind, payload)`` of each intact record; stop at the first torn one.

    ``contents`` (optional) is updated with ``valid_bytes``, ``file_bytes`` and ``torn``.
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
        while True:
            prefix = handle.read(_RECORD.size)
            if not prefix:
                return
            if len(prefix) < _RECORD.size:
                contents.torn = True
                return
            length, crc = _RECORD.unpack(prefix)
            if length < 1 or length > MAX_RECORD_BYTES or position + _RECORD.size + length > size:
                contents.torn = True
                return
            body = handle.read(length)
            if len(body) < length or zlib.crc32(body) != crc:
                contents.torn = True
                return
            position += _RECORD.size + length
            contents.valid_bytes = position
            yield body[0], body[1:]


def read_journal(path: str | os.PathLike[str]) -> JournalContents:
    """Every intact record of the journal at ``path`` (see :func:`iter_journal`)."""
    contents = JournalContents(Path(path))
    contents.records = list(iter_journal(path, contents))
    return contents
