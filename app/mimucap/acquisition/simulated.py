"""Simulated driver: the simulated suit (:class:`mimucap.core.simulate.suit.SuitSimulator`) in real time.

Runs inside a worker process like a device driver. Every ``block_interval_s`` it advances
the simulator to the time elapsed since the start and sends the new samples as blocks: the
host time of sample ``k`` is ``start + k / rate_hz`` (the simulator's true time on the host
clock), ``device_time_s`` is the simulated node clock, ``seq`` the simulator's sample number
(samples the error model drops leave gaps, counted as drops like real ones).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from threading import Event

import numpy as np

from mimucap.acquisition.messages import STATE_RUNNING, BlocksMessage, WorkerReport
from mimucap.acquisition.outbox import Outbox
from mimucap.core.device_identity import SensorDevice
from mimucap.core.samples import SensorSamples
from mimucap.core.simulate.config import SimulationConfig, default_assignment
from mimucap.core.simulate.suit import SuitSimulator

DEFAULT_SENSORS = 10
DEFAULT_RATE_HZ = 100.0


@dataclass(frozen=True)
class SimulatedSourceConfig:
    """A simulated source (picklable). ``None`` means the simulator's default."""

    name: str = "simulated"
    scenario: str = "demo"
    n_sensors: int | None = None
    rate_hz: float | None = None
    seed: int = 0
    errors: str = "default"            #: the simulator's error-model preset
    room: str = "clean"                #: the simulator's room (:mod:`mimucap.core.simulate.rooms`)
    duration_s: float | None = None    #: end by itself after this long (``None``: until stopped)
    block_interval_s: float = 0.04     #: s of host time between blocks
    report_interval_s: float = 0.5

    def __post_init__(self) -> None:
        self.simulation_config()  # a bad scenario, sensor count or rate fails here, in the caller

    def simulation_config(self) -> SimulationConfig:
        return SimulationConfig(scenario=self.scenario, duration_s=0.0,
                                n_sensors=self.n_sensors or DEFAULT_SENSORS,
                                rate_hz=self.rate_hz or DEFAULT_RATE_HZ, seed=self.seed,
                                errors=self.errors, room=self.room)

    def sensor_segments(self) -> dict[str, str]:
        """Sensor id → the segment it drives as the suit comes (one sensor per segment)."""
        return default_assignment(self.simulation_config().sensor_ids)


class SimulatedDriver:
    def __init__(self, config: SimulatedSourceConfig, outbox: Outbox) -> None:
        self.config = config
        self.outbox = outbox
        self.simulator = SuitSimulator(config.simulation_config())
        self.sent = 0

    def report(self, state: str, message: str = "") -> WorkerReport:
        devices = {sid: SensorDevice(device_id) for sid, device_id in self.simulator.device_ids.items()}
        return WorkerReport(self.config.name, state, message, overflow_samples=self.outbox.overflow_samples,
                            devices=devices)

    def run(self, stop: Event) -> None:
        start = time.monotonic()
        self.outbox.send_report(self.report(STATE_RUNNING, f"scenario {self.config.scenario}, room {self.config.room}"))
        end = None if self.config.duration_s is None else start + self.config.duration_s
        while not stop.is_set():
            now = time.monotonic()
            horizon = (now if end is None else min(now, end)) - start
            due = int(np.floor(horizon * self.simulator.rate_hz)) + 1   # samples k/rate <= horizon
            block = self.simulator.advance_samples(max(due - int(round(self.simulator.time_s * self.simulator.rate_hz)), 0))
            blocks = []
            for sensor_id, samples in block.samples.items():
                if len(samples.t_s) == 0:
                    continue
                blocks.append(SensorSamples(
                    sensor_id, start + samples.t_s, samples.seq.astype(np.int64), samples.acc, samples.gyr,
                    samples.mag_uT, samples.q_world_from_sensor, device_time_s=samples.device_time_s,
                    receive_time_s=np.full(len(samples.t_s), now), source=self.config.name))
            markers = tuple((start + t, label) for t, label in block.markers)
            if blocks or markers:
                self.sent += sum(len(b) for b in blocks)
                self.outbox.send_blocks(BlocksMessage(self.config.name, tuple(blocks), markers))
            if end is not None and now >= end:
                return
            if self.outbox.report_due(now):
                self.outbox.send_report(self.report(STATE_RUNNING, f"scenario {self.config.scenario}, room {self.config.room}"))
            stop.wait(self.config.block_interval_s)
