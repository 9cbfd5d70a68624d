"""``mimucap emulate``: emulated sensor devices driven by the simulated suit.

    mimucap emulate udp --sensors N --rate HZ --target HOST:PORT [--loss P] [--jitter MS]
                        [--drift PPM] [--offset-ms MS] [--duration S] [--corrupt P] [--no-hello]
    mimucap emulate serial --sensors N --rate HZ [--link PATH] [--loss P] [--jitter MS]
                        [--drift PPM] [--offset-ms MS] [--duration S]
                        [--unplug-after S --unplug-for S] [--no-hello]

``udp`` runs N nodes speaking the UDP protocol (answering time-sync and hello requests);
``serial`` writes the serial line protocol on a pseudo-terminal and prints the device path to
open (first line of the output). Each node says hello with a MAC of its own (drawn from
``--seed`` and its wire id); ``--no-hello`` emulates nodes older than the hello. The emulated clock reads ``host_monotonic·(1+drift) + offset``.
Both stop after ``--duration`` seconds, or on Ctrl+C. ``--unplug-after`` and ``--unplug-for``
are seconds ≥ 0 (``--unplug-for``, default 1 s, only with ``--unplug-after``).
"""

from __future__ import annotations

import argparse
import math
import signal
import threading
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mimucap.acquisition.emulate_common import EmulatorSettings

#: How long ``--unplug-after`` keeps the emulated serial device unplugged by default, s.
DEFAULT_UNPLUG_S = 1.0


def _target(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise argparse.ArgumentTypeError(f"expected HOST:PORT, got {text!r}")
    return host, int(port)


def _common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--sensors", type=int, default=10, metavar="N", help="number of nodes (default 10)")
    parser.add_argument("--rate", type=float, default=100.0, metavar="HZ", help="sample rate (default 100)")
    parser.add_argument("--loss", type=float, default=0.0, metavar="P", help="probability a sample is lost")
    parser.add_argument("--jitter", type=float, default=0.0, metavar="MS", help="send delay up to MS ms")
    parser.add_argument("--corrupt", type=float, default=0.0, metavar="P", help="probability a message is damaged")
    parser.add_argument("--drift", type=float, default=0.0, metavar="PPM", help="node clock drift (ppm)")
    parser.add_argument("--offset-ms", type=float, default=0.0, metavar="MS", help="node clock offset (ms)")
    parser.add_argument("--duration", type=float, default=None, metavar="S", help="stop after S seconds")
    parser.add_argument("--scenario", default="demo", help="what the simulated subject does (default demo)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--first-id", type=int, default=1, metavar="ID", help="wire id of the first node")
    parser.add_argument("--no-hello", action="store_true",
                        help="nodes older than the hello: they never say which device they are")


def register(subparsers) -> None:
    parser = subparsers.add_parser("emulate", help="emulated sensor devices (UDP nodes, serial receiver)",
                                   description=__doc__.split("\n\n")[0].replace("``", ""))
    kinds = parser.add_subparsers(dest="kind", metavar="KIND", required=True)
    udp = kinds.add_parser("udp", help="N nodes speaking the UDP protocol")
    _common(udp)
    udp.add_argument("--target", required=True, type=_target, metavar="HOST:PORT", help="where the host listens")
    serial = kinds.add_parser("serial", help="a serial receiver on a pseudo-terminal (prints its path)")
    _common(serial)
    serial.add_argument("--link", metavar="PATH", help="also make PATH a symlink to the device")
    serial.add_argument("--unplug-after", type=float, metavar="S", help="unplug the device after S seconds")
    serial.add_argument("--unplug-for", type=float, default=None, metavar="S",
                        help=f"stay unplugged S seconds (default {DEFAULT_UNPLUG_S:g})")
    parser.set_defaults(func=run)


def unplug_times(args: argparse.Namespace) -> tuple[float, float] | None:
    """``(after_s, for_s)`` of the serial unplug, or ``None``; a negative or non-finite time,
    or ``--unplug-for`` without ``--unplug-after``, is refused rather than ignored."""
    for option, value in (("--unplug-after", args.unplug_after), ("--unplug-for", args.unplug_for)):
        if value is not None and not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{option} must be a number of seconds >= 0, got {value:g}")
    if args.unplug_after is None:
        if args.unplug_for is not None:
            raise ValueError("--unplug-for needs --unplug-after S (when to unplug the device)")
        return None
    return args.unplug_after, DEFAULT_UNPLUG_S if args.unplug_for is None else args.unplug_for


def _settings(args: argparse.Namespace) -> EmulatorSettings:
    from mimucap.acquisition.emulate_common import EmulatorSettings

    return EmulatorSettings(n_sensors=args.sensors, rate_hz=args.rate, loss=args.loss, jitter_ms=args.jitter,
                            corrupt=args.corrupt,
                            drift_ppm=args.drift, offset_ms=args.offset_ms, duration_s=args.duration,
                            seed=args.seed, first_sensor_id=args.first_id, hello=not args.no_hello)


def run(args: argparse.Namespace) -> int:
    from mimucap.acquisition.emulate_motion import SimulatorMotion
    from mimucap.acquisition.emulate_serial import SerialEmulator
    from mimucap.acquisition.emulate_udp import UdpEmulator

    settings = _settings(args)
    motion = SimulatorMotion(settings.n_sensors, settings.rate_hz, args.scenario, args.seed)
    stop = threading.Event()
    previous = {sig: signal.signal(sig, lambda *_: stop.set()) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        if args.kind == "udp":
            emulator = UdpEmulator(settings, args.target, motion)
            print(f"emulating {settings.n_sensors} UDP nodes at {settings.rate_hz:g} Hz from "
                  f"{emulator.address[0]}:{emulator.address[1]} to {args.target[0]}:{args.target[1]}", flush=True)
            schedule = emulator.run(stop)
            print(f"sent {schedule.sent} samples ({emulator.corrupt.corrupted} damaged), lost {schedule.lost} on purpose, "
                  f"answered {emulator.sync_answered} time-sync requests, {emulator.send_errors} send errors")
            return 0
        unplug = unplug_times(args)
        emulator = SerialEmulator(settings, motion, link=args.link)
        print(emulator.device_path, flush=True)
        timers = []
        if unplug is not None:
            after_s, for_s = unplug
            timers = [threading.Timer(after_s, emulator.unplug),
                      threading.Timer(after_s + for_s, emulator.replug)]
            for timer in timers:
                timer.daemon = True
                timer.start()
        try:
            schedule = emulator.run(stop)
        finally:
            for timer in timers:
                timer.cancel()
            emulator.close()
        print(f"wrote {schedule.sent - emulator.unplugged_samples} samples, lost {schedule.lost} on purpose, "
              f"{emulator.unplugged_samples} while unplugged, {emulator.overflow} overflowed")
        return 0
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
