"""Per-sample processing shared by the packet drivers (UDP, serial) inside a worker.

For every decoded sample: check that the sensor belongs to the session, unwrap its sequence
number (a stale one is refused), feed the node clock estimator and map the device time to
the host's monotonic clock, and collect accepted samples into blocks. A node whose clock
jumps back by more than ``RESTART_CLOCK_JUMP_S`` has rebooted: its clock estimate starts over
and, if its counter restarted too, the new numbers continue after the last one (counted in
the report's ``restarts``). Blocks are flushed
when the oldest pending sample is ``flush_interval_s`` old or ``max_block_samples`` are
pending, so memory stays bounded and latency stays low.

Mapped host times are kept strictly increasing per sensor (a refit of the clock that would
move a sample before its predecessor places it 1 µs after it).

A node's hello (:mod:`mimucap.acquisition.hello`) says which device its sensor is
(:meth:`SampleIntake.identify`); a sensor heard for :data:`~mimucap.acquisition.hello.HELLO_WAIT_S`
without one is reported as lacking a device id (an older node), and the report's ``devices``
carries both.

A well-framed sample whose values are refused (:class:`RefusedSample`: NaN, beyond the limits)
is a rejection of its sensor. Its sequence number, if newer than the last accepted one, waits
until the next accepted sample: then it lies in the gap that sample leaves, and is reported in
``refused_in_gaps`` so the gap is not counted as a drop.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from mimucap.acquisition.hello import HELLO_WAIT_S, NO_HELLO, Hello
from mimucap.acquisition.messages import BlocksMessage, WorkerReport
from mimucap.acquisition.rejections import Rejection, RejectionCounter
from mimucap.acquisition.samples import BlockBuilder, RefusedSample, Sample, SequenceUnwrapper
from mimucap.acquisition.timesync import ClockSync, ClockSyncSettings
from mimucap.core.device_identity import SensorDevice

#: Distinct unknown ids/addresses tracked individually; beyond this they are lumped together.
MAX_TRACKED_UNKNOWN = 256
#: A node clock that jumps back by more than this (s) has restarted (reboot, brown-out).
RESTART_CLOCK_JUMP_S = 1.0
#: Refused sequence numbers remembered per sensor while no sample is accepted (about 10 min at
#: 100 Hz); older ones are forgotten, and their gap is then counted as a drop.
MAX_PENDING_REFUSED = 65536


def default_sensor_name(sensor_id: int) -> str:
    """Session name of wire id ``sensor_id`` when the session gives none (``"3"`` for 3)."""
    return str(int(sensor_id))


@dataclass(frozen=True)
class IntakeSettings:
    """Which sensors belong to the session and how samples are batched."""

    sensor_ids: tuple[int, ...] | None = None  #: expected wire ids; ``None`` accepts any id
    sensor_names: tuple[tuple[int, str], ...] = ()  #: wire id → session name (default str(id))
    flush_interval_s: float = 0.001   #: s, the oldest pending sample waits at most this long
    max_block_samples: int = 4096     #: pending samples that force a flush
    clock: ClockSyncSettings = field(default_factory=ClockSyncSettings)

    def __post_init__(self) -> None:
        if self.flush_interval_s <= 0 or self.max_block_samples < 1:
            raise ValueError("IntakeSettings: flush_interval_s must be > 0 and max_block_samples >= 1")


class _SensorState:
    __slots__ = ("name", "unwrapper", "clock", "last_host_s", "last_device_s", "rejections",
                 "restarts", "clock_settings", "pending_refused", "refused_in_gaps", "device", "first_heard_s")

    def __init__(self, name: str, clock_settings: ClockSyncSettings) -> None:
        self.name = name
        self.clock_settings = clock_settings
        self.unwrapper = SequenceUnwrapper()
        self.clock = ClockSync(clock_settings)
        self.last_host_s = float("-inf")
        self.last_device_s = float("-inf")
        self.rejections = RejectionCounter()
        self.restarts = 0
        self.pending_refused: deque[int] = deque(maxlen=MAX_PENDING_REFUSED)  # unwrapped numbers
        self.refused_in_gaps = 0
        self.device: SensorDevice | None = None   # from the node's hello
        self.first_heard_s: float | None = None   # host time of its first sample or hello

    def restart(self) -> None:
        """The node rebooted: its clock starts over (sequence numbers continue, see intake)."""
        self.clock = ClockSync(self.clock_settings)
        self.restarts += 1
        self.pending_refused.clear()   # the renumbered counter leaves no gap after them

    def note_refused(self, wire_seq: int) -> None:
        """Remember a refused sample's number if it is newer than the last accepted one."""
        seq = self.unwrapper.peek(wire_seq)
        if seq is not None:
            self.pending_refused.append(seq)

    def settle_refused(self, accepted_seq: int) -> None:
        """Count the refused numbers that lie before ``accepted_seq`` (they are in its gap)."""
        pending = self.pending_refused
        if not pending:
            return
        later = [seq for seq in pending if seq > accepted_seq]
        self.refused_in_gaps += len({seq for seq in pending if seq < accepted_seq})
        pending.clear()
        pending.extend(later)


class SampleIntake:
    """Turns decoded samples into blocks; ``send`` receives each :class:`BlocksMessage`."""

    def __init__(self, source: str, settings: IntakeSettings,
                 send: Callable[[BlocksMessage], None]) -> None:
        self.source = source
        self.settings = settings
        self._send = send
        self._expected = None if settings.sensor_ids is None else frozenset(settings.sensor_ids)
        self._names = dict(settings.sensor_names)
        self._sensors: dict[int, _SensorState] = {}
        self._builder = BlockBuilder(source)
        self.rejections = RejectionCounter()
        self.unknown: dict[str, int] = {}
        self._latest_s = float("-inf")   # host time of the newest input (the devices' clock)

    # ----------------------------------------------------------------- bookkeeping
    def reject(self, reason: Rejection, sensor_id: int | None = None) -> None:
        """Count a refused input (attributed to ``sensor_id`` when known)."""
        self.rejections.add(reason)
        if sensor_id is not None and sensor_id in self._sensors:
            self._sensors[sensor_id].rejections.add(reason)

    def count_unknown(self, key: str, reason: Rejection) -> None:
        """Count an input from an id/address that is not part of the session."""
        self.rejections.add(reason)
        if key not in self.unknown and len(self.unknown) >= MAX_TRACKED_UNKNOWN:
            key = "other"
        self.unknown[key] = self.unknown.get(key, 0) + 1

    def refuse(self, refused: RefusedSample) -> None:
        """Count a well-framed sample whose values were refused, against its sensor."""
        state = self.sensor(refused.sensor_id)
        if state is None:
            self.count_unknown(f"id {refused.sensor_id}", Rejection.UNKNOWN_SENSOR)
            return
        self.reject(refused.reason, refused.sensor_id)
        state.note_refused(refused.seq)

    def sensor(self, sensor_id: int) -> _SensorState | None:
        """State of an accepted sensor, creating it on first sight; ``None`` if unknown."""
        state = self._sensors.get(sensor_id)
        if state is None:
            if self._expected is not None and sensor_id not in self._expected:
                return None
            name = self._names.get(sensor_id, default_sensor_name(sensor_id))
            state = self._sensors[sensor_id] = _SensorState(name, self.settings.clock)
        return state

    def identify(self, hello: Hello, receive_time_s: float) -> bool:
        """Take a node's hello, received at host time ``receive_time_s``; returns whether its
        sensor's device changed (first told, or another node now sends under that id)."""
        state = self.sensor(hello.sensor_id)
        if state is None:
            self.count_unknown(f"id {hello.sensor_id}", Rejection.UNKNOWN_SENSOR)
            return False
        self._heard(state, receive_time_s)
        device = SensorDevice(hello.device_id)
        changed = device != state.device
        state.device = device
        return changed

    def identified(self, sensor_id: int) -> bool:
        """Whether the node of wire id ``sensor_id`` has said hello."""
        state = self._sensors.get(sensor_id)
        return state is not None and state.device is not None

    def _heard(self, state: _SensorState, receive_time_s: float) -> None:
        if state.first_heard_s is None:
            state.first_heard_s = receive_time_s
        self._latest_s = max(self._latest_s, receive_time_s)

    def devices(self) -> dict[str, SensorDevice]:
        """Sensor name → its device (the hello's), or why it has none once it has been heard
        for :data:`HELLO_WAIT_S` without a hello; sensors still waiting are left out."""
        found = {}
        for state in self._sensors.values():
            if state.device is not None:
                found[state.name] = state.device
            elif state.first_heard_s is not None and self._latest_s - state.first_heard_s >= HELLO_WAIT_S:
                found[state.name] = SensorDevice(None, NO_HELLO)
        return found

    def clock(self, sensor_id: int) -> ClockSync | None:
        state = self._sensors.get(sensor_id)
        return None if state is None else state.clock

    # ----------------------------------------------------------------- samples
    def accept(self, sample: Sample, receive_time_s: float) -> bool:
        """Process one decoded, validated sample received at host time ``receive_time_s``."""
        state = self.sensor(sample.sensor_id)
        if state is None:
            self.count_unknown(f"id {sample.sensor_id}", Rejection.UNKNOWN_SENSOR)
            return False
        self._heard(state, receive_time_s)
        restarted = state.last_device_s - sample.device_time_s > RESTART_CLOCK_JUMP_S
        if restarted:           # the node rebooted: new clock, and maybe a new counter
            state.restart()
        seq = state.unwrapper.unwrap(sample.seq)
        if seq is None:
            if not restarted:
                self.reject(Rejection.STALE_SEQUENCE, sample.sensor_id)
                return False
            seq = state.unwrapper.restart(sample.seq)
        state.settle_refused(seq)
        state.last_device_s = sample.device_time_s
        state.clock.add_one_way(sample.device_time_s, receive_time_s)
        estimate = state.clock.estimate
        host_s = estimate.host_from_device_scalar(sample.device_time_s)
        if host_s <= state.last_host_s:
            host_s = state.last_host_s + 1e-6
        state.last_host_s = host_s
        self._builder.add(state.name, seq, sample, host_s, receive_time_s)
        if len(self._builder) >= self.settings.max_block_samples:
            self.flush()
        return True

    def flush_due_in(self, now_s: float) -> float | None:
        """Seconds until the pending samples must be flushed (``None`` if nothing pends)."""
        if self._builder.oldest_receive_time_s is None:
            return None
        return self._builder.oldest_receive_time_s + self.settings.flush_interval_s - now_s

    def flush_if_due(self, now_s: float) -> None:
        due = self.flush_due_in(now_s)
        if due is not None and due <= 0:
            self.flush()

    def flush(self) -> None:
        """Send every pending sample now (with the refused samples in their gaps so far)."""
        if len(self._builder):
            self._send(BlocksMessage(self.source, tuple(self._builder.take()),
                                     refused_in_gaps=self._refused_in_gaps()))

    def _refused_in_gaps(self) -> dict[str, int]:
        return {s.name: s.refused_in_gaps for s in self._sensors.values() if s.refused_in_gaps}

    def report(self, state: str, message: str = "", overflow_samples: int = 0,
               reconnects: int = 0) -> WorkerReport:
        """A cumulative :class:`WorkerReport` of this intake."""
        clocks = {}
        by_sensor = {}
        restarts = {s.name: s.restarts for s in self._sensors.values() if s.restarts}
        for sensor in self._sensors.values():
            estimate = sensor.clock.estimate
            if estimate is not None:
                clocks[sensor.name] = estimate
            if sensor.rejections.total():
                by_sensor[sensor.name] = sensor.rejections.as_dict()
        rejections = self.rejections.as_dict()
        if overflow_samples:
            rejections[Rejection.QUEUE_OVERFLOW.value] = overflow_samples
        return WorkerReport(self.source, state, message, rejections,
                            dict(self.unknown), by_sensor, clocks, overflow_samples, reconnects,
                            restarts, self._refused_in_gaps(), devices=self.devices())
