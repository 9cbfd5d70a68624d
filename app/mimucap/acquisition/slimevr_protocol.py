"""The SlimeVR tracker UDP protocol, server side: pure decoders and encoders.

SlimeVR trackers (ESP8266/ESP32 with a BNO08x, BNO055, ICM, BMI, LSM6 or MPU IMU and on-board
fusion) talk to a *server* on UDP port 6969. This module follows the protocol as spoken by

* SlimeVR-Server, commit ``c12e1dd93f12ff364c76ee704fb0eb04a34977e4``
  (``server/core/src/main/java/dev/slimevr/tracking/trackers/udp/TrackersUDPServer.kt`` and
  ``UDPProtocolParser.kt``: the server's answers and the packet numbers);
* SlimeVR-Tracker-ESP, commit ``da447d06801b6a89fd2bb3d0cc07852461a2a507``
  (``src/network/connection.cpp``: what a tracker sends) and ``src/debug.h`` of firmware 0.4.1
  (``FIRMWARE_BUILD_NUMBER 17``);
* the npm package ``@slimevr/tracker-emulation`` 0.2.6 with ``@slimevr/firmware-protocol``
  0.6.6 (protocol build 13), which the tests run against this module.

**Protocol version.** A tracker names its protocol version in its handshake
(``firmwareBuild``). Builds :data:`MIN_PROTOCOL_BUILD` to :data:`MAX_PROTOCOL_BUILD` are
accepted: from build 9 on a tracker announces each sensor with a sensor-info packet, and build
17 is the newest whose packets were checked. Other builds (and owoTrack phones, which send no
firmware name) are refused with a message naming the build and the supported range.

**Wire format** (big-endian). Tracker → server: ``u32 type, u64 packet number, payload``
(the number counts every packet of a tracker since its handshake, so gaps are lost packets).
Server → tracker: ``u32 type, u64 0, payload``, except the handshake answer (byte ``3`` then
``"Hey OVR =D 5"``) and the sensor-info acknowledgement (``u32 15, u8 sensor, u8 status``).

==========  ==================  =====================================================
type        name                payload (tracker → server)
==========  ==================  =====================================================
0           heartbeat           (none); answer to the server's heartbeat
3           handshake           i32 board, i32 imu, i32 mcu, 3 × i32 reserved, i32 build,
                                u8 n + n bytes firmware name, 6 bytes MAC
4           acceleration        3 × f32 linear acceleration (gravity removed), u8 sensor
10          pong                i32 ping id (echo of the server's ping)
12          battery             f32 volts, f32 charge fraction 0..1
15          sensor info         u8 sensor, u8 status (1 ok, 2 error), u8 IMU type, ...
17          rotation data       u8 sensor, u8 kind (1 normal, 2 correction),
                                4 × f32 quaternion x, y, z, w, u8 accuracy
19          signal strength     u8 sensor (255 = all sensors of the tracker), i8 dBm
22          feature flags       bit field (bit 0 of byte 0: legacy tracker, bit 1 rotation)
100         bundle              repeated (u16 length, u32 type, payload) without numbers
==========  ==================  =====================================================

Temperature (20), magnetometer accuracy (18), tap (13), error (14), user action (21) and log
(26) packets are valid and read as :class:`Ignored`; any other type is ``unknown_type``.

**Frame.** The quaternion on the wire is the tracker's fused orientation in its IMU axes: it
rotates the tracker's (mounting-corrected) sensor frame into the fusion's world frame, whose
z axis points up; the SlimeVR server turns it into its y-up frame by a −90° rotation about x
(``AXES_OFFSET`` in ``TrackersUDPServer.kt``). The wire frame is therefore already z-up like
MimuCap's world ENU: the rotation between them is the identity; its heading is the tracker fusion's own (magnetic north only for magnetometer-aided
fusion). :func:`q_world_from_slimevr` applies it after reordering ``x, y, z, w`` into
MimuCap's scalar-first ``[w, x, y, z]``.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

from mimucap.acquisition.rejections import Rejection

DEFAULT_PORT = 6969
MIN_PROTOCOL_BUILD = 9
MAX_PROTOCOL_BUILD = 17

PACKET_HEARTBEAT = 0
PACKET_HEARTBEAT_TO_TRACKER = 1
PACKET_HANDSHAKE = 3
PACKET_ACCELERATION = 4
PACKET_PING_PONG = 10
PACKET_BATTERY = 12
PACKET_TAP = 13
PACKET_ERROR = 14
PACKET_SENSOR_INFO = 15
PACKET_ROTATION_DATA = 17
PACKET_MAGNETOMETER_ACCURACY = 18
PACKET_SIGNAL_STRENGTH = 19
PACKET_TEMPERATURE = 20
PACKET_USER_ACTION = 21
PACKET_FEATURE_FLAGS = 22
PACKET_LOG = 26
PACKET_BUNDLE = 100
IGNORED_TYPES = frozenset({PACKET_TAP, PACKET_ERROR, PACKET_MAGNETOMETER_ACCURACY, PACKET_TEMPERATURE,
                           PACKET_USER_ACTION, PACKET_LOG})

ROTATION_NORMAL = 1
ROTATION_CORRECTION = 2
ALL_SENSORS = 255
#: The answer to a handshake starts with this text (after the byte 3).
HANDSHAKE_REPLY_TEXT = b"Hey OVR =D 5"
#: Server feature flags this server announces: bit 0, bundles of packets (type 100).
SERVER_FEATURES = bytes([0b0000_0001])
#: Largest datagram read (an Ethernet MTU less the IP and UDP headers).
MAX_DATAGRAM_BYTES = 1472

_HEADER = struct.Struct(">IQ")
_HANDSHAKE_INTS = struct.Struct(">7i")
_ROTATION = struct.Struct(">BB4fB")
_VEC3 = struct.Struct(">3f")
_BATTERY = struct.Struct(">2f")
_SIGNAL = struct.Struct(">Bb")
_PING = struct.Struct(">i")


@dataclass(frozen=True)
class Handshake:
    """A tracker introduces itself: ``build`` is its protocol version, ``mac`` 6 bytes."""

    board: int
    imu: int
    mcu: int
    build: int
    firmware: str
    mac: bytes

    @property
    def mac_text(self) -> str:
        """``"A1:B2:C3:D4:E5:F6"``."""
        return ":".join(f"{b:02X}" for b in self.mac)


@dataclass(frozen=True)
class Heartbeat:
    pass


@dataclass(frozen=True)
class SensorInfo:
    sensor: int
    status: int
    imu: int          #: SlimeVR IMU type code (5 = BNO055, 4 = BNO085, ...; 0 unknown)


@dataclass(frozen=True)
class Rotation:
    """Fused orientation of one sensor: ``q_xyzw`` on the wire (see :func:`q_world_from_slimevr`)."""

    sensor: int
    kind: int
    q_xyzw: tuple[float, float, float, float]
    accuracy: int


@dataclass(frozen=True)
class Acceleration:
    """Linear acceleration (gravity removed, m/s²) of one sensor in the tracker's axes."""

    sensor: int
    linear_m_s2: tuple[float, float, float]


@dataclass(frozen=True)
class Battery:
    volts: float
    fraction: float   #: remaining charge 0..1


@dataclass(frozen=True)
class Signal:
    sensor: int       #: 255: every sensor of the tracker
    dbm: int


@dataclass(frozen=True)
class Pong:
    ping_id: int


@dataclass(frozen=True)
class FeatureFlags:
    flags: bytes


@dataclass(frozen=True)
class Ignored:
    """A valid packet MimuCap has no use for (temperature, tap, log, ...)."""

    packet_type: int


Message = (Handshake | Heartbeat | SensorInfo | Rotation | Acceleration | Battery | Signal | Pong
           | FeatureFlags | Ignored)


@dataclass(frozen=True)
class Datagram:
    """One decoded datagram: its packet number and the message(s) it carries (several for a
    bundle); ``messages`` may hold :class:`Rejection` s for refused parts of a bundle."""

    packet_type: int
    number: int
    messages: tuple[Message | Rejection, ...]


def q_world_from_slimevr(q_xyzw) -> tuple[float, float, float, float]:
    """``q_world_from_sensor`` (scalar first, world ENU) of a wire quaternion ``x, y, z, w``:
    the wire frame is already z-up like world ENU (module docstring), so only the order changes."""
    x, y, z, w = (float(v) for v in q_xyzw)
    return (w, x, y, z)


# --------------------------------------------------------------------------- decoding
def decode_datagram(data: bytes) -> Datagram | Rejection:
    """Decode one tracker → server datagram; any input gives a :class:`Datagram` or a
    :class:`Rejection` (never raises, never lets NaN through)."""
    try:
        return _decode_datagram(bytes(data))
    except Exception:  # noqa: BLE001 - totality: a decoder bug must not kill a worker
        return Rejection.UNDECODABLE


def _decode_datagram(data: bytes) -> Datagram | Rejection:
    if len(data) > MAX_DATAGRAM_BYTES:
        return Rejection.OVERSIZED
    if len(data) < _HEADER.size:
        return Rejection.TOO_SHORT
    packet_type, number = _HEADER.unpack_from(data)
    payload = data[_HEADER.size:]
    if packet_type == PACKET_BUNDLE:
        return Datagram(packet_type, number, tuple(_decode_bundle(payload)))
    return Datagram(packet_type, number, (_decode_message(packet_type, payload),))


def _decode_bundle(payload: bytes) -> list[Message | Rejection]:
    out: list[Message | Rejection] = []
    offset = 0
    while offset < len(payload):
        if len(payload) - offset < 2:
            out.append(Rejection.LENGTH_MISMATCH)
            break
        (length,) = struct.unpack_from(">H", payload, offset)
        offset += 2
        part = payload[offset: offset + length]
        offset += length
        if len(part) != length or length < 4:
            out.append(Rejection.LENGTH_MISMATCH)
            break
        (inner_type,) = struct.unpack_from(">I", part)
        if inner_type in (PACKET_BUNDLE, PACKET_HANDSHAKE):
            out.append(Rejection.UNEXPECTED_MESSAGE)
            continue
        out.append(_decode_message(inner_type, part[4:]))
    return out


def _finite(values) -> bool:
    return all(math.isfinite(v) for v in values)


def _decode_message(packet_type: int, p: bytes) -> Message | Rejection:
    if packet_type == PACKET_HEARTBEAT:
        return Heartbeat()
    if packet_type == PACKET_ROTATION_DATA:
        if len(p) < _ROTATION.size:
            return Rejection.LENGTH_MISMATCH
        sensor, kind, x, y, z, w, accuracy = _ROTATION.unpack_from(p)
        if not _finite((x, y, z, w)):
            return Rejection.NON_FINITE
        return Rotation(sensor, kind, (x, y, z, w), accuracy)
    if packet_type == PACKET_ACCELERATION:
        if len(p) < _VEC3.size:
            return Rejection.LENGTH_MISMATCH
        vector = _VEC3.unpack_from(p)
        if not _finite(vector):
            return Rejection.NON_FINITE
        return Acceleration(p[12] if len(p) > 12 else 0, vector)
    if packet_type == PACKET_BATTERY:
        if len(p) < _BATTERY.size:
            return Rejection.LENGTH_MISMATCH
        volts, fraction = _BATTERY.unpack_from(p)
        if not _finite((volts, fraction)):
            return Rejection.NON_FINITE
        return Battery(volts, fraction)
    if packet_type == PACKET_SIGNAL_STRENGTH:
        if len(p) < _SIGNAL.size:
            return Rejection.LENGTH_MISMATCH
        return Signal(*_SIGNAL.unpack_from(p))
    if packet_type == PACKET_SENSOR_INFO:
        if len(p) < 2:
            return Rejection.LENGTH_MISMATCH
        return SensorInfo(p[0], p[1], p[2] if len(p) > 2 else 0)
    if packet_type == PACKET_PING_PONG:
        if len(p) < _PING.size:
            return Rejection.LENGTH_MISMATCH
        return Pong(_PING.unpack_from(p)[0])
    if packet_type == PACKET_FEATURE_FLAGS:
        return FeatureFlags(bytes(p))
    if packet_type == PACKET_HANDSHAKE:
        return _decode_handshake(p)
    if packet_type in IGNORED_TYPES:
        return Ignored(packet_type)
    return Rejection.UNKNOWN_TYPE


def _decode_handshake(p: bytes) -> Handshake | Rejection:
    if len(p) < _HANDSHAKE_INTS.size + 1:
        return Rejection.LENGTH_MISMATCH
    board, imu, mcu, _r1, _r2, _r3, build = _HANDSHAKE_INTS.unpack_from(p)
    offset = _HANDSHAKE_INTS.size
    length = p[offset]
    offset += 1
    name = p[offset: offset + length]
    if len(name) != length:
        return Rejection.LENGTH_MISMATCH
    offset += length
    mac = p[offset: offset + 6]
    if len(mac) != 6:
        return Rejection.LENGTH_MISMATCH
    firmware = name.split(b"\0", 1)[0].decode("ascii", errors="replace")
    return Handshake(board, imu, mcu, build, firmware, bytes(mac))


# --------------------------------------------------------------------------- encoding
def encode_handshake_reply() -> bytes:
    """The server's answer to a handshake: byte 3, the reply text, zero-padded to 64 bytes
    (the size SlimeVR-Server sends)."""
    return (bytes([PACKET_HANDSHAKE]) + HANDSHAKE_REPLY_TEXT).ljust(64, b"\0")


def encode_heartbeat() -> bytes:
    """Server → tracker heartbeat (the tracker answers with its own)."""
    return _HEADER.pack(PACKET_HEARTBEAT_TO_TRACKER, 0)


def encode_ping(ping_id: int) -> bytes:
    """Server → tracker ping; the tracker echoes ``ping_id`` (0 ≤ id < 2³¹) in a pong."""
    return _HEADER.pack(PACKET_PING_PONG, 0) + _PING.pack(int(ping_id))


def encode_sensor_info_ack(sensor: int, status: int) -> bytes:
    """Acknowledgement of a sensor-info packet (no packet number, as SlimeVR-Server sends it)."""
    return struct.pack(">IBB", PACKET_SENSOR_INFO, sensor & 0xFF, status & 0xFF)


def encode_feature_flags(flags: bytes = SERVER_FEATURES) -> bytes:
    """Server → tracker feature flags (answer to the tracker's)."""
    return _HEADER.pack(PACKET_FEATURE_FLAGS, 0) + bytes(flags)


def encode_tracker_packet(packet_type: int, number: int, payload: bytes) -> bytes:
    """A tracker → server datagram (used by tests and the frame check)."""
    return _HEADER.pack(packet_type, number) + payload


def supported_build(handshake: Handshake) -> str | None:
    """``None`` when the tracker's protocol is supported, otherwise why not (one line)."""
    if not handshake.firmware:
        return (f"tracker {handshake.mac_text} sent no firmware name (an owoTrack phone?); only "
                f"SlimeVR trackers of protocol builds {MIN_PROTOCOL_BUILD}-{MAX_PROTOCOL_BUILD} are supported")
    if not MIN_PROTOCOL_BUILD <= handshake.build <= MAX_PROTOCOL_BUILD:
        return (f"tracker {handshake.mac_text} (firmware {handshake.firmware!r}) speaks SlimeVR protocol "
                f"build {handshake.build}; MimuCap supports builds {MIN_PROTOCOL_BUILD}-{MAX_PROTOCOL_BUILD}")
    return None
