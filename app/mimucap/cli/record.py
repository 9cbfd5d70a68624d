"""``mimucap record``: record a session without the GUI (crash-safe, see ``mimucap recover``).

    mimucap record --source SPEC --duration S --out SESSION.h5 [--sensors 1-10] [--allow IP ...]
    mimucap record --source SPEC --duration S --subject ID [--library DIR] [--condition TEXT] [--tags A,B]

SPEC is one of ``simulated[:SCENARIO][@ROOM]``, ``udp:BIND_ADDRESS:PORT``, ``serial:DEVICE[@BAUD]``,
``replay:FILE[@SPEED]``. Samples are journaled to ``SESSION.h5.journal`` as they arrive
(flushed at least every second) and turned into the session file at the end. Ctrl+C or
SIGTERM end the recording early and still write the file. The duration counts from the moment
every source is up (its worker started, its port bound or its device opened; at most
:data:`STARTUP_LIMIT_S` after the start), so that a slow start does not shorten the recording. The exit code is 1 when the
recording ended by an error (the message says how to recover the journal), and when it
received no sample at all (the message gives the source's last complaint, e.g. a device that
cannot be opened; the empty session file is still written). Options that do not apply to the
source are refused rather than ignored: ``--sensors`` (udp, serial), ``--allow`` (udp),
``--sensor-count`` and ``--rate`` (simulated).
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from mimucap.acquisition.source_spec import (
    VALID_FORMS, ReplaySpec, SerialSpec, SimulatedSpec, SourceSpec, UdpSpec, format_source_spec, parse_source_spec,
)

if TYPE_CHECKING:
    from mimucap.acquisition.supervisor import Supervisor


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "record", help="record a session without the GUI",
        description=__doc__.split("\n\n")[0].replace("``", "") + " Valid sources: " + ", ".join(VALID_FORMS))
    parser.add_argument("--source", required=True, metavar="SPEC", help="data source: " + ", ".join(VALID_FORMS))
    parser.add_argument("--duration", required=True, type=float, metavar="S", help="seconds to record")
    parser.add_argument("--out", type=Path, metavar="SESSION.h5", help="session file to write (or --subject)")
    parser.add_argument("--subject", metavar="ID", help="record into the library for subject ID (instead of --out)")
    parser.add_argument("--library", type=Path, metavar="DIR",
                        help="library folder for --subject (default: MIMUCAP_LIBRARY, else the application's)")
    parser.add_argument("--condition", default="", metavar="TEXT", help="with --subject: e.g. 'pre-op', '6 weeks'")
    parser.add_argument("--tags", default="", metavar="A,B", help="with --subject: comma-separated tags")
    parser.add_argument("--trial", metavar="NAME", help="with --subject: trial name (default: the next trialNN of the day)")
    parser.add_argument("--sensors", metavar="IDS", help="expected sensor ids, e.g. 1-10 (others are counted and ignored)")
    parser.add_argument("--allow", nargs="+", metavar="IP", help="UDP sender addresses allowed (default: any)")
    parser.add_argument("--sensor-count", type=int, metavar="N", help="simulated suit: number of sensors")
    parser.add_argument("--rate", type=float, metavar="HZ", help="simulated suit: sample rate")
    parser.add_argument("--flush-interval", type=float, default=0.5, metavar="S",
                        help="journal flush interval in seconds (at most 1, default 0.5)")
    parser.add_argument("--quiet", action="store_true", help="no progress lines")
    parser.set_defaults(func=run)


class _StopRequest:
    def __init__(self) -> None:
        self.requested = False

    def __call__(self, signum, frame) -> None:
        self.requested = True


def _status(supervisor: Supervisor) -> dict:
    stats = {name: {"received": s.received, "drops": s.drops, "rate_hz": round(s.rate_hz, 2),
                    "latency_p50_ms": round(s.latency_p50_s * 1e3, 3),
                    "latency_p95_ms": round(s.latency_p95_s * 1e3, 3), "rejections": s.rejections}
             for name, s in supervisor.stats().items()}
    sources = {name: {"state": s.state, "message": s.message, "restarts": s.restarts,
                      "failures": s.failures, "last_error": s.last_error,
                      "reconnects": s.reconnects, "node_restarts": s.node_restarts, "rejections": s.rejections,
                      "unknown_senders": s.unknown_sensors, "overflow_samples": s.overflow_samples,
                      "clocks": {k: {"drift_ppm": c.drift_ppm, "uncertainty_s": c.uncertainty_s}
                                 for k, c in s.clocks.items()}}
               for name, s in supervisor.sources().items()}
    return {"sensors": stats, "sources": sources}


def _devices(supervisor: Supervisor) -> dict:
    """Sensor → what its source told of its device (the session's ``devices``)."""
    from mimucap.core.device_identity import devices_to_json

    told = {}
    for source in supervisor.sources().values():
        told.update(source.devices)
    return devices_to_json(told)


#: The source kinds each source-specific option applies to (it is refused for the others).
OPTION_SOURCES = {
    "--sensors": (UdpSpec, SerialSpec),
    "--allow": (UdpSpec,),
    "--sensor-count": (SimulatedSpec,),
    "--rate": (SimulatedSpec,),
}
_SOURCE_NAMES = {UdpSpec: "udp", SerialSpec: "serial", SimulatedSpec: "simulated", ReplaySpec: "replay"}


def check_options(args: argparse.Namespace, spec: SourceSpec) -> None:
    """``ValueError`` for an option value that would be replaced by a default or ignored:
    an option the source does not use, a sensor count below 1, a rate that is not a positive
    number (the id list and the replay file are checked where they are read)."""
    given = {"--sensors": args.sensors, "--allow": args.allow, "--sensor-count": args.sensor_count,
             "--rate": args.rate}
    for option, kinds in OPTION_SOURCES.items():
        if given[option] is not None and not isinstance(spec, kinds):
            names = " and ".join(_SOURCE_NAMES[k] for k in kinds)
            raise ValueError(f"{option} applies to {names} sources only, not to "
                             f"{_SOURCE_NAMES.get(type(spec), 'this')} ({format_source_spec(spec)})")
    if args.sensor_count is not None and args.sensor_count < 1:
        raise ValueError(f"--sensor-count must be at least 1, got {args.sensor_count}")
    if args.rate is not None and not (math.isfinite(args.rate) and args.rate > 0):
        raise ValueError(f"--rate must be a positive number of Hz, got {args.rate:g}")


def run(args: argparse.Namespace) -> int:
    from mimucap.acquisition.supervisor import Supervisor
    from mimucap.session.recording import Recorder, RecorderSettings
    from mimucap.session.sources import SourceOptions, parse_sensor_ids, sensor_segments, source_configs

    if not args.duration > 0:
        raise ValueError(f"--duration must be > 0 s, got {args.duration}")
    spec = parse_source_spec(args.source)
    check_options(args, spec)
    try:
        sensor_ids = parse_sensor_ids(args.sensors)
    except ValueError as error:
        raise ValueError(f"--sensors {args.sensors!r}: {error}") from None
    options = SourceOptions(sensor_ids=sensor_ids,
                            allowed_addresses=tuple(args.allow) if args.allow else None,
                            sensor_count=args.sensor_count, rate_hz=args.rate)
    configs = source_configs(spec, options)
    metadata = {"source": format_source_spec(spec), "sensor_segments": sensor_segments(configs)}
    library = None
    if args.subject is not None:
        library, args.out, library_metadata = library_recording(args)
        metadata.update(library_metadata)
    elif args.out is None:
        raise ValueError("give --out SESSION.h5, or --subject ID (with --library DIR, or the configured library)")
    else:
        given = [name for name, value in (("--library", args.library), ("--condition", args.condition),
                                           ("--tags", args.tags), ("--trial", args.trial)) if value]
        if given:
            raise ValueError(f"{', '.join(given)} apply to recordings into the library only (with --subject)")
    recorder = Recorder(args.out, metadata,
                        RecorderSettings(flush_interval_s=args.flush_interval))
    recorder.start()  # refuses an existing file or journal before anything runs
    stop = _StopRequest()
    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    supervisor = Supervisor(configs)
    reason = "duration"
    last_troubles = ""  # the sources' last complaint (e.g. a device that cannot be opened)
    try:
        supervisor.start()
        started = time.monotonic()
        end = math.inf  # set when the sources are up: --duration seconds of data, however slow the start
        next_line = started + 1.0
        while True:
            now = time.monotonic()
            if end == math.inf and (_sources_up(supervisor) or now - started >= STARTUP_LIMIT_S):
                end = now + args.duration
            if now >= end:
                break
            if stop.requested:
                reason = "interrupted"
                break
            if supervisor.all_finished():
                failed = any(s.state == "failed" for s in supervisor.sources().values())
                reason = "source failed" if failed else "source finished"
                break
            blocks = supervisor.poll(min(0.05, end - now))  # 0.05 s while the sources start
            for host_s, label in supervisor.take_markers():
                recorder.add_marker(label, host_s)
            if not recorder.add_blocks(blocks):
                reason = "write error"
                break
            if now >= next_line:
                next_line = now + 1.0
                total = sum(recorder.samples.values())
                troubles = "; ".join(f"{name} {s.state}: {s.message}" for name, s in supervisor.sources().items()
                                     if s.state not in ("running", "starting"))
                last_troubles = troubles or last_troubles
                if not args.quiet:
                    print(f"recording {now - recorder.start_host_s:6.1f} s: {total} samples from "
                          f"{len(recorder.samples)} sensors" + (f" ({troubles})" if troubles else ""),
                          file=sys.stderr, flush=True)
    finally:
        recorder.add_blocks(supervisor.stop())
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    status = _status(supervisor)
    result = recorder.stop(status, reason, devices=_devices(supervisor))
    print(f"{'sensor':>10} {'samples':>8} {'drops':>6} {'rate Hz':>8} {'p95 ms':>7}  rejections")
    for name, s in status["sensors"].items():
        rejected = ", ".join(f"{k}: {v}" for k, v in s["rejections"].items()) or "-"
        print(f"{name:>10} {s['received']:>8} {s['drops']:>6} {s['rate_hz']:>8.1f} "
              f"{s['latency_p95_ms']:>7.2f}  {rejected}")
    for name, source in status["sources"].items():
        if source["rejections"] or source["state"] == "failed":
            print(f"source {name}: {source['state']} {source['message']} rejections {source['rejections']}")
    if result.session_path is None or recorder.failure is not None:
        print(f"mimucap record: error: {result.message}", file=sys.stderr)
        return 1
    failed = {name: s for name, s in status["sources"].items() if s["state"] == "failed"}
    if failed:
        reasons = "; ".join(f"source {name} failed: {s['message']}" for name, s in failed.items())
        print(f"mimucap record: error: {reasons} (wrote {result.session_path} with "
              f"{sum(result.samples.values())} samples)", file=sys.stderr)
        return 1
    if sum(result.samples.values()) == 0:
        print(f"mimucap record: error: no sample was received in {_reason_text(reason)}"
              f"{' (' + last_troubles + ')' if last_troubles else ''}; wrote the empty session "
              f"{result.session_path}", file=sys.stderr)
        return 1
    print(f"wrote {result.session_path} ({sum(result.samples.values())} samples, "
          f"{len(result.samples)} sensors, ended: {reason})")
    if library is not None:
        entry = library.add_file(result.session_path)
        print(f"library {library.root}: subject {entry.subject_id}, trial {entry.trial}")
    if result.message:
        print(result.message)
    return 0


def library_recording(args: argparse.Namespace):
    """``(library, session path, metadata)`` of a recording into the library for ``--subject``:
    the subject's record as the library knows it (defaults for a new subject), and the
    condition, tags and trial."""
    from mimucap.io.library import library_fields
    from mimucap.io.session import make_subject
    from mimucap.session.library import open_library

    if args.out is not None:
        raise ValueError("--out and --subject exclude each other: a library recording is named by the library")
    library = open_library(args.library)
    known = library.subject(args.subject)
    if known is not None and known.height_m is not None:
        subject = make_subject(args.subject, known.height_m, known.dominance or "unknown", known.notes)
    else:
        subject = make_subject(args.subject, dominance="unknown")
    path = library.recording_path(args.subject, args.trial)
    fields = library_fields(args.condition, args.tags.split(","), args.trial or path.stem.rsplit("_", 1)[-1])
    return library, path, {"subject": subject, "library": fields}


#: How long (s) the sources may take to start (worker processes spawned, a port bound, a device
#: opened) before the recording's duration starts counting anyway.
STARTUP_LIMIT_S = 10.0


def _sources_up(supervisor) -> bool:
    """Every source has left its start-up (running, or already finished, failed or disconnected)."""
    from mimucap.acquisition.messages import STATE_STARTING

    return all(status.state != STATE_STARTING for status in supervisor.sources().values())


def _reason_text(reason: str) -> str:
    """How the end of a recording reads after "no sample was received in …"."""
    return "the whole recording" if reason == "duration" else f"the recording (it ended: {reason})"
