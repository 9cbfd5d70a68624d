"""The payload layout of the journal's array records: a few named arrays of ``n`` rows each.

Layout: u32 length of a UTF-8 JSON header, the header (the record's own fields, ``"n"`` the
row count, and ``"arrays": [[name, dtype, trailing shape], ...]``), then each array's
little-endian bytes in header order; every array has ``n`` rows. Sample blocks and the
simulator's truth are such records (:mod:`.records`). :func:`decode_arrays` checks every size
and refuses anything inconsistent with ``ValueError``.
"""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Iterable, Mapping
from functools import lru_cache
from typing import Any

import numpy as np

_LENGTH = struct.Struct("<I")
#: The array types a record may hold: name → little-endian code.
DTYPES = {"int64": "<i8", "float64": "<f8", "int8": "i1"}
_ITEM_BYTES = {name: np.dtype(code).itemsize for name, code in DTYPES.items()}


def encode_arrays(fields: Mapping[str, Any], n: int, arrays: Iterable[tuple[str, np.ndarray]]) -> bytes:
    """A record of JSON-able ``fields`` and named ``arrays`` of ``n`` rows each (dtypes int64,
    float64 or int8; others are refused)."""
    entries, blobs = [], []
    for name, array in arrays:
        dtype = np.asarray(array).dtype.name
        if dtype not in DTYPES:
            raise ValueError(f"array {name!r}: dtype {dtype} cannot be journaled")
        array = np.ascontiguousarray(array, dtype=DTYPES[dtype])
        if array.shape[:1] != (n,):
            raise ValueError(f"array {name!r} has {array.shape[:1]} rows, not {n}")
        entries.append([name, dtype, list(array.shape[1:])])
        blobs.append(array.tobytes())
    header = json.dumps({**fields, "n": int(n), "arrays": entries}, separators=(",", ":")).encode("utf-8")
    return _LENGTH.pack(len(header)) + header + b"".join(blobs)


def decode_arrays(data: bytes, what: str) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The header fields and the arrays (name → copy, in record order) of a record made by
    :func:`encode_arrays`; ``ValueError`` naming ``what`` (e.g. ``"truth record"``) when the
    bytes are inconsistent."""
    try:
        return _decode_arrays(data, what)
    except (TypeError, KeyError, AttributeError, OverflowError) as error:
        raise ValueError(f"{what} is malformed: {error}") from None


def _decode_arrays(data: bytes, what: str) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    if len(data) < _LENGTH.size:
        raise ValueError(f"{what} is shorter than its header")
    (length,) = _LENGTH.unpack_from(data)
    header, layout = _layout(bytes(data[_LENGTH.size:_LENGTH.size + length]), what)
    position = _LENGTH.size + length
    if position + sum(size for _name, _code, _shape, _count, size in layout) != len(data):
        raise ValueError(f"{what} holds the wrong number of values for {header['n']} rows")
    values: dict[str, np.ndarray] = {}
    for name, code, shape, count, size in layout:
        values[name] = np.frombuffer(data, dtype=code, count=count, offset=position).reshape(shape).copy()
        position += size
    return dict(header), values


@lru_cache(maxsize=4096)
def _layout(header_bytes: bytes, what: str) -> tuple[dict[str, Any], tuple[tuple[str, str, tuple, int, int], ...]]:
    """The parsed header and its arrays' ``(name, dtype code, shape, count, bytes)``: one
    sensor's blocks of one size share a header, so a journal's few distinct headers are parsed
    once each (a journal holds hundreds of thousands of records)."""
    try:
        header = json.loads(header_bytes.decode("utf-8"))
        n = int(header["n"])
        entries = header["arrays"]
    except (UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError, ValueError) as error:
        raise ValueError(f"{what} has a bad header: {error}") from None
    if n < 0 or not isinstance(entries, list):
        raise ValueError(f"{what} has a bad header")
    layout = []
    for name, dtype, tail in entries:
        if dtype not in DTYPES:
            raise ValueError(f"{what} has an array {name!r} of unknown type {dtype!r}")
        shape = (n, *[int(v) for v in tail])
        if any(v < 0 for v in shape):
            raise ValueError(f"{what} has a negative shape for {name!r}")
        count = math.prod(shape)
        layout.append((name, DTYPES[dtype], shape, count, count * _ITEM_BYTES[dtype]))
    return header, tuple(layout)
