"""SlimeVR driver: a SlimeVR server for the trackers, MimuCap samples for the pipeline.

Runs inside a worker process (see :mod:`mimucap.acquisition.worker`). It binds one UDP
socket (port 6969 by default, where trackers look for a server), and speaks the protocol of
:mod:`mimucap.acquisition.slimevr_protocol` the way the trackers expect it:

* answers a handshake of a supported protocol build (others are refused with a message naming
  the build, counted as ``unsupported_version``), and the tracker's feature flags;
* acknowledges each sensor-info packet (a tracker resends it until acknowledged);
* sends every connected tracker a heartbeat and a ping every ``heartbeat_interval_s`` (a
  tracker that hears nothing from its server for 3 s goes looking for another one); the
  pong's round trip gives the network delay;
* reads rotation, battery, signal-strength and acceleration packets of every tracker and every
  sensor on it.

Each sensor of a tracker becomes one MimuCap sensor named ``"<MAC>-<sensor>"`` (the MAC as 12
hex digits, e.g. ``"A1B2C3D4E5F6-0"``), stable across reconnects, and is the device
``mac:<MAC>/<sensor>`` (:mod:`mimucap.core.device_identity`; a tracker whose handshake carries no
MAC is named by its address and has no device id). It is *orientation-only*: its
samples carry ``q_world_from_sensor`` (the tracker's on-board fusion, world ENU, see
:func:`~mimucap.acquisition.slimevr_protocol.q_world_from_slimevr`) and, once the tracker has
sent one, ``battery_pct``; no raw accelerometer, gyroscope or magnetometer. The acceleration
packets carry a gravity-free linear acceleration whose axes the protocol does not fix, so they
are decoded and checked but not passed on as ``acc`` (MimuCap's ``acc`` is specific force in
the sensor frame).

Times: the protocol carries no device clock. A sample's ``host_time_s`` is its arrival time less
the tracker's one-way network delay (half the last ping round trip), so the latency statistics
include the network; ``device_time_s`` is the same instant.

Drops: a tracker numbers every packet it sends since its handshake. Packet numbers missing on
arrival are lost packets of that tracker (whatever they carried), and each of its sensors
counts them: a sensor's sequence number is its rotation count plus its tracker's lost packets.
A packet number at or before the last one is refused (``stale_sequence``), except 0, which
SlimeVR-Server also takes as unnumbered (the firmware echoes the server's ping with it); a new
handshake starts the count again. Signal strength (dBm, per tracker or per sensor) travels in the
worker report (``signal_dbm``), not in the samples: it describes the radio link, not the body.
"""

from __future__ import annotations

import random
import socket
import sys
import time
from dataclasses import dataclass, field
from threading import Event

from mimucap.acquisition import slimevr_protocol as proto
from mimucap.acquisition.datagram_socket import drain, open_datagram_socket
from mimucap.acquisition.messages import STATE_RUNNING, BlocksMessage, WorkerReport
from mimucap.acquisition.outbox import Outbox
from mimucap.acquisition.rejections import Rejection, RejectionCounter
from mimucap.acquisition.samples import BlockBuilder, Sample, ValueLimits, DEFAULT_LIMITS, validate_sample
from mimucap.core.device_identity import SensorDevice, mac_device_id

#: Why the sensors of a tracker that sends no MAC have no device id.
NO_MAC = "its tracker's handshake carries no MAC"

#: Trackers served at most (a flood of handshakes with made-up MACs cannot grow the memory).
MAX_TRACKERS = 256
#: Distinct refused trackers remembered by name; beyond this they are lumped together.
MAX_TRACKED_REFUSED = 64


@dataclass(frozen=True)
class SlimeVrSourceConfig:
    """A SlimeVR source (picklable; sent to the worker process)."""

    name: str = "slimevr"
    bind_address: str = "0.0.0.0"
    port: int = proto.DEFAULT_PORT
    heartbeat_interval_s: float = 0.5   #: s between heartbeats (and pings) to each tracker
    flush_interval_s: float = 0.001     #: s, the oldest pending sample waits at most this long
    report_interval_s: float = 0.5
    receive_buffer_bytes: int = 4 * 1024 * 1024
    limits: ValueLimits = DEFAULT_LIMITS

    def __post_init__(self) -> None:
        if not 0 <= self.port < 65536:   # 0: a free port chosen by the system (tests)
            raise ValueError(f"SlimeVR source: bad port {self.port} (1..65535)")
        if self.heartbeat_interval_s <= 0 or self.flush_interval_s <= 0:
            raise ValueError("SlimeVR source: heartbeat_interval_s and flush_interval_s must be > 0")


class _Sensor:
    __slots__ = ("name", "index", "rotations", "rejections", "last_host_s")

    def __init__(self, name: str, index: int) -> None:
        self.name = name
        self.index = index
        self.rotations = 0
        self.rejections = RejectionCounter()
        self.last_host_s = float("-inf")


@dataclass
class _Tracker:
    mac: str
    address: tuple
    build: int
    last_number: int | None = None
    lost: int = 0
    handshakes: int = 1
    battery_pct: float | None = None
    one_way_delay_s: float = 0.0
    ping_id: int | None = None
    ping_sent_s: float = 0.0
    sensors: dict[int, _Sensor] = field(default_factory=dict)
    signal_dbm: dict[int, float] = field(default_factory=dict)   #: sensor (255 = all) → dBm


class SlimeVrDriver:
    """Server loop of one SlimeVR source; :meth:`run` returns when ``stop`` is set."""

    def __init__(self, config: SlimeVrSourceConfig, outbox: Outbox) -> None:
        self.config = config
        self.outbox = outbox
        self.sock: socket.socket | None = None
        self._trackers: dict[str, _Tracker] = {}          # MAC text → tracker
        self._by_address: dict[tuple, _Tracker] = {}
        self._builder = BlockBuilder(config.name)
        self.rejections = RejectionCounter()
        self.refused_trackers: dict[str, int] = {}        # "tracker MAC (build N)" → handshakes refused
        self.warning = ""
        self._next_heartbeat_s = 0.0
        self._sensor_count = 0
        self._random = random.Random()

    # ----------------------------------------------------------------- socket
    def open(self) -> None:
        try:
            self.sock = open_datagram_socket(self.config.bind_address, self.config.port,
                                             self.config.receive_buffer_bytes, "slimevr")
        except OSError as error:
            raise OSError(f"{error}; is a SlimeVR server already running on this port?") from None

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
            self.sock = None

    @property
    def address(self) -> tuple:
        assert self.sock is not None
        return self.sock.getsockname()

    def run(self, stop: Event) -> None:
        """Serve until ``stop`` is set."""
        if self.sock is None:
            self.open()
        sock = self.sock
        assert sock is not None
        self.outbox.send_report(self.report(STATE_RUNNING))
        try:
            while not stop.is_set():
                now = time.monotonic()
                timeout = min(0.05, max(self._next_heartbeat_s - now, 0.0))
                due = self._flush_due_in(now)
                if due is not None:
                    timeout = min(timeout, max(due, 0.0))
                for data, address, received in drain(sock, proto.MAX_DATAGRAM_BYTES + 1, timeout):
                    self.handle_datagram(data, address, received)
                now = time.monotonic()
                due = self._flush_due_in(now)
                if due is not None and due <= 0:
                    self.flush()
                if now >= self._next_heartbeat_s:
                    self._send_heartbeats(now)
                    self._next_heartbeat_s = now + self.config.heartbeat_interval_s
                if self.outbox.report_due(now):
                    self.outbox.send_report(self.report(STATE_RUNNING))
        finally:
            self.flush()
            self.close()

    def _send(self, packet: bytes, address: tuple) -> None:
        assert self.sock is not None
        try:
            self.sock.sendto(packet, address)
        except OSError:
            pass   # a tracker that went away; it is flagged stale by its silence

    def _send_heartbeats(self, now: float) -> None:
        for tracker in self._trackers.values():
            self._send(proto.encode_heartbeat(), tracker.address)
            tracker.ping_id = self._random.randrange(2**31)
            tracker.ping_sent_s = now
            self._send(proto.encode_ping(tracker.ping_id), tracker.address)

    # ----------------------------------------------------------------- packets
    def handle_datagram(self, data: bytes, address: tuple, now: float) -> None:
        """Process one datagram received from ``address`` at host time ``now`` (s)."""
        datagram = proto.decode_datagram(data)
        if isinstance(datagram, Rejection):
            self.rejections.add(datagram)
            return
        first = datagram.messages[0] if datagram.messages else None
        if isinstance(first, proto.Handshake):
            self._handshake(first, address, now)
            return
        tracker = self._by_address.get(address)
        if tracker is None:      # no handshake from there (yet): a tracker of an earlier server run
            self.rejections.add(Rejection.UNKNOWN_ADDRESS)
            return
        if datagram.number == 0 and tracker.last_number is not None:
            pass      # number 0 is unnumbered (the firmware echoes the server's ping as it came)
        elif tracker.last_number is not None and datagram.number <= tracker.last_number:
            self.rejections.add(Rejection.STALE_SEQUENCE)
            for sensor in tracker.sensors.values():
                sensor.rejections.add(Rejection.STALE_SEQUENCE)
            return
        else:
            if tracker.last_number is not None:
                tracker.lost += datagram.number - tracker.last_number - 1
            tracker.last_number = datagram.number
        for message in datagram.messages:
            self._message(tracker, message, address, now)

    def _handshake(self, handshake: proto.Handshake, address: tuple, now: float) -> None:
        why = proto.supported_build(handshake)
        if why is not None:
            self.rejections.add(Rejection.UNSUPPORTED_VERSION)
            key = f"tracker {handshake.mac_text} (build {handshake.build})"
            if key not in self.refused_trackers and len(self.refused_trackers) >= MAX_TRACKED_REFUSED:
                key = "other"
            if key not in self.refused_trackers:
                print(f"mimucap slimevr: refused {why}", file=sys.stderr, flush=True)
            self.refused_trackers[key] = self.refused_trackers.get(key, 0) + 1
            self.warning = f"refused {why}"
            return
        mac = handshake.mac.hex().upper() if any(handshake.mac) else f"{address[0]}:{address[1]}"
        tracker = self._trackers.get(mac)
        if tracker is None and len(self._trackers) >= MAX_TRACKERS:   # memory stays bounded
            self.rejections.add(Rejection.UNKNOWN_SENSOR)
            return
        if tracker is None:
            tracker = self._trackers[mac] = _Tracker(mac, address, handshake.build)
        else:                    # the same tracker again (rebooted or reconnected, maybe moved)
            self._by_address.pop(tracker.address, None)
            tracker.address = address
            tracker.build = handshake.build
            tracker.handshakes += 1
        tracker.last_number = None       # a handshake starts the packet numbers again
        self._by_address[address] = tracker
        self._send(proto.encode_handshake_reply(), address)
        self._next_heartbeat_s = 0.0     # a new tracker: heartbeat and ping it right away

    def _sensor(self, tracker: _Tracker, sensor_id: int) -> _Sensor:
        sensor = tracker.sensors.get(sensor_id)
        if sensor is None:
            sensor = tracker.sensors[sensor_id] = _Sensor(f"{tracker.mac}-{sensor_id}", self._sensor_count)
            self._sensor_count += 1
        return sensor

    def _message(self, tracker: _Tracker, message, address: tuple, now: float) -> None:
        if isinstance(message, Rejection):
            self.rejections.add(message)
        elif isinstance(message, proto.Rotation):
            self._rotation(tracker, message, now)
        elif isinstance(message, proto.SensorInfo):
            self._sensor(tracker, message.sensor)
            self._send(proto.encode_sensor_info_ack(message.sensor, message.status), address)
        elif isinstance(message, proto.Battery):
            if 0.0 <= message.fraction <= 1.0:
                tracker.battery_pct = 100.0 * message.fraction
            else:
                self.rejections.add(Rejection.OUT_OF_RANGE)
        elif isinstance(message, proto.Signal):
            tracker.signal_dbm[message.sensor] = float(message.dbm)
        elif isinstance(message, proto.Pong):
            if message.ping_id == tracker.ping_id:
                tracker.one_way_delay_s = max(now - tracker.ping_sent_s, 0.0) / 2.0
                tracker.ping_id = None
        elif isinstance(message, proto.FeatureFlags):
            self._send(proto.encode_feature_flags(), address)
        elif isinstance(message, (proto.Acceleration, proto.Ignored, proto.Heartbeat)):
            pass             # read and checked; nothing MimuCap uses (see the module docstring)
        else:        # a handshake inside a bundle, or anything unforeseen
            self.rejections.add(Rejection.UNEXPECTED_MESSAGE)

    def _rotation(self, tracker: _Tracker, rotation: proto.Rotation, now: float) -> None:
        sensor = self._sensor(tracker, rotation.sensor)
        if rotation.kind != proto.ROTATION_NORMAL:   # magnetometer correction data: unused
            return
        host_s = now - tracker.one_way_delay_s
        if host_s <= sensor.last_host_s:
            host_s = sensor.last_host_s + 1e-6
        sample = Sample(sensor_id=sensor.index, seq=sensor.rotations + tracker.lost, device_time_s=host_s,
                        q_world_from_sensor=proto.q_world_from_slimevr(rotation.q_xyzw),
                        battery_pct=tracker.battery_pct)
        checked = validate_sample(sample, self.config.limits)
        if isinstance(checked, Rejection):
            self.rejections.add(checked)
            sensor.rejections.add(checked)
            return
        sensor.rotations += 1
        sensor.last_host_s = host_s
        self._builder.add(sensor.name, checked.seq, checked, host_s, now)

    # ----------------------------------------------------------------- blocks and reports
    def _flush_due_in(self, now: float) -> float | None:
        oldest = self._builder.oldest_receive_time_s
        return None if oldest is None else oldest + self.config.flush_interval_s - now

    def flush(self) -> None:
        """Send every pending sample now."""
        if len(self._builder):
            self.outbox.send_blocks(BlocksMessage(self.config.name, tuple(self._builder.take())))

    def signal_dbm(self) -> dict[str, float]:
        """Sensor name → the last signal strength (dBm) of its tracker's radio link."""
        out = {}
        for tracker in self._trackers.values():
            for sensor_id, sensor in tracker.sensors.items():
                value = tracker.signal_dbm.get(sensor_id, tracker.signal_dbm.get(proto.ALL_SENSORS))
                if value is not None:
                    out[sensor.name] = value
        return out

    def devices(self) -> dict[str, SensorDevice]:
        """Sensor name → its device: sensor ``n`` of the tracker's MAC."""
        out = {}
        for tracker in self._trackers.values():
            for sensor_id, sensor in tracker.sensors.items():
                try:
                    out[sensor.name] = SensorDevice(mac_device_id(tracker.mac, sensor_id))
                except ValueError:     # named by its address: the handshake had no MAC
                    out[sensor.name] = SensorDevice(None, NO_MAC)
        return out

    def report(self, state: str, message: str = "") -> WorkerReport:
        """A cumulative report of this source (see :class:`~mimucap.acquisition.messages.WorkerReport`)."""
        by_sensor = {}
        for tracker in self._trackers.values():
            for sensor in tracker.sensors.values():
                if sensor.rejections.total():
                    by_sensor[sensor.name] = sensor.rejections.as_dict()
        rejections = self.rejections.as_dict()
        overflow = self.outbox.overflow_samples
        if overflow:
            rejections[Rejection.QUEUE_OVERFLOW.value] = overflow
        restarts = {s.name: t.handshakes - 1 for t in self._trackers.values() for s in t.sensors.values()
                    if t.handshakes > 1}
        return WorkerReport(self.config.name, state, message, rejections,
                            dict(self.refused_trackers), by_sensor, {}, overflow, 0, restarts,
                            signal_dbm=self.signal_dbm(), warning=self.warning, devices=self.devices())
