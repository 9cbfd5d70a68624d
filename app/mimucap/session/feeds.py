"""Where live sample blocks come from: the simulated suit in process, or acquisition workers.

A feed hands out lists of :class:`~mimucap.core.samples.SensorSamples` on the host's
monotonic clock (``time.monotonic()``, s) and per-sensor statistics. Both feeds give the
same blocks, so the rest of the live pipeline (fusion, calibration, recording) does not care
which one runs:

* :class:`SimulatorFeed` runs :class:`~mimucap.core.simulate.suit.SuitSimulator` in this process,
  advanced by the clock each :meth:`poll` (like the simulated acquisition driver); its
  subject follows the calibration procedures' instructions (:meth:`SimulatorFeed.follow`) and
  its true state (``feed.last_truth``) is kept for evaluation only;
* :class:`SupervisorFeed` runs any source spec (``udp:``, ``serial:``, ``replay:``,
  ``simulated:``) in acquisition worker processes through
  :class:`~mimucap.acquisition.supervisor.Supervisor`, polled without blocking.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Protocol

import numpy as np

from mimucap.acquisition.messages import STATE_DISCONNECTED, STATE_FAILED
from mimucap.acquisition.stats import SensorStats, SensorStatsTracker
from mimucap.acquisition.supervisor import Supervisor
from mimucap.core.device_identity import SensorDevice
from mimucap.core.samples import SensorSamples
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import SuitSimulator
from mimucap.core.simulate.truth import SuitTruth
from mimucap.session import instructions
from mimucap.session.instructions import Instruction
from mimucap.session.sources import SourceOptions, sensor_segments, source_configs

class LiveSource(Protocol):
    """What the live session needs of a source (both feeds below are one)."""

    name: str
    simulator: SuitSimulator | None      #: the simulated subject (evaluation only), or None
    last_truth: SuitTruth | None         #: the simulator's newest truth (evaluation only), or None

    @property
    def sensor_ids(self) -> tuple[str, ...]: ...

    def sensor_segments(self) -> dict[str, str]:
        """Sensor id → segment, as the source names it."""

    def start(self) -> None: ...

    def poll(self) -> list[SensorSamples]:
        """The sample blocks that arrived since the last call (never blocks)."""

    def stats(self) -> dict[str, SensorStats]: ...

    def signal_dbm(self) -> dict[str, float]:
        """Sensor id → strength of its radio link (dBm), for the sensors whose source reports it."""

    def devices(self) -> dict[str, SensorDevice]:
        """Sensor id → what the source says of its device
        (:class:`~mimucap.core.device_identity.SensorDevice`), for the sensors it has told of."""

    def refused_without_sensor(self) -> tuple[dict[str, int], dict[str, int]]:
        """Refused inputs that belong to no known sensor: (reason → count, sender → count)."""

    def follow(self, instruction: Instruction) -> None:
        """A calibration procedure's instruction (the simulated subject does it)."""

    def status_text(self) -> str: ...

    def problem(self) -> str: ...

    def stop(self) -> list[SensorSamples]: ...


#: Longest clock gap (s) the simulator catches up in one poll: after a longer stall the
#: samples before that are lost (a dropout) instead of computed as a long backlog on the GUI thread.
MAX_CATCH_UP_S = 1.0
#: Window (s) over which sensor rates are computed.
STATS_WINDOW_S = 2.0


class SimulatorFeed:
    """The simulated suit, in this process, on ``clock`` (real time, or a faster clock in tests:
    every part of the session reads the same clock).

    Args:
        config: the simulation (scenario, sensors, rate, error model, seed, height).
        clock: monotonic clock (s); tests pass a fake one.
        name: the source name carried by the blocks.
        simulator: an existing simulator of ``config`` to run (a new one by default).
    """

    kind = "simulated"

    def __init__(self, config: SimulationConfig = SimulationConfig(), clock: Callable[[], float] = time.monotonic,
                 name: str = "simulated", simulator: SuitSimulator | None = None) -> None:
        self.config = config
        self.simulator = simulator if simulator is not None else SuitSimulator(config)
        self.name = name
        self._clock = clock
        self._start_host_s: float | None = None
        self._last_poll: float | None = None
        self._trackers = {sid: SensorStatsTracker(sid, name, STATS_WINDOW_S) for sid in self.simulator.sensor_ids}
        self._devices = {sid: SensorDevice(device_id) for sid, device_id in self.simulator.device_ids.items()}
        #: truth of the newest simulated sample (segment orientations, root), or None
        self.last_truth: SuitTruth | None = None

    @property
    def sensor_ids(self) -> tuple[str, ...]:
        return tuple(self.simulator.sensor_ids)

    def sensor_segments(self) -> dict[str, str]:
        """Sensor id → the segment it drives as the suit comes (one sensor per segment,
        :func:`~mimucap.core.simulate.default_assignment`)."""
        return dict(self.simulator.assignment)

    def start(self) -> None:
        now = self._clock()
        self._start_host_s = now
        self._last_poll = now

    def host_time_of(self, t_sim_s: float | np.ndarray) -> float | np.ndarray:
        """Host monotonic time (s) of simulated time ``t_sim_s`` (s, a number or an array)."""
        return self._start_host_s + t_sim_s

    def poll(self) -> list[SensorSamples]:
        """Blocks of every sample simulated since the last poll (one block per sensor)."""
        if self._start_host_s is None:
            raise ValueError("the simulated source is not started")
        now = self._clock()
        gap = now - self._last_poll
        if gap > MAX_CATCH_UP_S:
            # The samples of the stall are lost, as a radio link loses them: the subject moved
            # on meanwhile (the clock and the samples' times stay one).
            lost_until = now - MAX_CATCH_UP_S - self._start_host_s
            due = int(np.floor(lost_until * self.simulator.rate_hz + 1e-9))
            self.simulator.skip_samples(max(due - int(round(self.simulator.time_s * self.simulator.rate_hz)), 0))
        self._last_poll = now
        target_sim_s = now - self._start_host_s
        return self.advance_to(target_sim_s, now)

    def advance_to(self, target_sim_s: float, arrival_s: float | None = None) -> list[SensorSamples]:
        """Simulate up to simulated time ``target_sim_s`` (s) and return the new blocks."""
        rate = self.simulator.rate_hz
        due = int(np.floor(target_sim_s * rate + 1e-9)) + 1
        done = int(round(self.simulator.time_s * rate))
        if due <= done:
            return []
        block = self.simulator.advance_samples(due - done)
        arrival = self._clock() if arrival_s is None else arrival_s
        blocks = []
        for sensor_id, samples in block.samples.items():
            if len(samples.t_s) == 0:
                continue
            host = self.host_time_of(samples.t_s)
            out = SensorSamples(
                sensor_id, host, samples.seq.astype(np.int64), samples.acc, samples.gyr, samples.mag_uT,
                samples.q_world_from_sensor, device_time_s=samples.device_time_s,
                receive_time_s=np.full(len(samples.t_s), arrival), source=self.name)
            self._trackers[sensor_id].add_block(out, arrival)
            blocks.append(out)
        if block.truth.t_s.shape[0]:
            self.last_truth = block.truth
        return blocks

    def follow(self, instruction: Instruction) -> None:
        """The simulated subject does what ``instruction`` asks (:func:`simulated_subject_follows`)."""
        simulated_subject_follows(self.simulator, instruction)

    def stats(self) -> dict[str, SensorStats]:
        now = self._clock()
        return {sid: tracker.snapshot(now) for sid, tracker in self._trackers.items()}

    def status_text(self) -> str:
        return f"scenario {self.config.scenario}, activity {self.simulator.current_activity()}"

    def refused_without_sensor(self) -> tuple[dict[str, int], dict[str, int]]:
        """Nothing is refused by the simulated suit (see :meth:`SupervisorFeed.refused_without_sensor`)."""
        return {}, {}

    def signal_dbm(self) -> dict[str, float]:
        """The simulated suit has no radio link (see :meth:`SupervisorFeed.signal_dbm`)."""
        return {}

    def devices(self) -> dict[str, SensorDevice]:
        """Each unit's device id (:meth:`~mimucap.core.simulate.SimulationConfig.device_ids`)."""
        return self._devices

    def problem(self) -> str:
        """Why data may not be coming ("" : nothing known); the simulator always delivers."""
        return ""

    def stop(self) -> list[SensorSamples]:
        self._start_host_s = None
        return []


def simulated_subject_follows(simulator: SuitSimulator, instruction: Instruction) -> None:
    """The simulated subject of ``simulator`` does what ``instruction`` asks, as a person reads
    it on the screen; :data:`instructions.RESUME` sends it back to its scenario."""
    kind = instruction.kind
    if kind == instructions.NPOSE:
        simulator.set_activity("npose")
    elif kind == instructions.TPOSE:
        simulator.set_activity("tpose", arms=instruction.arms)
    elif kind == instructions.TURN_SENSORS:
        activity = {"single_axis": "mag_single_axis", "figure8": "mag_figure8", "free": "mag_tumble"}[instruction.protocol]
        simulator.set_activity(activity, sensor_ids=list(instruction.sensor_ids),
                               turns=instructions.PROTOCOL_TURNS[instruction.protocol])
    elif kind in (instructions.PREPARE_TEST, instructions.PERFORM_TEST):
        from mimucap.core.simulate.clinical_tests import CLINICAL_TESTS

        scenario = {test: name for name, test in CLINICAL_TESTS.items()}[instruction.test]
        part = "prepare" if kind == instructions.PREPARE_TEST else "perform"
        walkway = {"walkway_m": instruction.walkway_m} if instruction.walkway_m > 0 else {}
        simulator.set_activity(scenario, part=part, **walkway)
    elif kind == instructions.MOVE_JOINT:
        from mimucap.session.rom_procedure import RomStep, simulated_activity

        simulator.set_activity("rom", **simulated_activity(RomStep(instruction.movement, instruction.side)))
    else:
        simulator.resume_scenario()


class SupervisorFeed:
    """Any source spec through acquisition worker processes (see the module doc)."""

    kind = "workers"

    def __init__(self, spec: str, options: SourceOptions = SourceOptions()) -> None:
        self.spec = spec
        self.name = spec
        self.configs = source_configs(spec, options)
        self.supervisor = Supervisor(self.configs)
        self.simulator = None
        self.last_truth = None
        self._segments = sensor_segments(self.configs)

    @property
    def sensor_ids(self) -> tuple[str, ...]:
        return tuple(self.supervisor.stats())

    def sensor_segments(self) -> dict[str, str]:
        return dict(self._segments)

    def start(self) -> None:
        self.supervisor.start()

    def poll(self) -> list[SensorSamples]:
        blocks = self.supervisor.poll(0.0)
        # A simulated worker sends its subject's activity changes as markers; live they are
        # not the user's markers and are not shown (dropped here so they do not pile up).
        self.supervisor.take_markers()
        return blocks

    def follow(self, instruction: Instruction) -> None:
        """Real sensors are worn by a person, who reads the instruction on the screen."""

    def stats(self) -> dict[str, SensorStats]:
        return self.supervisor.stats()

    def signal_dbm(self) -> dict[str, float]:
        """Sensor id → strength of its radio link (dBm), for sources that report it (SlimeVR)."""
        out: dict[str, float] = {}
        for status in self.supervisor.sources().values():
            out.update(status.signal_dbm)
        return out

    def devices(self) -> dict[str, SensorDevice]:
        """Sensor id → its device, as the sources told (a sensor a source has not told of yet
        is absent: e.g. a node whose hello has not arrived)."""
        out: dict[str, SensorDevice] = {}
        for status in self.supervisor.sources().values():
            out.update(status.devices)
        return out

    def refused_without_sensor(self) -> tuple[dict[str, int], dict[str, int]]:
        """Inputs the sources refused that belong to no known sensor: ``(reason → count,
        unknown sender or sensor id → count)`` (e.g. packets from an address that is not part of
        the session, or lines too damaged to name their sensor)."""
        counts: dict[str, int] = {}
        unknown: dict[str, int] = {}
        for status in self.supervisor.sources().values():
            for reason, count in status.rejections.items():
                counts[reason] = counts.get(reason, 0) + count
            for sender, count in status.unknown_sensors.items():
                unknown[str(sender)] = unknown.get(str(sender), 0) + count
        for stats in self.supervisor.stats().values():
            for reason, count in stats.rejections.items():
                counts[reason] = counts.get(reason, 0) - count
        return {reason: count for reason, count in counts.items() if count > 0}, unknown

    def status_text(self) -> str:
        parts = []
        for name, status in self.supervisor.sources().items():
            text = f"{name} {status.state}"
            if status.last_error:
                text += f" ({status.last_error})"
            parts.append(text)
        return ", ".join(parts)

    def problem(self) -> str:
        """Why data may not be coming: each source that is disconnected (its worker retries)
        or failed, with the reason its worker gave (e.g. ``serial:/dev/ttyUSB0: cannot open
        /dev/ttyUSB0: No such file or directory``); "" when every source is fine."""
        parts = []
        for name, status in self.supervisor.sources().items():
            if status.state in (STATE_DISCONNECTED, STATE_FAILED):
                parts.append(f"{name}: {status.message or status.last_error or status.state}")
            elif status.warning:   # running, with something to act on (e.g. a refused SlimeVR tracker)
                parts.append(f"{name}: {status.warning}")
        return "; ".join(parts)

    def stop(self) -> list[SensorSamples]:
        return self.supervisor.stop()
