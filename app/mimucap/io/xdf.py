"""MimuCap's raw-sample streams in an XDF file (LabRecorder's format) as a session.

A LabRecorder XDF of a session streamed by MimuCap (``mimucap stream --lsl`` or the window's
Lab Streaming Layer switch) holds one stream per sensor, named ``MimuCap raw <sensor>`` (type
``IMU``, :mod:`mimucap.session.streaming.lsl_streamer`): channels ``acc_x..z`` (m/s², sensor frame), ``gyr_x..z``
(rad/s), ``mag_x..z`` (µT, before the magnetometer calibration) and ``seq``, each sample stamped
with its sample time on the LSL clock; the stream's meta-data names the sensor, its segment and
its device. :func:`session_from_xdf` reads those streams (with ``pyxdf``, which applies the
file's clock offsets, so streams recorded from other machines are on the recorder's clock) into
a :class:`~mimucap.io.session.Session`: session time 0 is the earliest raw sample, and the
metadata ``lsl_clock.session_start_lsl_s`` says which LSL time that is. Every marker stream in
the file (one string channel) becomes session markers at its samples' times. The session then
runs through the one processing path like a recording of ours: magnetometer calibrations
stored for its devices, body calibration (``mimucap bodycal``, or in the review).

Channels a sensor did not send are NaN in the stream and absent (``None``) in the session; rows
where a channel it sends is not finite are left out and counted (metadata ``source.dropped_rows``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

#: The stream type and name prefix of MimuCap's raw-sample streams.
RAW_TYPE = "IMU"
RAW_PREFIX = "MimuCap raw "
#: Raw channel labels → the session's channels (three columns each).
RAW_CHANNELS = {"acc": ("acc_x", "acc_y", "acc_z"), "gyr": ("gyr_x", "gyr_y", "gyr_z"),
                "mag_uT": ("mag_x", "mag_y", "mag_z")}
PYXDF_HINT = "reading XDF files needs the pyxdf package: pip install 'mimucap[lsl]', or pip install pyxdf"


def _first(node: Any, *path: str) -> Any:
    """The first value along ``path`` in pyxdf's nested lists of dicts (``None`` when absent)."""
    for key in path:
        if isinstance(node, list):
            node = node[0] if node else None
        if not isinstance(node, dict) or key not in node:
            return None
        node = node[key]
    if isinstance(node, list):
        node = node[0] if node else None
    return node


def _channel_labels(info: dict) -> list[str]:
    channels = _first(info, "desc", "channels")
    if not isinstance(channels, dict):
        return []
    return [str(_first(channel, "label") or "") for channel in channels.get("channel", [])]


def _is_raw(info: dict) -> bool:
    return _first(info, "type") == RAW_TYPE and str(_first(info, "name") or "").startswith(RAW_PREFIX)


def _is_marker(stream: dict) -> bool:
    info = stream["info"]
    return _first(info, "channel_format") == "string" and str(_first(info, "channel_count")) == "1"


def session_from_xdf(path: str | Path):
    """The :class:`~mimucap.io.session.Session` of MimuCap's raw streams in XDF file ``path``
    (see the module doc); ``ValueError`` naming the file when it holds none, or naming the
    stream whose channels do not fit."""
    try:
        import pyxdf
    except ImportError as error:
        raise ValueError(f"{path}: {PYXDF_HINT} ({error})") from None
    from mimucap.core.sensor_samples import SensorSamples
    from mimucap.io.session import Marker, Session

    path = Path(path)
    try:
        streams, _header = pyxdf.load_xdf(str(path), dejitter_timestamps=False)
    except (OSError, EOFError) as error:
        raise OSError(f"{path}: cannot read it as XDF: {error}") from None
    except Exception as error:  # pyxdf raises plain Exceptions for a foreign or damaged file
        raise ValueError(f"{path}: not a readable XDF file: {error}") from None
    raw = [s for s in streams if _is_raw(s["info"]) and len(s["time_stamps"])]
    if not raw:
        names = ", ".join(repr(_first(s["info"], "name")) for s in streams) or "none"
        raise ValueError(f"{path}: no MimuCap raw-sample stream (type {RAW_TYPE}, named '{RAW_PREFIX}<sensor>') "
                         f"with samples in it; its streams: {names}")
    t0 = min(float(s["time_stamps"][0]) for s in raw)
    sensors: dict[str, SensorSamples] = {}
    devices: dict[str, dict] = {}
    dropped: dict[str, int] = {}
    for stream in raw:
        info = stream["info"]
        name = str(_first(info, "name"))
        sensor_id = str(_first(info, "desc", "acquisition", "sensor_id") or name[len(RAW_PREFIX):])
        labels = _channel_labels(info)
        values = np.asarray(stream["time_series"], dtype=np.float64)
        missing = [label for columns in RAW_CHANNELS.values() for label in columns if label not in labels]
        if missing or values.ndim != 2 or values.shape[1] != len(labels):
            raise ValueError(f"{path}: stream {name!r} lacks the channels {', '.join(missing) or '(shape)'} "
                             f"of a MimuCap raw stream (it has: {', '.join(labels)})")
        fields = {key: values[:, [labels.index(c) for c in columns]] for key, columns in RAW_CHANNELS.items()}
        fields = {key: v for key, v in fields.items() if np.isfinite(v).any()}
        keep = np.all([np.isfinite(v).all(axis=1) for v in fields.values()], axis=0) if fields else \
            np.ones(len(values), bool)
        t_s = np.asarray(stream["time_stamps"], dtype=np.float64) - t0
        seq = values[:, labels.index("seq")] if "seq" in labels else np.arange(len(values), dtype=np.float64)
        keep &= np.isfinite(seq)
        if not keep.all():
            dropped[sensor_id] = int((~keep).sum())
        segment = _first(info, "desc", "acquisition", "segment") or None
        sensors[sensor_id] = SensorSamples.checked(
            sensor_id, t_s[keep], seq[keep].astype(np.int64), segment=segment, source=name,
            **{key: v[keep] for key, v in fields.items()})
        device_id = _first(info, "desc", "acquisition", "device_id")
        devices[sensor_id] = ({"device_id": str(device_id)} if device_id else
                              {"device_id": None, "missing": "the XDF stream does not name the sensor's device"})
    markers = []
    for stream in streams:
        if _is_marker(stream):
            for value, stamp in zip(stream["time_series"], stream["time_stamps"]):
                markers.append(Marker(float(stamp) - t0, str(value[0] if isinstance(value, list) else value)))
    markers.sort(key=lambda m: m.t_s)
    segments = {sid: s.segment for sid, s in sensors.items()}
    model = "fifteen_segment" if any(str(s).startswith(("hand", "foot", "head")) for s in segments.values() if s) \
        else "ten_segment"
    metadata = {
        "source": {"kind": "xdf", "file": path.name, "streams": [str(_first(s["info"], "name")) for s in raw],
                   "dropped_rows": dropped},
        "skeleton_model": model,
        "sensor_segments": segments,
        "devices": devices,
        "lsl_clock": {"session_start_lsl_s": t0,
                      "note": "LSL time of an instant = its session time + session_start_lsl_s"},
    }
    return Session(metadata=metadata, sensors=sensors, markers=markers)
