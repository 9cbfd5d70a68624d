"""``mimucap stream``: the live processing path without the window, published to the Lab
Streaming Layer.

    mimucap stream --source SPEC --lsl [--calibration CAL.json] [--duration S]
                   [--lsl-markers NAME] [--out SESSION.h5]

The source's samples run through the one processing path as in the window (magnetometer
calibrations stored for the sensors' devices, the orientation filter, the body calibration of
``CAL.json`` with the magnetometer calibrations it carries; without one each sensor's axes stand
for its segment), and go out as LSL streams whose names begin with "MimuCap": segment
orientations (type MoCap), joint angles, each sensor's raw samples and the session's markers,
every sample stamped with its sample time on the LSL clock. ``--lsl-markers NAME`` takes the
marker stream NAME of another program as session markers at their LSL times; ``--out`` records
the session meanwhile (with those markers and the offset to the LSL clock). Runs until
``--duration`` seconds have passed, or Ctrl+C. Needs pylsl: ``pip install 'mimucap[lsl]'``.
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
import time
from pathlib import Path

from mimucap.acquisition.source_spec import VALID_FORMS

#: The pump's period (s): each step takes what arrived and publishes it.
STEP_S = 0.005


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "stream", help="publish the live pipeline's output to the Lab Streaming Layer",
        description=__doc__.split("\n\n", 1)[1], formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--source", required=True, metavar="SPEC", help="data source: " + ", ".join(VALID_FORMS))
    parser.add_argument("--lsl", action="store_true", help="publish LSL streams (the output this command has)")
    parser.add_argument("--calibration", type=Path, metavar="CAL.json",
                        help="body calibration (mimucap bodycal), with the magnetometer calibrations it carries")
    parser.add_argument("--duration", type=float, metavar="S", help="seconds to stream (default: until Ctrl+C)")
    parser.add_argument("--lsl-markers", metavar="NAME", help="take the LSL marker stream NAME as session markers")
    parser.add_argument("--out", type=Path, metavar="SESSION.h5", help="record the session meanwhile")
    parser.add_argument("--model", choices=("ten_segment", "fifteen_segment"), help="skeleton model")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if not args.lsl:
        raise ValueError("say where to stream: --lsl (Lab Streaming Layer) is the output this command has")
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        raise ValueError(f"--duration must be a positive number of seconds, got {args.duration:g}")
    if args.out is not None:
        from mimucap.cli import check_output_path

        check_output_path(args.out)
    from mimucap.session.streaming.lsl_clock import load_pylsl

    pylsl = load_pylsl()  # before anything starts: says how to install it
    from mimucap.session.live.live_session import open_live_session
    from mimucap.session.streaming.lsl_streamer import LslStreamer

    session = open_live_session(args.source, model_name=args.model)
    if args.calibration is not None:
        apply_calibration_file(session, args.calibration)
    streamer = LslStreamer(session, pylsl)
    from mimucap.cli.record import StopRequest

    stop = StopRequest()
    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        if args.lsl_markers:
            streamer.take_markers(args.lsl_markers)
        session.start()
        if args.out is not None:
            session.start_recording(args.out)
        print(f"streaming {session.label} to LSL ({session.model.name}): 'MimuCap segments' (MoCap), "
              f"'MimuCap joint angles', 'MimuCap raw <sensor>', 'MimuCap markers'"
              + (f"; markers from {args.lsl_markers!r}" if args.lsl_markers else ""), flush=True)
        end = math.inf if args.duration is None else time.monotonic() + args.duration
        while time.monotonic() < end and not stop.requested:
            if not session.step():
                streamer.poll()
            if session.recording_failure:
                raise OSError(session.recording_failure)
            time.sleep(STEP_S)
    finally:
        result = session.stop()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        streams = streamer.streams()
        taken = streamer.markers_taken
        streamer.close()
    for name, pushed, rate in streams:
        print(f"{name}: {pushed} samples at {rate:g} Hz nominal")
    if args.lsl_markers:
        print(f"{taken} markers taken from {args.lsl_markers!r}")
    if result is not None:
        print(f"wrote {result.session_path}")
    if not any(pushed for _name, pushed, _rate in streams):
        print(f"mimucap stream: error: no sample came from {session.label}"
              + (f" ({session.source_problem})" if session.source_problem else ""), file=sys.stderr)
        return 1
    return 0


def apply_calibration_file(session, path: Path) -> None:
    """Apply the body calibration of ``path`` (``mimucap bodycal``'s CAL.json) and the
    magnetometer calibrations it was made with to ``session``."""
    from mimucap.io.body_calibration_file import read_body_calibration
    from mimucap.session.recorded.calibration_choice import body_magnetometers

    calibration, _document = read_body_calibration(path)
    for mag in (body_magnetometers(calibration, str(path)) or {}).values():
        session.apply_mag_calibration(mag, save=False)
    session.apply_body_calibration(calibration)
