"""How long the library index takes, against reading the same session files alone.

    python bench/bench_library.py [--sessions 100] [--duration 30]

Writes ``--sessions`` ten-sensor, 100 Hz sessions of ``--duration`` s (simulated walks, truth
left out) into a scratch library, then times: reading every file with ``read_session`` (the
floor any index built from the files has), the first scan (every file new), a rescan with
nothing changed (what opening the library window costs), a full rebuild, listing the sessions,
and storing results one transaction each. Prints each time and its ratio to the plain reading.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path


def _timed(work) -> float:
    start = time.perf_counter()
    work()
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sessions", type=int, default=100)
    parser.add_argument("--duration", type=float, default=30.0, help="seconds per session")
    args = parser.parse_args()

    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.core.simulate.suit import simulate_session
    from mimucap.io.library import Library, library_fields
    from mimucap.io.session import make_subject, read_session, session_from_simulation, write_session

    with tempfile.TemporaryDirectory() as scratch:
        root = Path(scratch) / "library"
        root.mkdir()
        session = session_from_simulation(simulate_session(SimulationConfig(scenario="walk", duration_s=args.duration)),
                                          include_truth=False)
        for index in range(args.sessions):
            subject = f"P{index % 25:03d}"
            session.metadata["subject"] = make_subject(subject, 1.75)
            session.metadata["library"] = library_fields("pre-op" if index % 2 else "6 weeks", ["gait"], "trial01")
            write_session(root / f"{subject}_2026-01-{1 + index // 25:02d}_t{index:03d}.h5", session)
        size_mb = sum(p.stat().st_size for p in root.glob("*.h5")) / 1e6
        files = sorted(root.glob("*.h5"))
        read = _timed(lambda: [read_session(p, include_truth=False) for p in files])
        library = Library(root)
        timings = {
            "first scan (every file new)": _timed(library.scan),
            "rescan, nothing changed": _timed(library.scan),
            "rebuild": _timed(library.rebuild),
            "list every session": _timed(library.sessions),
        }
        first = library.sessions()[0].path
        timings["100 results, one transaction each"] = _timed(
            lambda: [library.store_result(first, f"r{k}", {"value": k}) for k in range(100)])
    print(f"{args.sessions} sessions of {args.duration:g} s, 10 sensors at 100 Hz, {size_mb:.0f} MB")
    print(f"{'read_session of every file (reference)':42s} {read:8.3f} s   1.00")
    for name, seconds in timings.items():
        print(f"{name:42s} {seconds:8.3f} s   {seconds / read:.2f}")


if __name__ == "__main__":
    main()
