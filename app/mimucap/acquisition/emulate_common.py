"""What the device emulators share: settings, the emulated clock, loss and jitter.

An emulated node's clock reads ``device_s = host_s · (1 + drift_ppm·1e-6) + offset_ms/1000``
where ``host_s`` is the host's monotonic clock (``time.monotonic()``, shared by every process
of the machine). Tests therefore know the true mapping and can check the time-sync estimate.

Motion comes from a :class:`MotionSource` (the simulated suit by default, see
:mod:`mimucap.acquisition.emulate_motion`): node ``i`` (wire id ``first_sensor_id + i``)
sends the motion source's sensor ``i mod n_sensors``.

Each emulated node is a device of its own: its MAC (:func:`node_mac`, a locally administered
address drawn from the random seed and the wire id) is what its hello says, unless ``hello`` is off
(nodes older than the hello, which send none).
"""

from __future__ import annotations

import hashlib
import heapq
import itertools
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from mimucap.acquisition.hello import Hello
from mimucap.acquisition.wire_sample import Sample


@dataclass(frozen=True)
class EmulatorSettings:
    """How the emulated nodes behave (defaults: a well-behaved 10-node suit at 100 Hz)."""

    n_sensors: int = 10
    rate_hz: float = 100.0
    loss: float = 0.0            #: probability that a sample is never sent (0..1)
    jitter_ms: float = 0.0       #: each sample leaves up to this many ms late (uniform)
    corrupt: float = 0.0         #: probability that a sent packet/line has one byte damaged (0..1)
    drift_ppm: float = 0.0       #: node clock rate error, ppm
    offset_ms: float = 0.0       #: node clock offset, ms (see the module docstring)
    duration_s: float | None = None  #: stop after this long (``None``: until stopped)
    seed: int = 0
    first_sensor_id: int = 1
    battery_pct: float = 90.0
    hello: bool = True           #: the nodes say hello with their MAC (off: older firmware)

    def __post_init__(self) -> None:
        if not 1 <= self.n_sensors <= 1024:
            raise ValueError(f"--sensors must be 1..1024, got {self.n_sensors}")
        if not 0 < self.rate_hz <= 2000:
            raise ValueError(f"--rate must be in (0, 2000] Hz, got {self.rate_hz}")
        if not 0.0 <= self.loss < 1.0:
            raise ValueError(f"--loss must be in [0, 1), got {self.loss}")
        if not 0.0 <= self.corrupt < 1.0:
            raise ValueError(f"--corrupt must be in [0, 1), got {self.corrupt}")
        if not 0.0 <= self.jitter_ms <= 10_000:
            raise ValueError(f"--jitter must be in [0, 10000] ms, got {self.jitter_ms}")
        if abs(self.drift_ppm) > 2000:   # the host's clock estimator accepts up to ±2000 ppm
            raise ValueError(f"--drift must be within ±2000 ppm, got {self.drift_ppm}")
        if self.duration_s is not None and not self.duration_s > 0:
            raise ValueError(f"--duration must be > 0 s, got {self.duration_s}")
        if self.first_sensor_id < 0 or self.first_sensor_id + self.n_sensors > 0xFFFF:
            raise ValueError("sensor ids must fit in 0..65534")

    def sensor_ids(self) -> list[int]:
        return [self.first_sensor_id + i for i in range(self.n_sensors)]

    def hellos(self) -> list[Hello]:
        """Each node's hello (none when :attr:`hello` is off)."""
        return [Hello(sensor_id, node_mac(self.seed, sensor_id)) for sensor_id in self.sensor_ids()] if self.hello else []


def node_mac(seed: int, sensor_id: int) -> bytes:
    """The MAC of emulated node ``sensor_id`` of the emulator seeded ``seed``: locally
    administered and unicast (first byte ``0x02``), the rest drawn from both, so that two
    emulators with other seeds are other devices under the same wire ids."""
    return b"\x02" + hashlib.sha256(f"mimucap-emulated-node/{int(seed)}/{int(sensor_id)}".encode()).digest()[:5]


class DeviceClock:
    """The emulated node clock (see the module docstring)."""

    def __init__(self, drift_ppm: float = 0.0, offset_ms: float = 0.0) -> None:
        self.rate = 1.0 + drift_ppm * 1e-6
        self.offset_s = offset_ms * 1e-3

    def device_from_host(self, host_s):
        return host_s * self.rate + self.offset_s


class Corrupter:
    """Damages one byte (never the line terminator) of a fraction of the messages."""

    def __init__(self, probability: float, seed: int) -> None:
        self.probability = probability
        self._rng = np.random.default_rng(seed + 7919)
        self.corrupted = 0

    def __call__(self, data: bytes, keep_tail: int = 0) -> bytes:
        if self.probability <= 0 or self._rng.random() >= self.probability:
            return data
        damaged = bytearray(data)
        position = int(self._rng.integers(0, len(damaged) - keep_tail))
        damaged[position] ^= int(self._rng.integers(1, 256))
        if keep_tail and damaged[position] in (0x0A, 0x0D):   # a new line break would split the line
            damaged[position] = ord("#")
        self.corrupted += 1
        return bytes(damaged)


class MotionSource(Protocol):
    """Per-sensor measurements, advanced one sample period at a time."""

    n_sensors: int

    def advance(self, n_samples: int) -> dict[str, np.ndarray]:
        """Next ``n_samples`` of every sensor: channel → ``(n_sensors, n_samples, k)`` array
        (``acc`` m/s², ``gyr`` rad/s, ``mag_uT`` µT, ``q_world_from_sensor`` w,x,y,z)."""


class NodeSchedule:
    """Turns motion into timed per-node samples with loss and jitter applied.

    :meth:`due` returns the samples of every tick up to ``now``; :meth:`pop_ready` the
    (possibly jittered) samples whose send time has come, in send-time order.
    """

    #: Samples are generated this far ahead of their send time (one motion call per chunk).
    LOOKAHEAD_S = 0.05

    def __init__(self, settings: EmulatorSettings, motion: MotionSource, start_host_s: float) -> None:
        self.settings = settings
        self.motion = motion
        self.clock = DeviceClock(settings.drift_ppm, settings.offset_ms)
        self.start_host_s = start_host_s
        self.period_s = 1.0 / settings.rate_hz
        self.ticks = 0
        self.sent = 0
        self.lost = 0
        self._rng = np.random.default_rng(settings.seed)
        self._queue: list[tuple[float, int, Sample]] = []
        self._order = itertools.count()
        self._ids = settings.sensor_ids()

    def next_tick_s(self) -> float:
        return self.start_host_s + self.ticks * self.period_s

    def finished(self, now_s: float) -> bool:
        end = self.settings.duration_s
        return end is not None and now_s >= self.start_host_s + end and not self._queue

    def generate_until(self, now_s: float) -> None:
        """Create the samples of every tick due before ``now_s`` + :attr:`LOOKAHEAD_S`, once
        the next tick is due (they are sent at their own times, see :meth:`pop_ready`)."""
        if now_s < self.next_tick_s():
            return
        due = int(np.floor((now_s + self.LOOKAHEAD_S - self.start_host_s) / self.period_s)) + 1
        if self.settings.duration_s is not None:
            due = min(due, int(round(self.settings.duration_s * self.settings.rate_hz)))
        count = due - self.ticks
        if count <= 0:
            return
        data = self.motion.advance(count)
        n_motion = self.motion.n_sensors
        lost = self._rng.random((self.settings.n_sensors, count)) < self.settings.loss
        delays = self._rng.random((self.settings.n_sensors, count)) * self.settings.jitter_ms * 1e-3
        for k in range(count):
            tick = self.ticks + k
            host_t = self.start_host_s + tick * self.period_s
            device_t = self.clock.device_from_host(host_t)
            for i, sensor_id in enumerate(self._ids):
                if lost[i, k]:
                    self.lost += 1
                    continue
                m = i % n_motion
                values = {name: tuple(float(v) for v in array[m, k]) for name, array in data.items()}
                sample = Sample(sensor_id=sensor_id, seq=tick, device_time_s=device_t,
                                calibration=(3, 3, 3, 3), battery_pct=self.settings.battery_pct,
                                **values)
                heapq.heappush(self._queue, (host_t + delays[i, k], next(self._order), sample))
        self.ticks = due

    def next_send_s(self) -> float | None:
        return self._queue[0][0] if self._queue else None

    def pop_ready(self, now_s: float) -> list[Sample]:
        ready = []
        while self._queue and self._queue[0][0] <= now_s:
            ready.append(heapq.heappop(self._queue)[2])
        self.sent += len(ready)
        return ready
