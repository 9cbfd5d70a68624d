"""The MimuCap UDP protocol of wireless sensor nodes (ESP32 + BNO055 class), version 1.

Pure encoders and a *total* decoder: :func:`decode_packet` turns any byte string into a
:class:`~mimucap.acquisition.samples.Sample`, a :class:`SyncRequest`, a :class:`SyncResponse`,
a :class:`~mimucap.acquisition.samples.RefusedSample` (a valid frame whose values are NaN or out
of range: its sensor and sequence number are kept) or a
:class:`~mimucap.acquisition.rejections.Rejection`; it never raises and never lets a NaN through. The layout is documented in ``docs/protocols.md``; in short (little-endian)::

    header (20 bytes)  magic u16 = 0x434D ("MC"), version u8 = 1, type u8,
                       sensor_id u16, flags u16, seq u32, time_us u64
    payload            present channels in flag-bit order:
                       bit0 acc 3×f32 m/s² · bit1 gyr 3×f32 rad/s · bit2 mag 3×f32 µT ·
                       bit3 q_world_from_sensor 4×f32 [w,x,y,z] · bit4 calibration u8
                       (sys<<6 | gyr<<4 | acc<<2 | mag, each 0..3) · bit5 battery u8 (%)
    trailer            CRC-32 (zlib/IEEE) u32 of header + payload

Message types: ``1`` sample (node → host; ``time_us`` = node clock at measurement),
``2`` time-sync request (host → node; ``sensor_id`` = target or ``0xFFFF`` for all,
``seq`` = request id, ``time_us`` = host send time t1), ``3`` time-sync response
(node → host; ``seq`` = request id, ``time_us`` = node receive time t2, payload
``t1_us u64`` echoed and ``t3_us u64`` node send time), ``4`` hello (node → host, when it starts
and on request; ``time_us`` = node clock, payload the node's factory MAC, 6 bytes, see
:mod:`mimucap.acquisition.hello`), ``5`` hello request (host → node; ``sensor_id`` = target or
``0xFFFF``, no payload). A node older than the hello ignores a hello request (it is no
time-sync request) and sends no hello; a host older than the hello refuses a hello as
``unknown_type``.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

from mimucap.acquisition.hello import Hello, HelloRequest
from mimucap.acquisition.rejections import Rejection
from mimucap.acquisition.samples import (DEFAULT_LIMITS, RefusedSample, Sample, ValueLimits,
                                         validated_or_refused)

MAGIC = 0x434D
VERSION = 1
TYPE_SAMPLE = 1
TYPE_SYNC_REQUEST = 2
TYPE_SYNC_RESPONSE = 3
TYPE_HELLO = 4
TYPE_HELLO_REQUEST = 5
BROADCAST_ID = 0xFFFF
MAC_BYTES = 6

FLAG_ACC = 1 << 0
FLAG_GYR = 1 << 1
FLAG_MAG = 1 << 2
FLAG_QUAT = 1 << 3
FLAG_CALIBRATION = 1 << 4
FLAG_BATTERY = 1 << 5
KNOWN_FLAGS = FLAG_ACC | FLAG_GYR | FLAG_MAG | FLAG_QUAT | FLAG_CALIBRATION | FLAG_BATTERY

HEADER = struct.Struct("<HBBHHIQ")
CRC = struct.Struct("<I")
SYNC_PAYLOAD = struct.Struct("<QQ")
_VEC3 = struct.Struct("<3f")
_QUAT = struct.Struct("<4f")
_U8 = struct.Struct("<B")

#: Largest datagram the host accepts; anything longer is refused as ``oversized``.
MAX_PACKET_BYTES = 256
MAX_TIME_US = 2**64 - 1


@dataclass(frozen=True)
class SyncRequest:
    """Host → node: "what time is it for you?" (``host_send_us`` = t1, host clock, µs)."""

    target_id: int
    request_id: int
    host_send_us: int


@dataclass(frozen=True)
class SyncResponse:
    """Node → host answer: t1 echoed, t2 node receive and t3 node send time (µs)."""

    sensor_id: int
    request_id: int
    host_send_us: int
    node_receive_us: int
    node_send_us: int


def payload_size(flags: int) -> int:
    """Payload bytes implied by ``flags`` (known bits only)."""
    return _payload_struct(flags & KNOWN_FLAGS).size


def _frame(msg_type: int, sensor_id: int, flags: int, seq: int, time_us: int,
           payload: bytes) -> bytes:
    body = HEADER.pack(MAGIC, VERSION, msg_type, sensor_id, flags, seq % 2**32,
                       time_us) + payload
    return body + CRC.pack(zlib.crc32(body))


def encode_sample(sample: Sample) -> bytes:
    """The datagram for ``sample`` (its ``device_time_s`` rounded to µs, ``seq`` mod 2³²)."""
    flags = 0
    payload = bytearray()
    if sample.acc is not None:
        flags |= FLAG_ACC
        payload += _VEC3.pack(*sample.acc)
    if sample.gyr is not None:
        flags |= FLAG_GYR
        payload += _VEC3.pack(*sample.gyr)
    if sample.mag_uT is not None:
        flags |= FLAG_MAG
        payload += _VEC3.pack(*sample.mag_uT)
    if sample.q_world_from_sensor is not None:
        flags |= FLAG_QUAT
        payload += _QUAT.pack(*sample.q_world_from_sensor)
    if sample.calibration is not None:
        flags |= FLAG_CALIBRATION
        s, g, a, m = (int(c) & 3 for c in sample.calibration)
        payload += _U8.pack(s << 6 | g << 4 | a << 2 | m)
    if sample.battery_pct is not None:
        flags |= FLAG_BATTERY
        payload += _U8.pack(max(0, min(255, int(round(sample.battery_pct)))))
    time_us = int(round(sample.device_time_s * 1e6))
    return _frame(TYPE_SAMPLE, sample.sensor_id, flags, sample.seq, time_us, bytes(payload))


def encode_sync_request(request: SyncRequest) -> bytes:
    """The datagram for a time-sync request."""
    return _frame(TYPE_SYNC_REQUEST, request.target_id, 0, request.request_id,
                  request.host_send_us, b"")


def encode_sync_response(response: SyncResponse) -> bytes:
    """The datagram for a time-sync response."""
    payload = SYNC_PAYLOAD.pack(response.host_send_us, response.node_send_us)
    return _frame(TYPE_SYNC_RESPONSE, response.sensor_id, 0, response.request_id,
                  response.node_receive_us, payload)


def encode_hello(hello: Hello, node_time_us: int = 0) -> bytes:
    """The datagram of a node's hello (``node_time_us``: its clock when sending, µs)."""
    if len(hello.mac) != MAC_BYTES:
        raise ValueError(f"a hello carries a {MAC_BYTES}-byte MAC, got {len(hello.mac)} bytes")
    return _frame(TYPE_HELLO, hello.sensor_id, 0, 0, node_time_us, bytes(hello.mac))


def encode_hello_request(request: HelloRequest) -> bytes:
    """The datagram asking node ``request.target_id`` (or every node) for its hello."""
    return _frame(TYPE_HELLO_REQUEST, request.target_id, 0, 0, 0, b"")


def decode_packet(data: bytes, limits: ValueLimits = DEFAULT_LIMITS
                  ) -> Sample | RefusedSample | SyncRequest | SyncResponse | Hello | HelloRequest | Rejection:
    """Decode one datagram; any input gives a message or a :class:`Rejection` (never raises)."""
    try:
        return _decode(bytes(data), limits)
    except Exception:  # noqa: BLE001 - totality: a decoder bug must not kill a worker
        return Rejection.UNDECODABLE


def _decode(data: bytes, limits: ValueLimits
            ) -> Sample | RefusedSample | SyncRequest | SyncResponse | Hello | HelloRequest | Rejection:
    if len(data) > MAX_PACKET_BYTES:
        return Rejection.OVERSIZED
    if len(data) < HEADER.size + CRC.size:
        return Rejection.TOO_SHORT
    magic, version, msg_type, sensor_id, flags, seq, time_us = HEADER.unpack_from(data)
    if magic != MAGIC:
        return Rejection.BAD_MAGIC
    if version != VERSION:
        return Rejection.UNSUPPORTED_VERSION
    (crc,) = CRC.unpack_from(data, len(data) - CRC.size)
    if zlib.crc32(data[: -CRC.size]) != crc:
        return Rejection.BAD_CHECKSUM
    payload = data[HEADER.size: -CRC.size]
    if msg_type == TYPE_SAMPLE:
        return _decode_sample(sensor_id, flags, seq, time_us, payload, limits)
    if msg_type == TYPE_SYNC_REQUEST:
        if flags or payload:
            return Rejection.LENGTH_MISMATCH
        return SyncRequest(sensor_id, seq, time_us)
    if msg_type == TYPE_SYNC_RESPONSE:
        if flags:
            return Rejection.UNKNOWN_FLAGS
        if len(payload) != SYNC_PAYLOAD.size:
            return Rejection.LENGTH_MISMATCH
        t1, t3 = SYNC_PAYLOAD.unpack(payload)
        return SyncResponse(sensor_id, seq, t1, time_us, t3)
    if msg_type == TYPE_HELLO:
        if flags:
            return Rejection.UNKNOWN_FLAGS
        if len(payload) != MAC_BYTES:
            return Rejection.LENGTH_MISMATCH
        if sensor_id == BROADCAST_ID:
            return Rejection.UNKNOWN_SENSOR
        if payload in (bytes(MAC_BYTES), b"\xff" * MAC_BYTES):
            return Rejection.OUT_OF_RANGE   # a MAC that names no device
        return Hello(sensor_id, payload)
    if msg_type == TYPE_HELLO_REQUEST:
        if flags or payload:
            return Rejection.LENGTH_MISMATCH
        return HelloRequest(sensor_id)
    return Rejection.UNKNOWN_TYPE


_PAYLOAD_STRUCTS: dict[int, struct.Struct] = {}


def _payload_struct(flags: int) -> struct.Struct:
    """One struct for the whole payload of ``flags`` (cached)."""
    layout = _PAYLOAD_STRUCTS.get(flags)
    if layout is None:
        fmt = "<"
        for bit, code in ((FLAG_ACC, "3f"), (FLAG_GYR, "3f"), (FLAG_MAG, "3f"), (FLAG_QUAT, "4f"),
                          (FLAG_CALIBRATION, "B"), (FLAG_BATTERY, "B")):
            if flags & bit:
                fmt += code
        layout = _PAYLOAD_STRUCTS[flags] = struct.Struct(fmt)
    return layout


def _decode_sample(sensor_id: int, flags: int, seq: int, time_us: int, payload: bytes,
                   limits: ValueLimits) -> Sample | RefusedSample | Rejection:
    if sensor_id == BROADCAST_ID:
        return Rejection.UNKNOWN_SENSOR
    if flags & ~KNOWN_FLAGS:
        return Rejection.UNKNOWN_FLAGS
    layout = _payload_struct(flags)
    if len(payload) != layout.size:
        return Rejection.LENGTH_MISMATCH
    fields = layout.unpack(payload)
    values: dict[str, object] = {}
    offset = 0
    for bit, name, width in ((FLAG_ACC, "acc", 3), (FLAG_GYR, "gyr", 3), (FLAG_MAG, "mag_uT", 3),
                             (FLAG_QUAT, "q_world_from_sensor", 4)):
        if flags & bit:
            values[name] = fields[offset: offset + width]
            offset += width
    if flags & FLAG_CALIBRATION:
        packed = fields[offset]
        values["calibration"] = (packed >> 6 & 3, packed >> 4 & 3, packed >> 2 & 3, packed & 3)
        offset += 1
    if flags & FLAG_BATTERY:
        values["battery_pct"] = float(fields[offset])
    sample = Sample(sensor_id=sensor_id, seq=seq, device_time_s=time_us * 1e-6, **values)
    return validated_or_refused(sample, limits)
