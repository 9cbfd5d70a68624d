"""The supervisor: runs one worker process per source and gathers their samples.

Lives in the main process (the GUI's or the recorder's) and never blocks it for long:
:meth:`Supervisor.poll` waits at most ``timeout_s`` and returns the sample blocks that
arrived. It starts workers with the ``spawn`` method, restarts a worker that failed (up to
``max_restarts`` times, ``restart_backoff_s`` apart), stops them all on :meth:`stop`, and
keeps per-sensor statistics (:class:`~mimucap.acquisition.stats.SensorStats`) and per-source
status (state, message, rejections, unknown senders, clock estimates).
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import queue as queue_module
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

from mimucap.acquisition.messages import (
    STATE_FAILED, STATE_FINISHED, STATE_STARTING, STATE_STOPPED, BlocksMessage, WorkerReport,
)
from mimucap.acquisition.rejections import RejectionCounter
from mimucap.acquisition.samples import PackedBlock, join_packed_blocks
from mimucap.acquisition.stats import SensorStats, SensorStatsTracker
from mimucap.acquisition.timesync import ClockEstimate
from mimucap.acquisition.worker import SourceConfig, run_worker
from mimucap.core.device_identity import SensorDevice
from mimucap.core.samples import SensorSamples


@dataclass(frozen=True)
class SupervisorSettings:
    """Settings of :class:`Supervisor` (defaults documented per field)."""

    queue_max_messages: int = 2048   #: bounded worker → supervisor queue (messages)
    max_restarts: int = 5            #: restarts of a failed worker before giving up
    restart_backoff_s: float = 0.5   #: s to wait before restarting a failed worker
    stats_window_s: float = 2.0      #: s over which rates are computed
    latency_samples: int = 4096      #: recent latencies kept per sensor for the percentiles
    max_messages_per_poll: int = 512  #: a poll returns after this many messages at most
    stop_timeout_s: float = 3.0      #: s a worker gets to stop before it is terminated


@dataclass
class SourceStatus:
    """What the supervisor knows about one source."""

    name: str
    state: str = STATE_STARTING
    message: str = ""
    restarts: int = 0
    failures: int = 0                #: runs of the worker that ended in an error
    last_error: str = ""             #: the message of the last failure
    reconnects: int = 0
    overflow_samples: int = 0
    rejections: dict[str, int] = field(default_factory=dict)
    unknown_sensors: dict[str, int] = field(default_factory=dict)
    clocks: dict[str, ClockEstimate] = field(default_factory=dict)
    node_restarts: dict[str, int] = field(default_factory=dict)   #: sensor → reboots seen
    signal_dbm: dict[str, float] = field(default_factory=dict)    #: sensor → radio link (dBm)
    warning: str = ""                #: the worker's last warning (see WorkerReport.warning)
    devices: dict[str, SensorDevice] = field(default_factory=dict)   #: sensor → its device (WorkerReport.devices)
    exit_code: int | None = None


class _Worker:
    def __init__(self, config: SourceConfig) -> None:
        self.config = config
        self.process = None
        self.stop_event = None
        self.status = SourceStatus(config.name)
        self.previous_runs = RejectionCounter()   # rejections of earlier (restarted) runs
        self.previous_overflow = 0
        self.last_report: WorkerReport | None = None
        self.restart_at: float | None = None


class Supervisor:
    """Starts, watches and stops the workers of ``configs`` (one per source, unique names)."""

    def __init__(self, configs: Sequence[SourceConfig],
                 settings: SupervisorSettings = SupervisorSettings()) -> None:
        names = [c.name for c in configs]
        if len(set(names)) != len(names):
            raise ValueError(f"source names must be unique, got {names}")
        self.settings = settings
        self._context = multiprocessing.get_context("spawn")
        self._queue = self._context.Queue(maxsize=settings.queue_max_messages)
        self._workers = {c.name: _Worker(c) for c in configs}
        self._trackers: dict[str, SensorStatsTracker] = {}
        self._markers: list[tuple[float, str]] = []
        self._stopping = False
        self.started = False

    # -------------------------------------------------------------- lifecycle
    def start(self) -> None:
        """Start every worker (returns at once; samples arrive through :meth:`poll`)."""
        self._stopping = False
        for worker in self._workers.values():
            self._spawn(worker)
        self.started = True

    def _spawn(self, worker: _Worker) -> None:
        worker.stop_event = self._context.Event()
        worker.process = self._context.Process(
            target=run_worker, args=(worker.config, self._queue, worker.stop_event),
            name=f"mimucap-{worker.config.name}", daemon=True)
        worker.process.start()
        worker.status.state = STATE_STARTING
        worker.status.exit_code = None

    def stop(self) -> list[SensorSamples]:
        """Ask every worker to stop, wait for them and return the blocks still in flight."""
        self._stopping = True
        for worker in self._workers.values():
            if worker.stop_event is not None:
                worker.stop_event.set()
        blocks: list[SensorSamples] = []
        deadline = time.monotonic() + self.settings.stop_timeout_s
        while time.monotonic() < deadline and any(
                w.process is not None and w.process.is_alive() for w in self._workers.values()):
            blocks.extend(self._drain(0.02))
        for worker in self._workers.values():
            process = worker.process
            if process is not None and process.is_alive():
                process.terminate()
                process.join(1.0)
            if process is not None:
                worker.status.exit_code = process.exitcode
        blocks.extend(self._drain(0.0))
        for worker in self._workers.values():
            status = worker.status
            if status.state == STATE_STARTING and status.failures:
                # stopped while restarting after a failure: it never ran again
                status.state, status.message = STATE_FAILED, status.last_error
            elif status.state not in (STATE_FAILED, STATE_FINISHED):
                status.state = STATE_STOPPED
        self.started = False
        return blocks

    def __enter__(self) -> "Supervisor":
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    # -------------------------------------------------------------- data
    def poll(self, timeout_s: float = 0.05) -> list[SensorSamples]:
        """Blocks that arrived (waits up to ``timeout_s`` for the first message)."""
        blocks = self._drain(timeout_s)
        if not self._stopping:
            self._watch()
        return blocks

    def _drain(self, timeout_s: float) -> list[SensorSamples]:
        """Everything in the queue now (waiting up to ``timeout_s`` for a first message): the
        packed blocks of all the messages are joined before unpacking, so that each sensor
        yields one block per poll (its statistics and the pipeline then work per poll, not
        per message)."""
        blocks: list[SensorSamples] = []
        packed: list[PackedBlock] = []
        reports: list[WorkerReport] = []
        refused_in_gaps: dict[str, int] = {}
        for count in range(self.settings.max_messages_per_poll):
            try:
                if count == 0 and timeout_s > 0:
                    message = self._queue.get(timeout=timeout_s)
                else:
                    message = self._queue.get_nowait()
            except (queue_module.Empty, EOFError, OSError):
                break
            if isinstance(message, BlocksMessage):
                self._markers.extend(message.markers)
                refused_in_gaps.update(message.refused_in_gaps)
                for block in message.blocks:
                    (packed if isinstance(block, PackedBlock) else blocks).append(block)
            elif isinstance(message, WorkerReport):
                reports.append(message)
        # A source sends either packed or plain blocks, so a sensor's blocks keep their order.
        for joined in join_packed_blocks(packed):
            blocks.extend(joined.unpack())
        arrival = time.monotonic()
        for block in blocks:
            self._tracker(block).add_block(block, arrival)
        self._set_refused_in_gaps(refused_in_gaps)   # with the gaps they explain
        for report in reports:  # after the blocks sent before them: a sensor first seen here has its tracker
            self._apply_report(report)
        return blocks

    def _tracker(self, block: SensorSamples) -> SensorStatsTracker:
        tracker = self._trackers.get(block.sensor_id)
        if tracker is None:
            tracker = self._trackers[block.sensor_id] = SensorStatsTracker(
                block.sensor_id, block.source, self.settings.stats_window_s, self.settings.latency_samples)
        return tracker

    def _apply_report(self, report: WorkerReport) -> None:
        worker = self._workers.get(report.source)
        if worker is None:
            return
        worker.last_report = report
        status = worker.status
        if report.state == STATE_FAILED and status.state != STATE_FAILED:
            status.failures += 1
            status.last_error = report.message
        status.state, status.message = report.state, report.message
        status.reconnects = report.reconnects
        total = RejectionCounter(worker.previous_runs.as_dict())
        total.update(report.rejections)
        status.rejections = total.as_dict()
        status.unknown_sensors = dict(report.unknown_sensors)
        status.overflow_samples = worker.previous_overflow + report.overflow_samples
        status.clocks = dict(report.clocks)
        status.node_restarts = dict(report.node_restarts)
        status.signal_dbm = dict(report.signal_dbm)
        status.warning = report.warning
        status.devices.update(report.devices)   # a restarted worker has not told them all again yet
        for sensor, counts in report.rejections_by_sensor.items():
            if sensor in self._trackers:
                self._trackers[sensor].rejections = dict(counts)
        self._set_refused_in_gaps(report.refused_in_gaps)

    def _set_refused_in_gaps(self, counts: dict[str, int]) -> None:
        """Cumulative counts from blocks and reports; a report drained after newer blocks
        may carry an older, smaller count, so a count only grows."""
        for sensor, count in counts.items():
            tracker = self._trackers.get(sensor)
            if tracker is not None and count > tracker.refused_in_gaps:
                tracker.refused_in_gaps = count

    def _watch(self) -> None:
        """Restart failed workers (after the backoff)."""
        now = time.monotonic()
        for worker in self._workers.values():
            process = worker.process
            if process is None or process.is_alive():
                continue
            worker.status.exit_code = process.exitcode
            if process.exitcode == 0:
                if worker.status.state not in (STATE_FAILED,):
                    worker.status.state = STATE_FINISHED
                continue
            if worker.status.restarts >= self.settings.max_restarts:
                worker.status.state = STATE_FAILED
                continue
            if worker.restart_at is None:
                if worker.status.state != STATE_FAILED:   # died without a report (e.g. killed)
                    worker.status.failures += 1
                    worker.status.last_error = f"worker exited with code {process.exitcode}"
                    worker.status.message = worker.status.last_error
                worker.status.state = STATE_FAILED
                worker.restart_at = now + self.settings.restart_backoff_s
            elif now >= worker.restart_at:
                if worker.last_report is not None:
                    worker.previous_runs.update(worker.last_report.rejections)
                    worker.previous_overflow += worker.last_report.overflow_samples
                    worker.last_report = None
                worker.restart_at = None
                worker.status.restarts += 1
                self._spawn(worker)

    def take_markers(self) -> list[tuple[float, str]]:
        """Markers sources sent since the last call: ``(host monotonic s, label)``."""
        markers, self._markers = self._markers, []
        return markers

    # -------------------------------------------------------------- state
    def stats(self) -> dict[str, SensorStats]:
        """Per-sensor statistics now (sensor id → snapshot)."""
        now = time.monotonic()
        order = sorted(self._trackers, key=lambda n: (not n.isdigit(), int(n) if n.isdigit() else 0, n))
        return {name: self._trackers[name].snapshot(now) for name in order}

    def latencies_s(self, sensor_id: str):
        """Recent latencies (s) of one sensor (see :mod:`mimucap.acquisition.stats`)."""
        return self._trackers[sensor_id].latencies_s()

    def sources(self) -> dict[str, SourceStatus]:
        """Per-source status now (name → a copy of its :class:`SourceStatus`)."""
        return {name: dataclasses.replace(worker.status) for name, worker in self._workers.items()}

    def worker_pid(self, source: str) -> int | None:
        """Process id of the worker of ``source`` (``None`` if not running)."""
        process = self._workers[source].process
        return None if process is None or not process.is_alive() else process.pid

    def all_finished(self) -> bool:
        """True when no worker runs any more and none will be restarted."""
        return all(w.process is not None and not w.process.is_alive() and
                   (w.process.exitcode == 0 or w.status.restarts >= self.settings.max_restarts)
                   for w in self._workers.values())
