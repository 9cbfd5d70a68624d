"""Accepted samples of several sensors packed into one set of columns (:class:`PackedBlock`):
the worker → supervisor transport, unpacked into one
:class:`~mimucap.core.sensor_samples.SensorSamples` per sensor.

Units and frames are those of :mod:`mimucap.acquisition.wire_sample` (``host_time_s`` the
host's monotonic clock after clock mapping, s); a missing channel is absent, never zero-filled.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mimucap.acquisition.wire_sample import Sample
from mimucap.core.sensor_samples import CHANNELS, SensorSamples

_CHANNEL_DTYPES = {
    "acc": np.float64, "gyr": np.float64, "mag_uT": np.float64,
    "q_world_from_sensor": np.float64, "calibration": np.int8, "battery_pct": np.float64,
}


@dataclass(frozen=True, eq=False)
class PackedBlock:
    """Samples of several sensors in one set of columns (the worker → supervisor transport).

    Packing many sensors into a few arrays keeps the per-message cost independent of the
    number of sensors; :meth:`unpack` splits it into one
    :class:`~mimucap.core.sensor_samples.SensorSamples` per sensor.
    ``sensor_index`` (N,) indexes ``sensor_ids``; every row has the same ``channels``.
    """

    source: str
    sensor_ids: tuple[str, ...]
    sensor_index: np.ndarray
    seq: np.ndarray
    device_time_s: np.ndarray
    host_time_s: np.ndarray
    receive_time_s: np.ndarray
    channels: dict[str, np.ndarray]

    def __len__(self) -> int:
        return int(self.seq.shape[0])

    def unpack(self) -> list[SensorSamples]:
        """One record per sensor, in order of first appearance; rows keep their order; ``t_s``
        is the host time."""
        order = np.argsort(self.sensor_index, kind="stable")
        index = self.sensor_index[order]
        starts = np.flatnonzero(np.r_[True, index[1:] != index[:-1]])
        ends = np.r_[starts[1:], len(index)]
        seq, device = self.seq[order], self.device_time_s[order]
        host, receive = self.host_time_s[order], self.receive_time_s[order]
        present = [self.channels.get(name) for name in CHANNELS]
        present = [None if values is None else values[order] for values in present]
        names, source = self.sensor_ids, self.source
        blocks = []
        # positional arguments: the field order of SensorSamples (t_s, seq, CHANNELS, clocks)
        for start, end, sensor in zip(starts.tolist(), ends.tolist(), index[starts].tolist()):
            blocks.append(SensorSamples(
                names[sensor], host[start:end], seq[start:end],
                *[None if v is None else v[start:end] for v in present],
                device[start:end], receive[start:end], source))
        return blocks


def join_packed_blocks(blocks: Sequence[PackedBlock]) -> list[PackedBlock]:
    """Consecutive packed blocks of one source joined into as few as possible: one per set of
    channels, rows in their order. The supervisor joins what one poll drained, so that each
    sensor comes out of :meth:`PackedBlock.unpack` once per poll, not once per message.

    A worker's sensor list only grows (new sensors are appended), so a block whose
    ``sensor_ids`` extend another's joins it; blocks of other sources or with unrelated
    sensor lists stay apart.
    """
    groups: list[tuple[tuple[str, ...], list[PackedBlock]]] = []  # (longest sensor list, blocks)
    open_groups: dict[tuple, int] = {}  # (source, channels) -> index of its last group
    for block in blocks:
        key = (block.source, tuple(block.channels))
        index = open_groups.get(key)
        if index is not None:
            names, members = groups[index]
            shorter, longer = sorted((names, block.sensor_ids), key=len)
            if longer[: len(shorter)] == shorter:
                members.append(block)
                groups[index] = (longer, members)
                continue
        open_groups[key] = len(groups)
        groups.append((block.sensor_ids, [block]))
    return [members[0] if len(members) == 1 else _join(names, members) for names, members in groups]


def _join(sensor_ids: tuple[str, ...], blocks: list[PackedBlock]) -> PackedBlock:
    """One packed block of ``blocks`` (one source, same channels; indices into ``sensor_ids``)."""
    join = lambda name: np.concatenate([getattr(b, name) for b in blocks])  # noqa: E731
    return PackedBlock(
        source=blocks[0].source, sensor_ids=sensor_ids, sensor_index=join("sensor_index"), seq=join("seq"),
        device_time_s=join("device_time_s"), host_time_s=join("host_time_s"),
        receive_time_s=join("receive_time_s"),
        channels={name: np.concatenate([b.channels[name] for b in blocks]) for name in blocks[0].channels})


class _Group:
    __slots__ = ("channels", "index", "seq", "device", "host", "receive", "values")

    def __init__(self, channels: tuple[str, ...]) -> None:
        self.channels = channels
        self.index: list[int] = []
        self.seq: list[int] = []
        self.device: list[float] = []
        self.host: list[float] = []
        self.receive: list[float] = []
        self.values: list[list] = [[] for _ in channels]


class BlockBuilder:
    """Collects accepted samples of any sensors and packs them into :class:`PackedBlock` s
    (one per set of channels present)."""

    def __init__(self, source: str) -> None:
        self.source = source
        self._names: list[str] = []
        self._name_index: dict[str, int] = {}
        self._groups: dict[tuple[str, ...], _Group] = {}
        self._count = 0
        self.oldest_receive_time_s: float | None = None

    def __len__(self) -> int:
        return self._count

    def add(self, sensor_name: str, seq: int, sample: Sample, host_time_s: float,
            receive_time_s: float) -> None:
        """Append one validated sample (``seq`` already unwrapped)."""
        index = self._name_index.get(sensor_name)
        if index is None:
            index = self._name_index[sensor_name] = len(self._names)
            self._names.append(sensor_name)
        channels = sample.channels()
        group = self._groups.get(channels)
        if group is None:
            group = self._groups[channels] = _Group(channels)
        group.index.append(index)
        group.seq.append(seq)
        group.device.append(sample.device_time_s)
        group.host.append(host_time_s)
        group.receive.append(receive_time_s)
        for values, name in zip(group.values, channels):
            values.append(getattr(sample, name))
        self._count += 1
        if self.oldest_receive_time_s is None:
            self.oldest_receive_time_s = receive_time_s

    def take(self) -> list[PackedBlock]:
        """All pending samples, packed; the builder is empty afterwards."""
        names = tuple(self._names)
        packed = [PackedBlock(
            source=self.source, sensor_ids=names,
            sensor_index=np.asarray(group.index, dtype=np.int32),
            seq=np.asarray(group.seq, dtype=np.int64),
            device_time_s=np.asarray(group.device, dtype=np.float64),
            host_time_s=np.asarray(group.host, dtype=np.float64),
            receive_time_s=np.asarray(group.receive, dtype=np.float64),
            channels={name: np.asarray(values, dtype=_CHANNEL_DTYPES[name])
                      for name, values in zip(group.channels, group.values)})
            for group in self._groups.values()]
        self._groups.clear()
        self._count = 0
        self.oldest_receive_time_s = None
        return packed
