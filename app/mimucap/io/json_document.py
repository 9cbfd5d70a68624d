"""Reading a user's JSON file (a body calibration, a magnetometer calibration, a skeleton model,
a norm table) with one sentence for everything that can be wrong with it.

People give the wrong file: a session instead of its calibration, a path with a typo, a file
cut short by a full disk. The reader names the file and says what it is, never Python's own
exception text ("[Errno 2]…", "'utf-8' codec can't decode byte 0x89…").
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

#: The first bytes of file kinds people hand us by mistake, and what to call them.
_BINARY_SIGNATURES = (
    (b"\x89HDF\r\n\x1a\n", "an HDF5 file (a MimuCap session?)"),
    (b"%PDF", "a PDF document"),
    (b"PK\x03\x04", "a ZIP archive"),
    (b"\x89PNG", "a PNG picture"),
)


def os_error_reason(error: OSError) -> str:
    """What went wrong in an ``OSError``, in words (no errno, no Python text)."""
    if error.errno is None:  # raised by us with a sentence of its own
        return str(error)
    return {
        2: "no such file",
        13: "permission denied",
        21: "it is a folder, not a file",
        20: "a part of the path is a file, not a folder",
        28: "the disk is full",
    }.get(error.errno, (error.strerror or str(error)).lower())


def describe_os_error(error: OSError) -> str:
    """One sentence for an ``OSError``, naming its file when it has one."""
    reason = os_error_reason(error)
    return f"{error.filename}: {reason}" if error.filename is not None else reason


def read_json_document(path: str | Path, what: str) -> Any:
    """The parsed JSON of ``path``; ``ValueError`` with one sentence naming the file and ``what``
    it should have been (e.g. ``"body calibration"``) when it cannot be read or is not JSON."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as error:
        raise ValueError(f"cannot read {what} {path}: {os_error_reason(error)}") from None
    for signature, kind in _BINARY_SIGNATURES:
        if raw.startswith(signature):
            raise ValueError(f"{path} is {kind}, not a {what} (a JSON file)")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{path} is not a text file, so not a {what} (a JSON file)") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        raise ValueError(f"{path}: invalid JSON at line {error.lineno}: {error.msg} (not a valid {what})") from None
