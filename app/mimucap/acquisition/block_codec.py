"""Bytes for a :class:`~mimucap.acquisition.samples.SampleBlock` (used by the recorder's journal).

Layout: u32 length of a UTF-8 JSON header, the header
``{"source", "sensor_id", "n", "arrays": [[name, dtype, trailing shape], ...]}``, then each
array's little-endian bytes in header order. :func:`decode_block` checks every size and
refuses anything inconsistent with ``ValueError``.
"""

from __future__ import annotations

import json
import struct

import numpy as np

from mimucap.acquisition.samples import CHANNELS, SampleBlock

_LENGTH = struct.Struct("<I")
_TIME_ARRAYS = ("seq", "device_time_s", "host_time_s", "receive_time_s")
_DTYPES = {"int64": "<i8", "float64": "<f8", "int8": "i1"}


def encode_block(block: SampleBlock) -> bytes:
    names = [name for name in _TIME_ARRAYS + CHANNELS if getattr(block, name) is not None]
    arrays = []
    entries = []
    for name in names:
        array = np.asarray(getattr(block, name))
        dtype = {"i": "int64", "f": "float64"}.get(array.dtype.kind, "float64")
        if name == "calibration":
            dtype = "int8"
        array = np.ascontiguousarray(array, dtype=_DTYPES[dtype])
        entries.append([name, dtype, list(array.shape[1:])])
        arrays.append(array.tobytes())
    header = json.dumps({"source": block.source, "sensor_id": block.sensor_id, "n": len(block),
                         "arrays": entries}, separators=(",", ":")).encode("utf-8")
    return _LENGTH.pack(len(header)) + header + b"".join(arrays)


def decode_block(data: bytes) -> SampleBlock:
    """The block encoded in ``data``; ``ValueError`` if the bytes are inconsistent."""
    try:
        return _decode(data)
    except (TypeError, KeyError, AttributeError, OverflowError) as error:
        raise ValueError(f"sample block record is malformed: {error}") from None


def _decode(data: bytes) -> SampleBlock:
    if len(data) < _LENGTH.size:
        raise ValueError("sample block record too short")
    (length,) = _LENGTH.unpack_from(data)
    try:
        header = json.loads(data[_LENGTH.size:_LENGTH.size + length].decode("utf-8"))
        n = int(header["n"])
        entries = header["arrays"]
    except (UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError, ValueError) as error:
        raise ValueError(f"sample block record has a bad header: {error}") from None
    position = _LENGTH.size + length
    values: dict[str, np.ndarray] = {}
    if n < 0 or not isinstance(entries, list):
        raise ValueError("sample block record has a bad header")
    for name, dtype, tail in entries:
        if name not in _TIME_ARRAYS + CHANNELS or dtype not in _DTYPES:
            raise ValueError(f"sample block record has an unknown array {name!r} ({dtype})")
        shape = (n, *[int(v) for v in tail])
        if any(v < 0 for v in shape):
            raise ValueError(f"sample block record has a negative shape for {name!r}")
        count = int(np.prod(shape))
        size = count * np.dtype(_DTYPES[dtype]).itemsize
        if position + size > len(data):
            raise ValueError(f"sample block record is short in array {name!r}")
        values[name] = np.frombuffer(data, dtype=_DTYPES[dtype], count=count, offset=position).reshape(shape).copy()
        position += size
    if position != len(data) or any(name not in values for name in _TIME_ARRAYS):
        raise ValueError("sample block record has the wrong size")
    return SampleBlock(source=str(header.get("source", "")), sensor_id=str(header["sensor_id"]), **values)
