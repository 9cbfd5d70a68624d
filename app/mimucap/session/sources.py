"""From a source spec string to the worker configs that acquire it (composition with ``io``).

The acquisition layer may not read files, so the parts of a source that need ``io`` live
here: ``replay:FILE[@SPEED]`` loads a MimuCap session file (HDF5) or Xsens MT Manager text
exports (one ``.txt`` or a folder of them) and hands the arrays to the replay worker.
Everything else is mapped directly onto acquisition configs.

Replayed Xsens exports carry ``acc`` (m/s²), ``gyr`` (rad/s) and ``q_world_from_sensor``
(ENU); their magnetometer is in arbitrary units (normalised to the local field), not µT, so
it is not replayed. Rows that a live source would refuse — a missing (NaN) or infinite value,
a value beyond the physical limits, in either kind of file — are not replayed
(:func:`~mimucap.acquisition.replay.replayable`), so no NaN reaches the
pipeline: they are counted in :attr:`LoadedReplay.skipped_rows` and reported by the replay
source as rejections with their reason (``non_finite``, ``out_of_range``), not as drops.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from mimucap.acquisition.intake import IntakeSettings
from mimucap.acquisition.replay import RefusedRows, ReplaySourceConfig, replayable
from mimucap.acquisition.serial_port import SerialSourceConfig
from mimucap.acquisition.source_spec import (
    ReplaySpec, SerialSpec, SimulatedSpec, SlimeVrSpec, SourceSpec, UdpSpec, parse_source_spec,
)
from mimucap.acquisition.simulated import SimulatedSourceConfig
from mimucap.acquisition.slimevr import SlimeVrSourceConfig
from mimucap.acquisition.udp import UdpSourceConfig
from mimucap.acquisition.worker import SourceConfig
from mimucap.core.device_identity import SensorDevice, xsens_device_id
from mimucap.core.samples import SensorSamples
from mimucap.io.input_names import SESSION_SUFFIXES
from mimucap.io.quaternion_tables import read_xsens_file
from mimucap.io.session import read_session


@dataclass(frozen=True)
class SourceOptions:
    """Session-level choices that apply to a source."""

    sensor_ids: tuple[int, ...] | None = None        #: expected wire ids (UDP/serial)
    allowed_addresses: tuple[str, ...] | None = None  #: UDP senders allowed
    sensor_count: int | None = None                  #: simulated suit size (default: the model's)
    rate_hz: float | None = None                     #: simulated rate (default: simulator's)
    seed: int = 0                                    #: simulated suit seed


@dataclass
class LoadedReplay:
    """What a replay plays: each sensor's replayable samples (``segment`` where a session names
    it), the rows refused before replay (sensor → :class:`RefusedRows`, sensors with some) and
    each sensor's device as the file says (a session's recorded devices, an Xsens export's
    device id)."""

    streams: tuple[SensorSamples, ...]
    refused: dict[str, RefusedRows] = field(default_factory=dict)
    devices: dict[str, SensorDevice] = field(default_factory=dict)

    @property
    def skipped_rows(self) -> dict[str, int]:
        """Sensor → rows refused before replay (0 for a sensor with none)."""
        return {s.sensor_id: len(self.refused.get(s.sensor_id) or ()) for s in self.streams}

    @property
    def segments(self) -> dict[str, str]:
        """Sensor → the segment it was worn on (sessions name it)."""
        return {s.sensor_id: s.segment for s in self.streams if s.segment}

    def config(self, name: str, speed: float) -> ReplaySourceConfig:
        """The replay worker's config."""
        return ReplaySourceConfig(name=name, streams=self.streams, refused=tuple(self.refused.items()), speed=speed,
                                  devices=tuple(self.devices.items()))


def load_replay(path: str | Path) -> LoadedReplay:
    """Sensor streams of a session file or Xsens export(s) at ``path`` (``ValueError`` if unusable)."""
    path = Path(path)
    if not path.exists():
        raise ValueError(f"replay file {path} does not exist")
    is_hdf5 = path.is_file() and h5py.is_hdf5(path)
    if is_hdf5 or (path.is_file() and path.suffix.lower() in SESSION_SUFFIXES):
        if not is_hdf5:
            raise ValueError(f"replay file {path}: not an HDF5 session (a MimuCap session is HDF5; "
                             f"replayed Xsens exports are .txt files)")
        return _session_streams(path)
    files = sorted(path.glob("*.txt")) if path.is_dir() else [path]
    if not files:
        raise ValueError(f"replay folder {path} holds no Xsens .txt exports")
    recordings = []
    devices = {}
    for file in files:
        recording = read_xsens_file(file)
        samples = SensorSamples(recording.device_id, recording.t_s, recording.packet_counter.astype(np.int64),
                                acc=recording.acc, gyr=recording.gyr,
                                q_world_from_sensor=recording.q_world_from_sensor)
        if not samples.channels():
            raise ValueError(f"{file}: no accelerometer, gyroscope or orientation columns to replay")
        recordings.append(samples)
        try:
            devices[recording.device_id] = SensorDevice(xsens_device_id(recording.device_id))
        except ValueError:
            devices[recording.device_id] = SensorDevice(None, f"{file.name} names no Xsens device id")
    return _replayed(recordings, devices)


def _session_streams(path: Path) -> LoadedReplay:
    session = read_session(path, include_truth=False)
    if not session.sensors:
        raise ValueError(f"replay file {path} holds no sensor streams")
    # a NaN row (e.g. a channel missing for a while) is refused, as a live source refuses it
    try:
        devices = session.devices()
    except ValueError as error:
        raise ValueError(f"replay file {path}: {error}") from None
    return _replayed(list(session.sensors.values()), devices)


def _replayed(recordings: list[SensorSamples], devices: dict[str, SensorDevice]) -> LoadedReplay:
    """Each recording's replayable rows, and those refused (see :func:`replayable`)."""
    streams, refused = [], {}
    for samples in recordings:
        stream, rows = replayable(samples)
        streams.append(stream)
        if rows is not None:
            refused[stream.sensor_id] = rows
    return LoadedReplay(tuple(streams), refused, dict(devices))


def source_configs(spec: str | SourceSpec, options: SourceOptions = SourceOptions(),
                   name: str | None = None) -> list[SourceConfig]:
    """The worker config(s) for ``spec`` (a spec string is parsed first)."""
    if isinstance(spec, str):
        spec = parse_source_spec(spec)
    intake = IntakeSettings(sensor_ids=options.sensor_ids)
    if isinstance(spec, UdpSpec):
        return [UdpSourceConfig(name=name or "udp", bind_address=spec.bind_address, port=spec.port,
                                allowed_addresses=options.allowed_addresses, intake=intake)]
    if isinstance(spec, SerialSpec):
        return [SerialSourceConfig(name=name or "serial", device=spec.device, baud=spec.baud,
                                   intake=intake)]
    if isinstance(spec, ReplaySpec):
        return [load_replay(spec.path).config(name or "replay", spec.speed)]
    if isinstance(spec, SlimeVrSpec):
        # SlimeVR trackers name their sensors by MAC (see acquisition.slimevr); wire ids do not apply
        return [SlimeVrSourceConfig(name=name or "slimevr", bind_address=spec.bind_address, port=spec.port)]
    if isinstance(spec, SimulatedSpec):
        return [SimulatedSourceConfig(name=name or "simulated", scenario=spec.scenario, room=spec.room,
                                      n_sensors=options.sensor_count, rate_hz=options.rate_hz,
                                      seed=options.seed)]
    raise TypeError(f"not a source spec: {spec!r}")


def sensor_segments(configs: list[SourceConfig]) -> dict[str, str]:
    """Sensor id → segment, where the source knows it: the simulated suit, a replayed session
    (the placement stored in it)."""
    segments: dict[str, str] = {}
    for config in configs:
        if isinstance(config, (SimulatedSourceConfig, ReplaySourceConfig)):
            segments.update(config.sensor_segments())
    return segments


def parse_sensor_ids(text: str | None) -> tuple[int, ...] | None:
    """``"1-4,7"`` → ``(1, 2, 3, 4, 7)``; ``None``/empty → ``None`` (accept any id). A range
    whose first id is above its last (``10-1``) is refused: it holds no id."""
    if not text:
        return None
    ids: list[int] = []
    for part in text.split(","):
        part = part.strip()
        low, sep, high = part.partition("-")
        try:
            values = range(int(low), int(high) + 1) if sep else [int(low)]
        except ValueError:
            raise ValueError(f"bad sensor id list {text!r}: use e.g. 1-4,7") from None
        if not values:
            raise ValueError(f"the range {part} is empty (give the lower id first, e.g. {int(high)}-{int(low)})")
        for value in values:
            if not 0 <= value < 0xFFFF:
                raise ValueError(f"sensor id {value} is outside 0..65534")
            ids.append(value)
    return tuple(sorted(set(ids)))
