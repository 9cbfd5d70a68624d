"""UDP device emulator: N sensor nodes that speak the UDP protocol from one socket.

Sends one datagram per sample and node to ``target`` (loopback in tests), answers
time-sync requests with the emulated clock (see :mod:`mimucap.acquisition.emulate_common`),
says each node's hello when it starts and when asked (unless the settings emulate nodes older
than the hello) and misbehaves on demand: ``loss`` drops samples (their sequence numbers are skipped),
``corrupt`` damages one byte of some datagrams (the host refuses them: ``bad_checksum``),
``jitter_ms`` delays them, ``drift_ppm``/``offset_ms`` skew the node clock. The loop stops
by itself after ``duration_s`` or when ``stop`` is set.
"""

from __future__ import annotations

import select
import socket
import time
from dataclasses import replace
from threading import Event

from mimucap.acquisition import protocol_udp as proto
from mimucap.acquisition.emulate_common import Corrupter, EmulatorSettings, MotionSource, NodeSchedule
from mimucap.acquisition.hello import HelloRequest


def resolve_target(target: tuple[str, int]) -> tuple[str, int]:
    """``(IPv4 address, port)`` of ``target`` (host name or address, port), resolved once;
    ``ValueError`` naming the host when it cannot be resolved (every send would fail)."""
    host, port = target
    try:
        info = socket.getaddrinfo(host, port, socket.AF_INET, socket.SOCK_DGRAM)
    except (socket.gaierror, UnicodeError) as error:
        reason = error.strerror if isinstance(error, socket.gaierror) else str(error)
        raise ValueError(f"--target {host}:{port}: cannot resolve host {host!r} ({reason})") from None
    return info[0][4][0], port


class UdpEmulator:
    """N emulated nodes; :meth:`run` sends until the duration is over or ``stop`` is set."""

    def __init__(self, settings: EmulatorSettings, target: tuple[str, int], motion: MotionSource,
                 bind_address: str = "127.0.0.1", stamp_on_send: bool = False) -> None:
        """``stamp_on_send``: stamp each sample with the node clock at the moment it is sent
        (instead of its nominal sampling instant), so send→arrival latency can be measured."""
        self.settings = settings
        self.stamp_on_send = stamp_on_send
        self.target = resolve_target(target)
        self.motion = motion
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((bind_address, 0))
        self.sock.setblocking(False)
        self.schedule: NodeSchedule | None = None
        self.corrupt = Corrupter(settings.corrupt, settings.seed)
        self.sync_answered = 0
        self.send_errors = 0
        self._ids = frozenset(settings.sensor_ids())

    @property
    def address(self) -> tuple[str, int]:
        return self.sock.getsockname()

    def run(self, stop: Event | None = None) -> NodeSchedule:
        start = time.monotonic()
        schedule = self.schedule = NodeSchedule(self.settings, self.motion, start)
        try:
            for hello in self.settings.hellos():      # a node says hello when it starts
                self._send(proto.encode_hello(hello, self._node_time_us()), self.target)
            while not (stop is not None and stop.is_set()):
                now = time.monotonic()
                schedule.generate_until(now)
                for sample in schedule.pop_ready(now):
                    if self.stamp_on_send:
                        sample = replace(sample, device_time_s=schedule.clock.device_from_host(time.monotonic()))
                    try:
                        self.sock.sendto(self.corrupt(proto.encode_sample(sample)), self.target)
                    except OSError:  # receiver not there yet (ICMP refused) or buffer full
                        self.send_errors += 1
                if schedule.finished(now):
                    break
                wake = schedule.next_tick_s()
                next_send = schedule.next_send_s()
                if next_send is not None:
                    wake = min(wake, next_send)
                readable, _, _ = select.select([self.sock], [], [], max(0.0, min(wake - time.monotonic(), 0.05)))
                if readable:
                    self._answer_requests()
        finally:
            self.sock.close()
        return schedule

    def _node_time_us(self) -> int:
        clock = self.schedule.clock
        return int(round(clock.device_from_host(time.monotonic()) * 1e6))

    def _send(self, packet: bytes, address: tuple[str, int]) -> None:
        try:
            self.sock.sendto(packet, address)
        except OSError:
            self.send_errors += 1

    def _answer_requests(self) -> None:
        assert self.schedule is not None
        clock = self.schedule.clock
        for _ in range(256):
            try:
                data, address = self.sock.recvfrom(proto.MAX_PACKET_BYTES + 1)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                continue
            received = clock.device_from_host(time.monotonic())
            request = proto.decode_packet(data)
            if isinstance(request, HelloRequest):
                for hello in self.settings.hellos():
                    if request.target_id in (hello.sensor_id, proto.BROADCAST_ID):
                        self._send(proto.encode_hello(hello, self._node_time_us()), address)
                continue
            if not isinstance(request, proto.SyncRequest):
                continue
            targets = self._ids if request.target_id == proto.BROADCAST_ID else (
                {request.target_id} & self._ids)
            for sensor_id in sorted(targets):
                response = proto.SyncResponse(
                    sensor_id, request.request_id, request.host_send_us,
                    int(round(received * 1e6)),
                    int(round(clock.device_from_host(time.monotonic()) * 1e6)))
                try:
                    self.sock.sendto(proto.encode_sync_response(response), address)
                    self.sync_answered += 1
                except OSError:
                    self.send_errors += 1
