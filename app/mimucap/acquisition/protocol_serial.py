"""The MimuCap serial line protocol (radio receivers and wired boards, MPU-9250 class).

One sample per ASCII line, NMEA-style, with an XOR checksum of every byte between ``$`` and
``*`` written as two hex digits::

    $MIMU,<sensor_id>,<seq>,<time_us>[,A,ax,ay,az][,G,gx,gy,gz][,M,mx,my,mz]
         [,Q,w,x,y,z][,C,sys,gyr,acc,mag][,B,battery_pct]*HH\\r\\n

Units: ``A`` m/s², ``G`` rad/s, ``M`` µT (sensor frame), ``Q`` = q_world_from_sensor scalar
first, ``C`` calibration status 0..3, ``B`` battery percent; ``time_us`` is the board clock in
µs. Each tag appears at most once, in this order. Lines longer than :data:`MAX_LINE_BYTES` are
refused.

A node says which hardware it is in a hello line, when it starts and every
:data:`~mimucap.acquisition.hello.SERIAL_HELLO_PERIOD_S` (the link is one-way: the host cannot
ask)::

    $MIMUH,<sensor_id>,<MAC as 12 hex digits>*HH\\r\\n

:func:`parse_line` is total: any bytes give a Sample, a RefusedSample (a well-formed line whose
values are refused, e.g. ``nan``/``inf`` spellings as ``non_finite``: its sensor and sequence
number are kept), a :class:`~mimucap.acquisition.hello.Hello` or a Rejection, never an exception
and never a NaN.
"""

from __future__ import annotations

from mimucap.acquisition.hello import Hello
from mimucap.acquisition.rejections import Rejection
from mimucap.acquisition.samples import (DEFAULT_LIMITS, RefusedSample, Sample, ValueLimits,
                                         validated_or_refused)

TALKER = "MIMU"
HELLO_TALKER = "MIMUH"
MAX_LINE_BYTES = 256
#: Tag → (sample attribute, number of values), in the only allowed order.
TAGS = {
    "A": ("acc", 3), "G": ("gyr", 3), "M": ("mag_uT", 3),
    "Q": ("q_world_from_sensor", 4), "C": ("calibration", 4), "B": ("battery_pct", 1),
}
_TAG_ORDER = list(TAGS)


def checksum(body: bytes) -> int:
    """XOR of every byte of ``body`` (the text between ``$`` and ``*``)."""
    value = 0
    for byte in body:
        value ^= byte
    return value


def _format_number(value: float) -> str:
    return format(float(value), ".7g")


def encode_line(sample: Sample) -> bytes:
    """The line (with ``\\r\\n``) for ``sample``; ``device_time_s`` is rounded to µs."""
    fields = [TALKER, str(int(sample.sensor_id)), str(int(sample.seq) % 2**32),
              str(int(round(sample.device_time_s * 1e6)))]
    for tag, (name, _count) in TAGS.items():
        value = getattr(sample, name)
        if value is None:
            continue
        fields.append(tag)
        if name == "calibration":
            fields.extend(str(int(v)) for v in value)
        elif name == "battery_pct":
            fields.append(_format_number(value))
        else:
            fields.extend(_format_number(v) for v in value)
    body = ",".join(fields).encode("ascii")
    return b"$" + body + b"*" + f"{checksum(body):02X}".encode("ascii") + b"\r\n"


def encode_hello_line(hello: Hello) -> bytes:
    """The hello line (with ``\\r\\n``) of a node."""
    body = f"{HELLO_TALKER},{int(hello.sensor_id)},{bytes(hello.mac).hex().upper()}".encode("ascii")
    return b"$" + body + b"*" + f"{checksum(body):02X}".encode("ascii") + b"\r\n"


def _int_field(text: str, upper: int) -> int | None:
    if not text.isdigit() or len(text) > 20:
        return None
    value = int(text)
    return value if value <= upper else None


def parse_line(line: bytes, limits: ValueLimits = DEFAULT_LIMITS) -> Sample | RefusedSample | Hello | Rejection:
    """Decode one line (with or without its line terminator); never raises."""
    try:
        return _parse(bytes(line), limits)
    except Exception:  # noqa: BLE001 - totality: a parser bug must not kill a worker
        return Rejection.UNDECODABLE


def _parse(line: bytes, limits: ValueLimits) -> Sample | RefusedSample | Hello | Rejection:
    line = line.rstrip(b"\r\n")
    if len(line) > MAX_LINE_BYTES:
        return Rejection.OVERSIZED
    if len(line) < 4 or line[:1] != b"$" or line[-3:-2] != b"*":
        return Rejection.MALFORMED_LINE
    body, given = line[1:-3], line[-2:]
    try:
        text = body.decode("ascii")
        expected = int(given.decode("ascii"), 16)
    except (UnicodeDecodeError, ValueError):
        return Rejection.MALFORMED_LINE
    if not all(c in b"0123456789abcdefABCDEF" for c in given):
        return Rejection.MALFORMED_LINE
    if checksum(body) != expected:
        return Rejection.BAD_CHECKSUM
    fields = text.split(",")
    if fields[0] == HELLO_TALKER:
        return _hello(fields)
    if len(fields) < 4 or fields[0] != TALKER:
        return Rejection.MALFORMED_LINE
    sensor_id = _int_field(fields[1], 0xFFFE)
    seq = _int_field(fields[2], 2**32 - 1)
    time_us = _int_field(fields[3], 2**64 - 1)
    if sensor_id is None or seq is None or time_us is None:
        return Rejection.BAD_FIELD
    values: dict[str, object] = {}
    index, last_tag = 4, -1
    while index < len(fields):
        tag = fields[index]
        if tag not in TAGS or _TAG_ORDER.index(tag) <= last_tag:
            return Rejection.BAD_FIELD
        last_tag = _TAG_ORDER.index(tag)
        name, count = TAGS[tag]
        raw = fields[index + 1: index + 1 + count]
        if len(raw) != count:
            return Rejection.BAD_FIELD
        if name == "calibration":
            numbers = [_int_field(v, 3) for v in raw]
            if any(v is None for v in numbers):
                return Rejection.BAD_FIELD
            values[name] = tuple(numbers)
        else:
            try:
                numbers = [float(v) for v in raw]
            except ValueError:
                return Rejection.BAD_FIELD
            values[name] = numbers[0] if count == 1 else tuple(numbers)
        index += 1 + count
    sample = Sample(sensor_id=sensor_id, seq=seq, device_time_s=time_us * 1e-6, **values)
    return validated_or_refused(sample, limits)  # refuses NaN and infinity as non_finite


def _hello(fields: list[str]) -> Hello | Rejection:
    """A hello line's fields (``MIMUH``, sensor id, MAC) as a :class:`Hello`."""
    if len(fields) != 3:
        return Rejection.MALFORMED_LINE
    sensor_id = _int_field(fields[1], 0xFFFE)
    mac = fields[2]
    if sensor_id is None or len(mac) != 12 or not all(c in "0123456789abcdefABCDEF" for c in mac):
        return Rejection.BAD_FIELD
    raw = bytes.fromhex(mac)
    if raw in (bytes(6), b"\xff" * 6):
        return Rejection.OUT_OF_RANGE   # a MAC that names no device
    return Hello(sensor_id, raw)
