"""The records of a recorder's journal: their kinds and payloads, and the journal's file names.

A recording is journaled beside its session file (``SESSION.h5.journal``:
:func:`journal_path_for`) as records of the crash-safe journal file (:mod:`.file`), each a kind
byte and a payload:

* :data:`KIND_START` — JSON: the session metadata, the host's monotonic time of ``t_s = 0``,
  the UTC start and the flush interval (:func:`encode_start`);
* :data:`KIND_BLOCK` — a block of one sensor's samples (:func:`encode_block`: the named-array
  layout of :mod:`.arrays`, header fields ``source`` and ``sensor_id``; arrays ``seq``,
  ``device_time_s``, ``host_time_s`` (the block's ``t_s``: the host's monotonic clock),
  ``receive_time_s`` and the channels present);
* :data:`KIND_MARKER` — JSON ``{"host_s": host monotonic time, "label": ...}`` (:func:`encode_marker`);
* :data:`KIND_STATUS` — JSON: the acquisition statistics at the end (:func:`encode_json`);
* :data:`KIND_END` — JSON: why the recording ended, when, and the devices told by then
  (:func:`encode_end`);
* :data:`KIND_TRUTH` — a block of the simulator's ground truth (:func:`encode_truth`), kept
  beside the samples for evaluation only.

Every decoder refuses bytes that do not add up with ``ValueError``. :mod:`.to_session` reads a
journal back as a session.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mimucap.core.sensor_samples import CHANNELS, SensorSamples
from mimucap.io.journal.arrays import DTYPES, decode_arrays, encode_arrays

#: The journal of ``SESSION.h5`` is ``SESSION.h5`` plus this.
JOURNAL_SUFFIX = ".journal"
#: A damaged journal is kept under its name plus this after recovery (nothing is thrown away).
DAMAGED_SUFFIX = ".damaged"
KIND_START = 1     #: JSON: metadata and start time
KIND_BLOCK = 2     #: a sample block (:func:`encode_block`)
KIND_MARKER = 3    #: JSON: {"host_s": host time, "label": ...}
KIND_STATUS = 4    #: JSON: acquisition statistics at the end
KIND_END = 5       #: JSON: why the recording ended
KIND_TRUTH = 6     #: a block of the simulator's ground truth (:func:`encode_truth`)

_TIME_ARRAYS = ("seq", "device_time_s", "host_time_s", "receive_time_s")
#: A record's field behind each journal array name that differs from it.
_FIELDS = {"host_time_s": "t_s"}


def journal_path_for(session_path: str | os.PathLike[str]) -> Path:
    """``SESSION.h5`` → ``SESSION.h5.journal``."""
    path = Path(session_path)
    return path.with_name(path.name + JOURNAL_SUFFIX)


def _json_safe(value: Any) -> Any:
    """``value`` with NaN/infinite floats replaced by ``None`` (session metadata is strict JSON)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    return value


def encode_json(value: Any) -> bytes:
    """A JSON record's payload (NaN and infinite numbers as ``null``; other objects as their text)."""
    return json.dumps(_json_safe(value), default=str).encode("utf-8")


def encode_start(metadata: Mapping[str, Any], start_host_s: float, started_utc: str, flush_interval_s: float) -> bytes:
    """The :data:`KIND_START` payload: ``start_host_s`` (host monotonic s) is ``t_s = 0``."""
    return json.dumps({"metadata": dict(metadata), "start_host_s": float(start_host_s), "started_utc": started_utc,
                       "flush_interval_s": flush_interval_s}).encode("utf-8")


def encode_marker(host_s: float, label: str) -> bytes:
    """The :data:`KIND_MARKER` payload of ``label`` at host monotonic ``host_s``."""
    return json.dumps({"host_s": float(host_s), "label": str(label)}).encode("utf-8")


def encode_end(reason: str, stopped_host_s: float, devices: Mapping[str, Any] | None = None) -> bytes:
    """The :data:`KIND_END` payload: why and when (host monotonic s) the recording ended, and
    ``devices`` (sensor id → its device's JSON) told by then."""
    end: dict[str, Any] = {"reason": reason, "stopped_host_s": float(stopped_host_s)}
    if devices:
        end["devices"] = dict(devices)
    return json.dumps(end).encode("utf-8")


def decode_json(payload: bytes) -> Any:
    """The value of a JSON record (``ValueError`` when it is not JSON)."""
    return json.loads(payload)


def encode_block(block: SensorSamples) -> bytes:
    """The record of ``block`` (from a source: every clock present): times int64/float64,
    channels float64, calibration int8."""
    arrays = []
    for name in _TIME_ARRAYS + CHANNELS:
        value = getattr(block, _FIELDS.get(name, name))
        if value is not None:
            value = np.asarray(value)
            dtype = "int8" if name == "calibration" else "int64" if value.dtype.kind == "i" else "float64"
            arrays.append((name, value.astype(DTYPES[dtype], copy=False)))
    return encode_arrays({"source": block.source, "sensor_id": block.sensor_id}, len(block), arrays)


def decode_block(data: bytes) -> SensorSamples:
    """The block encoded in ``data``; ``ValueError`` if the bytes are inconsistent."""
    header, values = decode_arrays(data, "sample block record")
    unknown = [name for name in values if name not in _TIME_ARRAYS + CHANNELS]
    if unknown or "sensor_id" not in header or any(name not in values for name in _TIME_ARRAYS):
        raise ValueError(f"sample block record has unknown arrays {unknown}, or lacks its sensor id or a "
                         f"time array")
    return SensorSamples(source=str(header.get("source", "")), sensor_id=str(header["sensor_id"]),
                         **{_FIELDS.get(name, name): value for name, value in values.items()})


@dataclass
class TruthPart:
    """One decoded :data:`KIND_TRUTH` record (see :func:`encode_truth`): host monotonic times
    ``host_s`` (n,) s and the truth at them."""

    host_s: np.ndarray
    q_world_from_segment: dict[str, np.ndarray]
    joint_angles_deg: dict[str, np.ndarray]
    root_position_m: np.ndarray
    note: str


#: Prefixes of a truth record's per-segment and per-column array names.
_SEGMENT_PREFIX, _ANGLE_PREFIX = "q_world_from_segment:", "joint_angles_deg:"


def encode_truth(host_s, q_world_from_segment: Mapping[str, np.ndarray], joint_angles_deg: Mapping[str, np.ndarray],
                 root_position_m, note: str = "") -> bytes:
    """A truth block as a journal payload (:func:`~mimucap.io.journal.arrays.encode_arrays`,
    header field ``note``): float64 arrays ``host_s`` (n,), ``q_world_from_segment:<segment>``
    (n, 4), ``joint_angles_deg:<column>`` (n,) and ``root_position_m`` (n, 3)."""
    host = np.asarray(host_s, dtype=np.float64).reshape(-1)
    n = len(host)
    arrays = [("host_s", host)]
    arrays += [(_SEGMENT_PREFIX + name, np.asarray(q, dtype=np.float64).reshape(n, 4))
               for name, q in q_world_from_segment.items()]
    arrays += [(_ANGLE_PREFIX + name, np.asarray(a, dtype=np.float64).reshape(n))
               for name, a in joint_angles_deg.items()]
    arrays.append(("root_position_m", np.asarray(root_position_m, dtype=np.float64).reshape(n, 3)))
    return encode_arrays({"note": str(note)}, n, arrays)


def decode_truth(payload: bytes) -> TruthPart:
    """The inverse of :func:`encode_truth`; ``ValueError`` when the payload does not add up."""
    header, arrays = decode_arrays(payload, "truth record")
    if "host_s" not in arrays or "root_position_m" not in arrays:
        raise ValueError("truth record lacks its host times or root positions")

    def named(prefix: str) -> dict[str, np.ndarray]:
        return {name[len(prefix):]: value for name, value in arrays.items() if name.startswith(prefix)}

    return TruthPart(arrays["host_s"], named(_SEGMENT_PREFIX), named(_ANGLE_PREFIX), arrays["root_position_m"],
                      str(header.get("note", "")))
