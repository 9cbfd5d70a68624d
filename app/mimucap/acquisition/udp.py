"""UDP driver: receives sensor-node datagrams, answers nothing, asks for the time and the hello.

Runs inside a worker process (see :mod:`mimucap.acquisition.worker`). It binds one socket,
decodes every datagram with :func:`~mimucap.acquisition.protocol_udp.decode_packet`, refuses
datagrams from addresses or sensor ids outside the session (counted), and sends each known
node a time-sync request every ``sync_interval_s``; the answers feed the node's
:class:`~mimucap.acquisition.timesync.ClockSync`. A node that has not said which device it is
gets a hello request with each of them (:mod:`mimucap.acquisition.hello`); its hello is reported
at once. Memory is bounded by the kernel receive buffer (``receive_buffer_bytes``), the block
size and the supervisor queue.
"""

from __future__ import annotations

import socket
import time
from dataclasses import dataclass, field
from threading import Event

from mimucap.acquisition import protocol_udp as proto
from mimucap.acquisition.datagram_socket import drain, open_datagram_socket
from mimucap.acquisition.hello import Hello, HelloRequest
from mimucap.acquisition.intake import IntakeSettings, SampleIntake
from mimucap.acquisition.messages import STATE_RUNNING
from mimucap.acquisition.outbox import Outbox
from mimucap.acquisition.rejections import Rejection
from mimucap.acquisition.samples import DEFAULT_LIMITS, RefusedSample, Sample, ValueLimits

#: Outstanding sync requests remembered per node (older ones are forgotten).
MAX_PENDING_SYNC = 16


@dataclass(frozen=True)
class UdpSourceConfig:
    """A UDP source (picklable; sent to the worker process)."""

    name: str = "udp"
    bind_address: str = "127.0.0.1"
    port: int = 5555
    allowed_addresses: tuple[str, ...] | None = None  #: sender IPs; ``None`` accepts any
    sync_interval_s: float = 0.2       #: s between time-sync requests to each node
    min_flush_spacing_s: float = 0.0005  #: s, at most one block message per this interval
    receive_buffer_bytes: int = 4 * 1024 * 1024
    report_interval_s: float = 0.5
    intake: IntakeSettings = field(default_factory=IntakeSettings)
    limits: ValueLimits = DEFAULT_LIMITS


class UdpDriver:
    """Receive loop of one UDP source; :meth:`run` returns when ``stop`` is set."""

    def __init__(self, config: UdpSourceConfig, outbox: Outbox) -> None:
        self.config = config
        self.outbox = outbox
        self.intake = SampleIntake(config.name, config.intake, outbox.send_blocks)
        self._allowed = None if config.allowed_addresses is None else frozenset(config.allowed_addresses)
        self._addresses: dict[int, tuple[str, int]] = {}
        self._pending_sync: dict[int, dict[int, int]] = {}
        self._next_request_id = 1
        self._next_sync_s = 0.0
        self.sock: socket.socket | None = None

    def open(self) -> None:
        self.sock = open_datagram_socket(self.config.bind_address, self.config.port,
                                         self.config.receive_buffer_bytes, self.config.name)

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
            self.sock = None

    def run(self, stop: Event) -> None:
        """Receive until ``stop`` is set.

        Each wake-up drains the socket (:func:`~mimucap.acquisition.datagram_socket.drain`:
        a bounded number of datagrams, each stamped with its own receive time); pending
        samples are flushed as soon as the socket is empty (at most every
        ``min_flush_spacing_s``) or, even in the middle of a long burst, when the oldest is
        ``flush_interval_s`` old.
        """
        if self.sock is None:
            self.open()
        sock = self.sock
        assert sock is not None
        intake = self.intake
        self.outbox.send_report(intake.report(STATE_RUNNING))
        last_flush = 0.0
        try:
            while not stop.is_set():
                now = time.monotonic()
                timeout = min(0.05, max(self._next_sync_s - now, 0.0))
                due = intake.flush_due_in(now)
                if due is not None:
                    timeout = min(timeout, max(due, 0.0))
                for data, address, received in drain(sock, proto.MAX_PACKET_BYTES + 1, timeout):
                    self.handle_datagram(data, address, received)
                    due = intake.flush_due_in(received)
                    if due is not None and due <= 0:    # a long burst: ship what waited
                        intake.flush()
                        last_flush = received
                now = time.monotonic()
                due = intake.flush_due_in(now)
                if due is not None and (due <= 0 or now - last_flush >= self.config.min_flush_spacing_s):
                    intake.flush()
                    last_flush = now
                if now >= self._next_sync_s:
                    self._send_sync_requests(now)
                    self._next_sync_s = now + self.config.sync_interval_s
                if self.outbox.report_due(now):
                    self.outbox.send_report(self.report(STATE_RUNNING))
        finally:
            intake.flush()
            self.close()

    def report(self, state: str, message: str = ""):
        """A cumulative report of this source (see :class:`~mimucap.acquisition.messages.WorkerReport`)."""
        return self.intake.report(state, message, self.outbox.overflow_samples)

    def handle_datagram(self, data: bytes, address: tuple, now: float) -> None:
        """Process one datagram received from ``address`` at host time ``now``."""
        host = address[0]
        if self._allowed is not None and host not in self._allowed:
            self.intake.count_unknown(f"address {host}", Rejection.UNKNOWN_ADDRESS)
            return
        message = proto.decode_packet(data, self.config.limits)
        if isinstance(message, Rejection):
            self.intake.reject(message)
        elif isinstance(message, RefusedSample):
            self.intake.refuse(message)
        elif isinstance(message, Sample):
            if self.intake.accept(message, now):
                if message.sensor_id not in self._addresses:
                    self._next_sync_s = 0.0      # a new node: ask for its time right away
                self._addresses[message.sensor_id] = address
        elif isinstance(message, proto.SyncResponse):
            self._handle_sync_response(message, now)
        elif isinstance(message, Hello):
            if self.intake.identify(message, now):
                self.outbox.send_report(self.report(STATE_RUNNING))   # the device is known: tell now
        else:
            self.intake.reject(Rejection.UNEXPECTED_MESSAGE)

    def _handle_sync_response(self, response: proto.SyncResponse, now: float) -> None:
        pending = self._pending_sync.get(response.sensor_id, {})
        sent_us = pending.pop(response.request_id, None)
        clock = self.intake.clock(response.sensor_id)
        if sent_us is None or clock is None or sent_us != response.host_send_us:
            self.intake.reject(Rejection.UNEXPECTED_MESSAGE, response.sensor_id)
            return
        clock.add_round_trip(sent_us * 1e-6, response.node_receive_us * 1e-6,
                             response.node_send_us * 1e-6, now)

    def _send_sync_requests(self, now: float) -> None:
        assert self.sock is not None
        for sensor_id, address in self._addresses.items():
            request_id = self._next_request_id
            self._next_request_id = (self._next_request_id + 1) % 2**32
            pending = self._pending_sync.setdefault(sensor_id, {})
            if len(pending) >= MAX_PENDING_SYNC:
                pending.pop(next(iter(pending)))
            send_us = int(time.monotonic() * 1e6)
            pending[request_id] = send_us
            packet = proto.encode_sync_request(proto.SyncRequest(sensor_id, request_id, send_us))
            try:
                self.sock.sendto(packet, address)
                if not self.intake.identified(sensor_id):
                    self.sock.sendto(proto.encode_hello_request(HelloRequest(sensor_id)), address)
            except OSError:
                pending.pop(request_id, None)
