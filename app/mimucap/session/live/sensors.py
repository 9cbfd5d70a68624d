"""The live session's source and its sensors (no Qt): what arrives, from which sensors and
devices, worn on which segments.

:class:`LiveSensors` owns the source (a feed of :mod:`mimucap.session.sources.feeds`: ``poll``,
``stats``, ``devices``, ``follow(instruction)``), the session clock's origin (``t0_host_s``: the
host monotonic time of the start; a sample's session time is its host time minus it), the sensors
known so far (the source's, and those that appeared with their first samples), what the source
says of each sensor's device, each sensor's battery, and the assignment of sensors to segments
(one sensor per segment).

Events (``events``, :class:`~mimucap.session.events.EmitterGroup`):

* ``blocks(list[SensorSamples])``: the raw blocks as they arrived (host times, raw magnetometer);
* ``sensors(sensor_ids)``: the tuple of known sensors grew (a worker source's sensors appear
  with their first samples);
* ``assignment(sensor_segments)``: a sensor was worn on another segment (a copy of
  :attr:`LiveSensors.sensor_segments`);
* ``problem(text)``: why the source may send nothing ("": nothing known), when it changed;
* ``refused(reasons, senders)``: packets refused from no known sensor (reason → count, sender →
  count), when they changed;
* ``unpaired(list[UnpairedSensor])``: the sensors a network source refuses because their device is
  not paired (:mod:`mimucap.acquisition.pairing`), when they changed (a device became known,
  another was heard).

The last three are read from the source when the status is published
(:meth:`LiveSensors.publish_state`, at the status rate).
"""

from __future__ import annotations

from collections.abc import Callable

from mimucap.core import skeleton
from mimucap.core.device_identity import SensorDevice
from mimucap.io.pairing_store import PairingStore
from mimucap.core.pipeline.segments import one_sensor_per_segment
from mimucap.core.sensor_samples import SensorSamples
from mimucap.session.events import EmitterGroup
from mimucap.session.procedures.instructions import Instruction


class LiveSensors:
    """The source ``feed`` (not started yet), named ``label``, of sensors worn on ``model``'s
    segments; ``clock``: the monotonic clock (s) the feed's host times are on."""

    def __init__(self, feed, label: str, model: skeleton.SkeletonModel, clock: Callable[[], float]) -> None:
        self.feed = feed
        self.label = label or feed.name
        self.model = model
        self._clock = clock
        self.events = EmitterGroup("blocks", "sensors", "assignment", "problem", "refused", "unpaired")
        #: host monotonic time (s) of the start: session time 0
        self.t0_host_s: float | None = None
        self.started = False
        #: sensor id → segment, as the source names it (a replayed recording's placement, the
        #: simulated suit's labels); the user's assignment changes it
        self.sensor_segments: dict[str, str] = one_sensor_per_segment(feed.sensor_segments())
        #: sensor → what the source says of its device (updated by :meth:`follow_devices`)
        self.devices: dict[str, SensorDevice] = dict(feed.devices())
        self._seen: dict[str, None] = {}   # sensors that sent samples, in order of arrival
        self._battery: dict[str, float] = {}
        self._known_ids: tuple[str, ...] = ()
        self.samples_received = 0
        self.last_arrival_s = float("nan")   #: host time the newest block arrived (latency bench)
        self._problem: str | None = None
        self._refused: tuple | None = None
        self._unpaired: tuple | None = None
        #: the paired suit the network sources let in (:func:`~mimucap.session.live.live_session.open_live_session`
        #: sets it; the source must be opened again for a device paired meanwhile to be let in)
        self.pairing_store: PairingStore | None = None

    # -- the source ------------------------------------------------------------------------
    @property
    def simulator(self):
        """The in-process :class:`~mimucap.core.simulate.suit.SuitSimulator`, or ``None`` (for the
        evaluation of its truth; the pipeline and the procedures never ask for it)."""
        return self.feed.simulator

    def start(self) -> None:
        """Start the source; session time 0 is now."""
        self.t0_host_s = self._clock()
        self.feed.start()
        self.started = True

    def stop(self) -> None:
        if self.started:
            self.feed.stop()
            self.started = False

    def instruct(self, instruction: Instruction) -> None:
        """Tell the source what a procedure asks of the subject (the person reads it on the
        screen; the simulated subject does it)."""
        self.feed.follow(instruction)

    @property
    def problem(self) -> str:
        """Why the source may be sending nothing, as its reader reported it (e.g. a serial
        device that cannot be opened); "" when nothing is known to be wrong."""
        return self.feed.problem()

    def stats(self):
        """Sensor id → :class:`~mimucap.acquisition.stats.SensorStats` (rates and drops over the last 2 s)."""
        return self.feed.stats()

    def poll(self) -> list[SensorSamples]:
        """The blocks that arrived since the last call (never blocks), told by ``blocks``."""
        blocks = self.feed.poll()
        if blocks:
            self.last_arrival_s = max(float(b.receive_time_s[-1]) for b in blocks if len(b))
            for block in blocks:
                if block.battery_pct is not None and len(block):
                    self._battery[block.sensor_id] = float(block.battery_pct[-1])
            self.events.blocks.emit(blocks)
        return blocks

    # -- the sensors -------------------------------------------------------------------------
    @property
    def sensor_ids(self) -> tuple[str, ...]:
        """The source's sensors, then those that appeared with their samples."""
        ids = list(self.feed.sensor_ids)
        ids += [s for s in self._seen if s not in ids]
        return tuple(ids)

    def seen(self) -> tuple[str, ...]:
        """The sensors that have sent samples."""
        return tuple(self._seen)

    def new_sensors(self, blocks: list[SensorSamples]) -> list[str]:
        """The sensors of ``blocks`` that have not sent samples before."""
        return [block.sensor_id for block in blocks if block.sensor_id not in self._seen]

    def note_samples(self, blocks: list[SensorSamples]) -> None:
        """``blocks`` went through the session: their sensors are seen, their samples counted;
        ``sensors`` is told when the known sensors grew."""
        for block in blocks:
            self._seen.setdefault(block.sensor_id, None)
            self.samples_received += len(block)
        known = self.sensor_ids
        if known != self._known_ids:
            self._known_ids = known
            self.events.sensors.emit(known)

    def battery_pct(self, sensor_id: str) -> float:
        """The sensor's newest battery charge (%), NaN when unknown."""
        return self._battery.get(sensor_id, float("nan"))

    def device_of(self, sensor_id: str) -> SensorDevice:
        """What the source says of ``sensor_id``'s device (nothing yet: ``SensorDevice()``)."""
        return self.devices.get(sensor_id, SensorDevice())

    def follow_devices(self) -> list[str]:
        """Take what the source now says of its sensors' devices; returns the sensors whose
        device became known or changed (another node answering to the same id)."""
        devices = self.feed.devices()
        if devices == self.devices:
            return []
        changed = [sid for sid in set(devices) | set(self.devices) if devices.get(sid) != self.devices.get(sid)]
        self.devices = dict(devices)
        return changed

    def assign(self, sensor_id: str, segment: str | None) -> None:
        """Wear ``sensor_id`` on ``segment`` (``None`` unassigns); a segment holds one sensor."""
        if segment is not None and segment not in self.model.segment_names:
            raise ValueError(f"sensor {sensor_id}: unknown segment {segment!r}; use one of "
                             f"{', '.join(self.model.segment_names)}")
        for other, seg in list(self.sensor_segments.items()):
            if seg == segment and other != sensor_id:
                del self.sensor_segments[other]
        before = dict(self.sensor_segments)
        if segment is None:
            self.sensor_segments.pop(sensor_id, None)
        else:
            self.sensor_segments[sensor_id] = segment
        if self.sensor_segments != before:
            self.events.assignment.emit(dict(self.sensor_segments))

    # -- what the status publishes -------------------------------------------------------------
    def publish_state(self) -> None:
        """Emit ``problem``, ``refused`` and ``unpaired`` when they changed since they were last told."""
        problem = self.problem
        if problem != self._problem:
            self._problem = problem
            self.events.problem.emit(problem)
        refused = self.feed.refused_without_sensor()
        key = (tuple(sorted(refused[0].items())), tuple(sorted(refused[1].items())))
        if key != self._refused:
            self._refused = key
            self.events.refused.emit(dict(refused[0]), dict(refused[1]))
        unpaired = self.feed.unpaired()
        key = tuple(sorted((name, sensor.device) for name, sensor in unpaired.items()))
        if key != self._unpaired:
            self._unpaired = key
            self.events.unpaired.emit(list(unpaired.values()))

    def forget_state(self) -> None:
        """Forget what was told (the next :meth:`publish_state` tells everything again)."""
        self._problem = None
        self._refused = None
        self._unpaired = None
