"""Serial driver: reads text lines from a board or radio receiver with pyserial.

Runs inside a worker process. Each line is decoded with
:func:`~mimucap.acquisition.protocol_serial.parse_line`; the node clock is mapped with
one-way timestamps (see :mod:`mimucap.acquisition.timesync`); a node's hello line says which
device its sensor is (:mod:`mimucap.acquisition.hello`). When the device disappears
(unplugged: the read fails or the path is gone) the driver reports ``disconnected``, closes
the port and tries to reopen the same path every ``reconnect_interval_s`` until it is back;
the partial line at the moment of the unplug is discarded and counted.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from threading import Event

import serial

from mimucap.acquisition import protocol_serial as proto
from mimucap.acquisition.hello import Hello
from mimucap.acquisition.intake import IntakeSettings, SampleIntake
from mimucap.acquisition.messages import STATE_DISCONNECTED, STATE_RUNNING, STATE_STARTING
from mimucap.acquisition.outbox import Outbox
from mimucap.acquisition.rejections import Rejection
from mimucap.acquisition.samples import DEFAULT_LIMITS, RefusedSample, Sample, ValueLimits

READ_CHUNK_BYTES = 4096


@dataclass(frozen=True)
class SerialSourceConfig:
    """A serial source (picklable; sent to the worker process)."""

    name: str = "serial"
    device: str = "/dev/ttyUSB0"
    baud: int = 115200
    reconnect_interval_s: float = 0.2   #: s between attempts to reopen a vanished device
    read_timeout_s: float = 0.01
    report_interval_s: float = 0.5
    intake: IntakeSettings = field(default_factory=IntakeSettings)
    limits: ValueLimits = DEFAULT_LIMITS


class SerialDriver:
    """Read loop of one serial source; :meth:`run` returns when ``stop`` is set."""

    def __init__(self, config: SerialSourceConfig, outbox: Outbox) -> None:
        self.config = config
        self.outbox = outbox
        self.intake = SampleIntake(config.name, config.intake, outbox.send_blocks)
        self.port: serial.Serial | None = None
        self._buffer = bytearray()
        self._discarding = False   # inside an oversized line: skip up to its end
        self.reconnects = 0
        self.state = STATE_STARTING
        self.message = ""

    def _open(self) -> bool:
        try:
            self.port = serial.Serial(self.config.device, self.config.baud,
                                      timeout=self.config.read_timeout_s)
        except (serial.SerialException, OSError, ValueError) as error:
            self.port = None
            self.message = f"cannot open {self.config.device}: {error}"
            return False
        self._buffer.clear()
        return True

    def _close(self) -> None:
        if self.port is not None:
            try:
                self.port.close()
            except (serial.SerialException, OSError):
                pass
            self.port = None
        if self._buffer and not self._discarding:
            self.intake.reject(Rejection.MALFORMED_LINE)  # the torn line of the unplug
        self._buffer.clear()
        self._discarding = False

    def _set_state(self, state: str, message: str = "") -> None:
        changed = state != self.state
        self.state, self.message = state, message
        if changed:
            self.outbox.send_report(self.report(state, message))

    def report(self, state: str, message: str = ""):
        return self.intake.report(state, message, self.outbox.overflow_samples, self.reconnects)

    def run(self, stop: Event) -> None:
        ever_connected = False
        try:
            while not stop.is_set():
                if self.port is None:
                    if not self._open():
                        self._set_state(STATE_DISCONNECTED, self.message)
                        stop.wait(self.config.reconnect_interval_s)
                        continue
                    if ever_connected:
                        self.reconnects += 1
                    ever_connected = True
                    self._set_state(STATE_RUNNING, f"reading {self.config.device}")
                try:
                    waiting = self.port.in_waiting
                    data = self.port.read(min(max(waiting, 1), READ_CHUNK_BYTES))
                except (serial.SerialException, OSError) as error:
                    self.intake.flush()
                    self._close()
                    self._set_state(STATE_DISCONNECTED, f"{self.config.device} lost: {error}")
                    continue
                now = time.monotonic()
                if data:
                    self.handle_bytes(data, now)
                self.intake.flush_if_due(now)
                if self.outbox.report_due(now):
                    self.outbox.send_report(self.report(self.state, self.message))
        finally:
            self.intake.flush()
            self._close()

    def handle_bytes(self, data: bytes, now: float) -> None:
        """Split ``data`` into lines and process each complete one (received at ``now``)."""
        self._buffer += data
        while True:
            end = self._buffer.find(b"\n")
            if end < 0:
                break
            line = bytes(self._buffer[: end + 1])
            del self._buffer[: end + 1]
            if self._discarding:          # the tail of an oversized line, already counted
                self._discarding = False
                continue
            self.handle_line(line, now)
        if len(self._buffer) > proto.MAX_LINE_BYTES:
            if not self._discarding:
                self.intake.reject(Rejection.OVERSIZED)
            self._discarding = True
            self._buffer.clear()

    def handle_line(self, line: bytes, now: float) -> None:
        if not line.strip():
            return
        result = proto.parse_line(line, self.config.limits)
        if isinstance(result, Sample):
            self.intake.accept(result, now)
        elif isinstance(result, Hello):
            if self.intake.identify(result, now):
                self.outbox.send_report(self.report(self.state, self.message))   # the device is known: tell now
        elif isinstance(result, RefusedSample):
            self.intake.refuse(result)
        else:
            self.intake.reject(result)
