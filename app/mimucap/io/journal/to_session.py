"""A recorder's journal read back as a session: every intact record, in time order.

Used when a recording stops (the journal becomes the session file) and after a crash
(``mimucap recover``): the session holds every sample block, marker and truth block the journal
kept (:mod:`.records`), its metadata from the start record (or, when that record was damaged,
times from the first sample and no metadata), and what reading could not use
(:func:`damage_report`).

Times: journal records carry host monotonic times (``time.monotonic()``, s); the session's
samples count from the start of the recording (``t_s − start_host_s``).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mimucap.core.sensor_samples import SensorSamples, concatenate_samples
from mimucap.io.journal.file import JournalContents, iter_journal
from mimucap.io.journal.records import (
    KIND_BLOCK, KIND_END, KIND_MARKER, KIND_START, KIND_STATUS, KIND_TRUTH, TruthPart, decode_block, decode_json,
    decode_truth,
)
from mimucap.io.session import Marker, Session, SessionTruth

#: Journal records read between two progress reports of :func:`session_from_journal`.
PROGRESS_EVERY_RECORDS = 4096
def session_from_journal(journal_path: str | os.PathLike[str],
                         progress: Callable[[float], None] | None = None) -> tuple[Session, JournalContents]:
    """Rebuild the session from every intact record of a recorder journal. ``progress``
    (optional) is called with the fraction (0..1) of the journal's bytes read so far."""
    journal_path = Path(journal_path)
    contents = JournalContents(journal_path)
    start: dict[str, Any] | None = None
    status: Any = None
    end: dict[str, Any] | None = None
    markers: list[Any] = []
    per_sensor: dict[str, list[SensorSamples]] = {}
    truth_parts: list[TruthPart] = []
    for index, (kind, payload) in enumerate(iter_journal(journal_path, contents)):
        if progress is not None and index % PROGRESS_EVERY_RECORDS == 0 and contents.file_bytes:
            progress(contents.valid_bytes / contents.file_bytes)
        try:
            if kind == KIND_START:
                start = decode_json(payload)
            elif kind == KIND_BLOCK:
                block = decode_block(payload)
                per_sensor.setdefault(block.sensor_id, []).append(block)
            elif kind == KIND_MARKER:
                markers.append(decode_json(payload))
            elif kind == KIND_STATUS:
                status = decode_json(payload)
            elif kind == KIND_END:
                end = decode_json(payload)
            elif kind == KIND_TRUTH:
                truth_parts.append(decode_truth(payload))
        except ValueError as error:
            raise ValueError(f"{journal_path}: record {index + 1} is damaged: {error}") from None
    if start is None:
        start = _start_from_samples(per_sensor)
        if start is None:
            raise ValueError(f"{journal_path}: the journal holds no recording start (nothing to recover)")
    try:
        t0 = float(start["start_host_s"])
        metadata = dict(start.get("metadata") or {})
        markers = [(float(m["host_s"]) - t0, str(m["label"])) for m in markers]
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise ValueError(f"{journal_path}: the start or a marker record is damaged: {error!r}") from None
    segments = metadata.pop("sensor_segments", {}) or {}
    calibrations = metadata.pop("calibrations", {}) or {}
    recording = {"started_utc": start.get("started_utc"), "start_host_monotonic_s": t0,
                 "start_record_lost": bool(start.get("lost", False)),
                 "journal_flush_interval_s": start.get("flush_interval_s"),
                 "ended": (end or {}).get("reason", "crash (recovered from the journal)"),
                 "journal_discarded_bytes": contents.discarded_bytes,
                 "journal_skipped_bytes": [[span.offset, span.size] for span in contents.skipped]}
    metadata["recording"] = recording
    told_at_end = (end or {}).get("devices")
    if isinstance(told_at_end, dict) and told_at_end:
        # the devices known at the start stand (their calibrations were chosen for them)
        metadata["devices"] = {**told_at_end, **(metadata.get("devices") or {})}
    if status is not None:
        metadata["acquisition"] = status
    sensors = {sensor_id: _recorded(blocks, t0, segments.get(sensor_id))
               for sensor_id, blocks in sorted(per_sensor.items())}
    session = Session(metadata=metadata, sensors=sensors,
                      markers=[Marker(t, label) for t, label in markers],
                      truth=_joined_truth(truth_parts, t0), calibrations=dict(calibrations))
    return session, contents


def _joined_truth(parts: list[TruthPart], t0: float) -> SessionTruth | None:
    """The truth blocks of a recording as one :class:`SessionTruth` on session time (``t_s =
    host − t0``, rows before the start dropped, sorted, a repeated instant kept once);
    ``None`` when there is none. Blocks whose names differ from the first one's are left out
    (one recording shows one simulated suit)."""
    parts = [p for p in parts if p.q_world_from_segment.keys() == parts[0].q_world_from_segment.keys()
             and p.joint_angles_deg.keys() == parts[0].joint_angles_deg.keys()] if parts else []
    if not parts:
        return None
    t = np.concatenate([p.host_s for p in parts]) - t0
    order = np.argsort(t, kind="stable")
    keep = order[t[order] >= 0.0]
    if len(keep):
        keep = keep[np.r_[True, np.diff(t[keep]) > 0.0]]

    def joined(pick) -> np.ndarray:
        return np.concatenate([pick(p) for p in parts])[keep]

    return SessionTruth(
        t_s=t[keep],
        q_world_from_segment={name: joined(lambda p, k=name: p.q_world_from_segment[k])
                              for name in parts[0].q_world_from_segment},
        joint_angles_deg={name: joined(lambda p, k=name: p.joint_angles_deg[k]) for name in parts[0].joint_angles_deg},
        extra={"root_position_m": joined(lambda p: p.root_position_m)},
        attributes={"origin": parts[0].note} if parts[0].note else {},
    )


def _start_from_samples(per_sensor: Mapping[str, list[SensorSamples]]) -> dict[str, Any] | None:
    """A stand-in for a damaged start record: time zero at the first sample (host monotonic
    s), no metadata (source, subject and sensor segments are lost with the record); ``None``
    when there is no sample either."""
    first = min((float(np.min(b.t_s)) for blocks in per_sensor.values() for b in blocks if len(b)),
                default=None)
    if first is None:
        return None
    return {"metadata": {}, "start_host_s": first, "started_utc": None, "flush_interval_s": None, "lost": True}


def _recorded(blocks: list[SensorSamples], t0: float, segment: str | None) -> SensorSamples:
    """One sensor's journaled blocks as the session keeps them: rows in host-time order, ``t_s``
    since the recording started (host monotonic ``t0`` s), a channel that some blocks lacked
    NaN (−1 for the calibration status) in their rows: every sample is kept, and what it did
    not send stays recognisable."""
    joined = concatenate_samples(blocks, missing="fill")
    joined = joined.rows(np.argsort(joined.t_s, kind="stable"))
    return replace(joined, t_s=joined.t_s - t0, receive_time_s=None, source="", segment=segment)


def damage_report(contents: JournalContents) -> str:
    """What reading a journal could not use, one clause per damaged stretch: skipped bytes in
    the middle (offset, size and the records recovered after them) and a torn tail."""
    parts = [f"skipped {span.size} damaged bytes at offset {span.offset}; "
             f"{contents.records_after(span)} records after it recovered" for span in contents.skipped]
    if contents.torn:
        parts.append(f"the last {contents.torn_bytes} bytes (from offset {contents.valid_bytes}) are a torn "
                     f"tail holding no intact record (the unflushed moment of a crash)")
    return "; ".join(parts)
