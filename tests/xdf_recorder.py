"""A small stand-in for LabRecorder in the tests: record LSL streams through real pylsl inlets
and write them as an XDF 1.0 file (the format pyxdf reads; LabRecorder writes the same chunks).

XDF layout (the XDF specification): the magic ``XDF:``, then chunks ``[NumLengthBytes (1 byte: 1,
4 or 8)][Length (that many bytes, little endian; counts the tag and the content)][Tag (uint16)]
[Content]``. Tags: 1 FileHeader (XML), 2 StreamHeader (uint32 stream id + the stream's info
XML), 3 Samples (stream id, a variable-length sample count, then per sample a timestamp flag byte
(8) with a float64 time stamp and the values: numeric channels little endian, strings each a
variable-length byte count and UTF-8 bytes), 4 ClockOffset (stream id, collection time and
offset, float64), 6 StreamFooter (stream id + XML).
"""

from __future__ import annotations

import struct
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

_FORMATS = {"float32": "<f4", "double64": "<f8", "int32": "<i4", "int16": "<i2", "int8": "<i1", "int64": "<i8"}


def _varlen(n: int) -> bytes:
    if n < 256:
        return struct.pack("<BB", 1, n)
    if n < 2 ** 32:
        return struct.pack("<BI", 4, n)
    return struct.pack("<BQ", 8, n)


def _chunk(tag: int, content: bytes) -> bytes:
    return _varlen(len(content) + 2) + struct.pack("<H", tag) + content


@dataclass
class RecordedStream:
    """One stream as recorded: its info XML, channel format, time stamps and samples, and
    the clock offsets measured while recording (collection time, offset)."""

    header_xml: str
    channel_format: str
    stamps: list[float] = field(default_factory=list)
    samples: list = field(default_factory=list)
    offsets: list[tuple[float, float]] = field(default_factory=list)


def write_xdf(path: str | Path, streams: list[RecordedStream]) -> None:
    """Write ``streams`` as an XDF file at ``path``."""
    out = bytearray(b"XDF:")
    out += _chunk(1, b'<?xml version="1.0"?><info><version>1.0</version></info>')
    for number, stream in enumerate(streams, start=1):
        sid = struct.pack("<I", number)
        out += _chunk(2, sid + stream.header_xml.encode("utf-8"))
        for start in range(0, len(stream.stamps), 100):
            body = bytearray()
            stamps = stream.stamps[start:start + 100]
            for stamp, sample in zip(stamps, stream.samples[start:start + 100]):
                body += struct.pack("<Bd", 8, stamp)
                if stream.channel_format == "string":
                    for value in sample:
                        data = str(value).encode("utf-8")
                        body += _varlen(len(data)) + data
                else:
                    body += np.asarray(sample, dtype=_FORMATS[stream.channel_format]).tobytes()
            out += _chunk(3, sid + _varlen(len(stamps)) + bytes(body))
        for collected, offset in stream.offsets:
            out += _chunk(4, sid + struct.pack("<dd", collected, offset))
        first = stream.stamps[0] if stream.stamps else 0.0
        last = stream.stamps[-1] if stream.stamps else 0.0
        footer = (f'<?xml version="1.0"?><info><first_timestamp>{first}</first_timestamp>'
                  f'<last_timestamp>{last}</last_timestamp><sample_count>{len(stream.stamps)}</sample_count>'
                  f'</info>')
        out += _chunk(6, sid + footer.encode("utf-8"))
    Path(path).write_bytes(bytes(out))


def record(pylsl, infos, duration_s: float, while_recording=None) -> list[RecordedStream]:
    """Record the streams ``infos`` (``pylsl.StreamInfo``) through inlets for ``duration_s``
    seconds, as LabRecorder does (time stamps as sent, clock offsets beside them);
    ``while_recording()`` is called about every 5 ms (e.g. to step a live session)."""
    inlets = [pylsl.StreamInlet(info, max_buflen=60) for info in infos]
    recorded = []
    for inlet in inlets:
        inlet.open_stream(5.0)
        full = inlet.info(5.0)
        recorded.append(RecordedStream(full.as_xml(), _format_name(full.channel_format())))
    end = time.monotonic() + duration_s
    while time.monotonic() < end:
        if while_recording is not None:
            while_recording()
        for inlet, stream in zip(inlets, recorded):
            values, stamps = inlet.pull_chunk(timeout=0.0)
            stream.stamps.extend(stamps)
            stream.samples.extend(values)
        time.sleep(0.005)
    for inlet, stream in zip(inlets, recorded):
        stream.offsets.append((pylsl.local_clock(), inlet.time_correction(2.0)))
        inlet.close_stream()
    return recorded


def _format_name(code: int) -> str:
    return {1: "float32", 2: "double64", 3: "string", 4: "int32", 5: "int16", 6: "int8", 7: "int64"}[code]
