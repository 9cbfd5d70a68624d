"""Guided magnetometer turns on the simulated suit: which sensors pass, and the turns measured.

Each seed is the magnetometer part of a guided session (:mod:`mimucap.session.procedures.guided_session`):
every unit of a ten-sensor suit held together and turned one full turn about its x, y and z
axis by the simulated subject, who follows the procedure's instruction, with the default sensor
errors (gyro bias, noise, hard and soft iron) and the hand's sway. The procedure
(:class:`mimucap.session.procedures.magnetometer.MagcalProcedure`) measures the turns from each
sensor's gyroscope and finishes once every axis of every sensor has 330°, or after 120 s.

Prints per seed how many sensors pass, the smallest angle measured over every sensor and axis,
and the smallest per axis. The recording stops as soon as the last axis (z) reaches 330°, so
z's smallest is about 330° by construction; x and y are measured over their whole turn.

Run: ``.venv/bin/python bench/bench_magcal_turns.py [--seeds 0-7] [--sensors 10]``
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from mimucap.core.simulate.config import SimulationConfig
from mimucap.io.calibration_store import CalibrationStore
from mimucap.session.sources.calibration_feed import LiveSessionFeed, SteppedClock
from mimucap.session.sources.feeds import SimulatorFeed
from mimucap.session.live.live_session import LiveSession
from mimucap.session.procedures.magnetometer import MagcalProcedure

STEP_S = 0.02  # the guided session's clock step


def run_seed(seed: int, n_sensors: int, folder: Path) -> dict:
    """The guided magnetometer turns of one simulated subject; returns the figures."""
    clock = SteppedClock(10.0)
    config = SimulationConfig(scenario="walk", seed=seed, n_sensors=n_sensors)
    live = LiveSession(SimulatorFeed(config, clock=clock), "walk", model_name=config.model_name,
                       height_m=config.height_m, clock=clock)
    live.start()
    procedure = MagcalProcedure(LiveSessionFeed(live), live.sensor_ids, store=CalibrationStore(folder / f"store-{seed}"))
    procedure.start()
    while procedure.phase == "recording":
        clock.now += STEP_S
        live.step()
        procedure.step()
    swept = {s: [a.swept_deg for a in procedure.guidance(s).axes] for s in live.sensor_ids}
    failed = {s: o.advice[0] if o.advice else "" for s, o in procedure.outcomes.items() if o.verdict == "fail"}
    return {
        "passed": len(procedure.outcomes) - len(failed), "total": len(procedure.outcomes), "failed": failed,
        "worst": min(min(v) for v in swept.values()),
        "worst_axis": [min(v[i] for v in swept.values()) for i in range(3)],
        "elapsed_s": procedure.elapsed_s,
    }


def parse_seeds(text: str) -> list[int]:
    """``"0-7"`` or ``"0,3,4"`` → list of seeds."""
    seeds = []
    for part in text.split(","):
        low, _, high = part.partition("-")
        seeds.extend(range(int(low), int(high or low) + 1))
    return seeds


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="0-7")
    parser.add_argument("--sensors", type=int, default=10)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        for seed in parse_seeds(args.seeds):
            started = time.perf_counter()
            r = run_seed(seed, args.sensors, Path(tmp))
            x, y, z = r["worst_axis"]
            print(f"seed {seed}: {r['passed']}/{r['total']} sensors pass; smallest turn {r['worst']:.1f}° "
                  f"(x {x:.1f}°, y {y:.1f}°, z {z:.1f}°); {r['elapsed_s']:.1f} s of turns, "
                  f"{time.perf_counter() - started:.1f} s to run")
            for sensor_id, advice in r["failed"].items():
                print(f"   {sensor_id} failed: {advice}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
