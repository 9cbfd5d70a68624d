"""Serial device emulator: N sensors multiplexed on one pseudo-terminal, like a radio receiver.

Opens a pty pair (``os.openpty``), puts it in raw mode and writes one protocol line per
sample to the master side; the host opens the slave side (:attr:`device_path`) with
pyserial. With ``link`` set, a symbolic link at that path points to the current slave, and
:meth:`unplug` / :meth:`replug` emulate pulling the cable: the link disappears and the master
is closed (the host's reads fail), then a new pty appears behind the same link path.
Lines the host does not read fast enough are discarded when the pty buffer is full (counted
in ``overflow``), as a real UART would. ``corrupt`` damages one byte of some lines. Each node
writes its hello line when it starts and every
:data:`~mimucap.acquisition.hello.SERIAL_HELLO_PERIOD_S` (unless the settings emulate nodes
older than the hello). Clock, loss and jitter as in
:mod:`mimucap.acquisition.emulate_common`.
"""

from __future__ import annotations

import os
import time
import tty
from pathlib import Path
from threading import Event, Lock

from mimucap.acquisition import protocol_serial as proto
from mimucap.acquisition.emulate_common import Corrupter, EmulatorSettings, MotionSource, NodeSchedule
from mimucap.acquisition.hello import SERIAL_HELLO_PERIOD_S


class SerialEmulator:
    """Emulated serial board(s) on a pty; :meth:`run` writes until done or ``stop`` is set."""

    def __init__(self, settings: EmulatorSettings, motion: MotionSource,
                 link: str | os.PathLike[str] | None = None) -> None:
        self.settings = settings
        self.motion = motion
        self.link = None if link is None else Path(link)
        #: where the next link is made before it replaces :attr:`link` in one step
        self._new_link = None if link is None else self.link.with_name(self.link.name + ".new")
        if self.link is not None:
            for path in (self.link, self._new_link):
                if path.exists() and not path.is_symlink():  # a link is replaced; a file never
                    raise ValueError(f"--link {path} exists and is not a symbolic link; choose another path")
        self._lock = Lock()
        self.master_fd: int | None = None
        self.slave_fd: int | None = None
        self.slave_path = ""
        self.plugged = False
        self.overflow = 0
        self.unplugged_samples = 0
        self.corrupt = Corrupter(settings.corrupt, settings.seed)
        self.schedule: NodeSchedule | None = None
        self.replug()

    @property
    def device_path(self) -> str:
        """The path the host should open (the link when set, else the pty slave)."""
        return str(self.link) if self.link is not None else self.slave_path

    def replug(self) -> None:
        """Create a fresh pty pair (and point the link at it)."""
        with self._lock:
            if self.plugged:
                return
            master, slave = os.openpty()
            tty.setraw(slave)
            os.set_blocking(master, False)
            self.master_fd, self.slave_fd = master, slave
            self.slave_path = os.ttyname(slave)
            if self.link is not None:
                if self._new_link.is_symlink():
                    self._new_link.unlink()
                os.symlink(self.slave_path, self._new_link)
                os.replace(self._new_link, self.link)
            self.plugged = True

    def unplug(self) -> None:
        """Remove the link and close the pty (the host sees the device vanish)."""
        with self._lock:
            if not self.plugged:
                return
            if self.link is not None and self.link.is_symlink():
                self.link.unlink()
            for fd in (self.master_fd, self.slave_fd):
                if fd is not None:
                    os.close(fd)
            self.master_fd = self.slave_fd = None
            self.plugged = False

    def close(self) -> None:
        self.unplug()

    def _write(self, data: bytes) -> None:
        with self._lock:
            if not self.plugged or self.master_fd is None:
                self.unplugged_samples += 1
                return
            try:
                written = os.write(self.master_fd, data)
                if written != len(data):
                    self.overflow += 1
            except BlockingIOError:
                self.overflow += 1
            except OSError:
                self.overflow += 1

    def run(self, stop: Event | None = None) -> NodeSchedule:
        schedule = self.schedule = NodeSchedule(self.settings, self.motion, time.monotonic())
        next_hello_s = schedule.start_host_s
        while not (stop is not None and stop.is_set()):
            now = time.monotonic()
            if now >= next_hello_s:
                for hello in self.settings.hellos():
                    self._write(proto.encode_hello_line(hello))
                next_hello_s = now + SERIAL_HELLO_PERIOD_S
            schedule.generate_until(now)
            for sample in schedule.pop_ready(now):
                self._write(self.corrupt(proto.encode_line(sample), keep_tail=2))
            if schedule.finished(now):
                break
            wake = schedule.next_tick_s()
            next_send = schedule.next_send_s()
            if next_send is not None:
                wake = min(wake, next_send)
            delay = min(max(wake - time.monotonic(), 0.0), 0.05)
            if stop is not None:
                stop.wait(delay)
            else:
                time.sleep(delay)
        return schedule
