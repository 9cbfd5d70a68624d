"""Messages from worker processes to the supervisor (picklable, sent through one queue).

A worker sends :class:`BlocksMessage` s with samples and, at least every
``report_interval_s`` and on every state change, a :class:`WorkerReport` whose counters are
*cumulative* since the worker started (so a report lost to a full queue costs nothing).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mimucap.acquisition.samples import PackedBlock
from mimucap.acquisition.timesync import ClockEstimate
from mimucap.core.device_identity import SensorDevice
from mimucap.core.samples import SensorSamples

#: Worker states as reported to the supervisor.
STATE_STARTING = "starting"
STATE_RUNNING = "running"          #: receiving (or ready to receive) data
STATE_DISCONNECTED = "disconnected"  #: the device is gone; the worker retries
STATE_FINISHED = "finished"        #: the source ended by itself (replay, limited simulation)
STATE_FAILED = "failed"            #: an error stopped the worker; the supervisor may restart it
STATE_STOPPED = "stopped"          #: the worker ended because it was asked to


@dataclass(frozen=True, eq=False)
class BlocksMessage:
    """Samples of one source: per-sensor blocks or packed multi-sensor blocks."""

    source: str
    blocks: tuple[SensorSamples | PackedBlock, ...]
    markers: tuple[tuple[float, str], ...] = ()   #: (host monotonic s, label), e.g. activity changes
    #: sensor → refused samples in its sequence gaps so far (cumulative, as in
    #: :attr:`WorkerReport.refused_in_gaps`), sent with the blocks whose gaps they explain so
    #: that the drop count never counts them for a moment
    refused_in_gaps: dict[str, int] = field(default_factory=dict)
    #: sensor → strength of its radio link (dBm), for sources that report one (SlimeVR)
    signal_dbm: dict[str, float] = field(default_factory=dict)
    #: something the user should act on while the source runs (e.g. a refused SlimeVR tracker)
    warning: str = ""

    def sample_count(self) -> int:
        return sum(len(block) for block in self.blocks)

    def unpacked(self) -> list[SensorSamples]:
        """One :class:`~mimucap.core.samples.SensorSamples` per sensor and run."""
        out: list[SensorSamples] = []
        for block in self.blocks:
            out.extend(block.unpack() if isinstance(block, PackedBlock) else (block,))
        return out


@dataclass(frozen=True)
class WorkerReport:
    """Cumulative state of one worker (counts since that worker process started)."""

    source: str
    state: str
    message: str = ""
    rejections: dict[str, int] = field(default_factory=dict)
    unknown_sensors: dict[str, int] = field(default_factory=dict)   #: id or address → count
    rejections_by_sensor: dict[str, dict[str, int]] = field(default_factory=dict)
    clocks: dict[str, ClockEstimate] = field(default_factory=dict)  #: sensor → clock mapping
    overflow_samples: int = 0        #: samples discarded because the queue was full
    reconnects: int = 0
    node_restarts: dict[str, int] = field(default_factory=dict)   #: sensor → reboots seen
    #: sensor → refused samples whose sequence numbers lie between delivered ones (the gaps
    #: they leave are rejections, not drops)
    refused_in_gaps: dict[str, int] = field(default_factory=dict)
    #: sensor → strength of its radio link (dBm), for sources that report one (SlimeVR)
    signal_dbm: dict[str, float] = field(default_factory=dict)
    #: something the user should act on while the source runs (e.g. a refused SlimeVR tracker)
    warning: str = ""
    #: sensor → which device it is, for the sensors the source can tell of (a node's hello, a
    #: tracker's MAC, a simulated unit; or why it has none)
    devices: dict[str, SensorDevice] = field(default_factory=dict)
