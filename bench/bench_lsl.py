"""Delay from a sample's time to its receipt by a Lab Streaming Layer inlet.

Run: ``.venv/bin/python bench/bench_lsl.py [--duration S]`` (needs pylsl: ``make bench`` installs it).

Two publishers of the simulated ten-sensor suit at 100 Hz:

* **stream command**: ``mimucap stream --source simulated --lsl`` in its own process (its pump
  steps every 5 ms), as a lab runs it headless;
* **window pump**: a live session stepped every 16 ms in this process, as the main window's pump
  does, with the streams of File → Stream to Lab Streaming Layer.

An inlet in this process (another program, for the first), one thread per stream, takes every
sample of the ``MimuCap segments`` (MoCap) and ``MimuCap raw S01`` streams as soon as it arrives
(a blocking ``pull_sample``), from 1 s after it opened; the delay of a sample is ``local_clock()``
at its receipt minus its time stamp, which is its sample time on the LSL clock. Printed: samples received, median and p95 of the
delay (ms) per stream. The pipeline waits for every sensor's sample of an instant before it forms
the pose, and the pump collects what arrived since its last step: both add to the delay.

liblsl here is configured to find streams on this machine only (``tests/lsl_api.cfg``, unless
``LSLAPICFG`` names another configuration).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("LSLAPICFG", str(ROOT / "tests" / "lsl_api.cfg"))
sys.path.insert(0, str(ROOT / "app"))

import pylsl  # noqa: E402

STREAMS = ("MimuCap segments", "MimuCap raw S01")


#: Seconds after an inlet opened whose samples are not counted (the backlog of its start).
SETTLE_S = 1.0


def _receive(name: str, source_id: str, seconds: float, delays: list[float]) -> None:
    found = pylsl.resolve_bypred(f"name='{name}' and source_id='{source_id}'", 1, 20.0)
    if not found:
        raise SystemExit(f"no stream {name!r} ({source_id}) appeared")
    inlet = pylsl.StreamInlet(found[0], max_buflen=30)
    inlet.open_stream(5.0)
    start = time.monotonic()
    while time.monotonic() < start + SETTLE_S + seconds:
        _sample, stamp = inlet.pull_sample(timeout=0.2)
        if stamp is not None and time.monotonic() >= start + SETTLE_S:
            delays.append(pylsl.local_clock() - stamp)
    inlet.close_stream()


def _measure(source_ids: dict[str, str], seconds: float, keep_running=None) -> dict[str, list[float]]:
    """Receive the streams ``name → source_id`` for ``seconds``, each in its own thread (which
    finds and opens it too); ``keep_running()`` is called every 16 ms meanwhile (the window's
    pump), else this thread just waits."""
    delays = {name: [] for name in source_ids}
    threads = [threading.Thread(target=_receive, args=(name, source_id, seconds, delays[name]))
               for name, source_id in source_ids.items()]
    for thread in threads:
        thread.start()
    while any(t.is_alive() for t in threads):
        if keep_running is not None:
            keep_running()
        time.sleep(0.016)
    return delays


def stream_command(seconds: float) -> dict[str, list[float]]:
    process = subprocess.Popen([sys.executable, "-m", "mimucap", "stream", "--source", "simulated", "--lsl",
                                "--duration", str(seconds + SETTLE_S + 10.0)], stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL, env={**os.environ, "PYTHONPATH": str(ROOT / "app")})
    try:
        time.sleep(2.0)  # the process starts and its outlets open
        return _measure({name: f"MimuCap:simulated:demo:{name[len('MimuCap '):]}" for name in STREAMS}, seconds)
    finally:
        process.terminate()
        process.wait(30)


def window_pump(seconds: float) -> dict[str, list[float]]:
    import tempfile

    from mimucap.io.calibration_store import CalibrationStore
    from mimucap.session.live.live_session import open_live_session
    from mimucap.session.streaming.lsl_streamer import LslStreamer

    session = open_live_session("simulated", calibration_store=CalibrationStore(Path(tempfile.mkdtemp())))
    session.sensors.label = "simulated:bench-window"
    streamer = LslStreamer(session)
    session.start()
    try:
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            session.step()
            time.sleep(0.016)
        return _measure({name: f"MimuCap:{session.label}:{name[len('MimuCap '):]}" for name in STREAMS}, seconds,
                        session.step)
    finally:
        session.stop()
        streamer.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=10.0, metavar="S", help="seconds received per publisher")
    args = parser.parse_args()
    print(f"pylsl {pylsl.__version__}, liblsl {pylsl.library_version()}; {args.duration:g} s per publisher, "
          "simulated suit 10 sensors at 100 Hz")
    print(f"{'publisher':<16} {'stream':<20} {'samples':>8} {'median ms':>10} {'p95 ms':>8} {'max ms':>8}")
    for label, run in (("stream command", stream_command), ("window pump", window_pump)):
        for name, delays in run(args.duration).items():
            ms = 1e3 * np.asarray(delays)
            print(f"{label:<16} {name:<20} {len(ms):>8} {np.median(ms):>10.1f} {np.percentile(ms, 95):>8.1f} "
                  f"{ms.max():>8.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
