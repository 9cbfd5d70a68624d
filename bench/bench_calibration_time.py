"""Total guided calibration time of a simulated ten-sensor suit, in simulated user time.

Runs the same procedures the wizards drive (:mod:`mimucap.session.procedures.magnetometer`,
:mod:`mimucap.session.procedures.body`) on the simulated suit, faster than real time:
magnetometers in bundles held together (single-axis protocol), then the N-pose/T-pose body
calibration with the orientation filter using the new magnetometer calibrations. Prints one
row per stage (user seconds, verdicts, errors against the simulator's truth) and the total,
for bundles of 10, 5 and 4 sensors (goal: under 180 s).

    .venv/bin/python bench/bench_calibration_time.py
"""

from __future__ import annotations

import tempfile
import time

import numpy as np

from mimucap.core import rotation as rot
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import SuitSimulator
from mimucap.io.calibration_store import CalibrationStore
from mimucap.session.procedures.body import BodycalProcedure
from mimucap.session.sources.calibration_feed import SimulatedSuitFeed
from mimucap.session.procedures.magnetometer import MagcalProcedure

GOAL_S = 180.0
#: Seconds between the last magnetometer bundle and the body calibration (units strapped on;
#: not counted in the guided time).
DON_S = 30.0


def run_suit(bundle_size: int, seed: int = 11) -> list[tuple[str, float, str, str]]:
    simulator = SuitSimulator(SimulationConfig(scenario="npose", n_sensors=10, seed=seed))
    feed = SimulatedSuitFeed(simulator, step_s=0.1)
    store = CalibrationStore(tempfile.mkdtemp(prefix="mimucap-bench-"))
    ids = list(simulator.sensor_ids)
    rows = []
    for start in range(0, len(ids), bundle_size):
        bundle = ids[start:start + bundle_size]
        procedure = MagcalProcedure(feed, bundle, store=store)
        t0 = feed.time_s
        procedure.start()
        while procedure.phase == "recording":
            procedure.step()
        for sensor_id in procedure.accept():
            feed.set_magnetometer_calibration(procedure.outcomes[sensor_id].result.calibration)
        offsets = [np.linalg.norm(procedure.outcomes[s].result.calibration.offset_uT - simulator.parameters[s].mag_b_uT)
                   for s in bundle]
        verdicts = sorted({procedure.outcomes[s].verdict for s in bundle})
        rows.append((f"magnetometers {bundle[0]}..{bundle[-1]}", feed.time_s - t0, "/".join(verdicts),
                     f"offset error ≤ {max(offsets):.2f} µT"))
    # Strapping the units on is not part of the guided time; the filters settle meanwhile.
    feed.simulator.set_activity("npose")
    for _ in range(int(DON_S / feed.step_s)):
        feed.read()
    mapping = {m.segment: sid for sid, m in simulator.mounting.items()}
    body = BodycalProcedure(feed, mapping, arms="both")
    t0 = feed.time_s
    body.start()
    while body.phase in ("npose", "tpose"):
        body.step()
    if body.calibration is None:
        rows.append(("body N/T-pose", feed.time_s - t0, "refused", body.refusal or ""))
    else:
        errors = [np.degrees(rot.angle_between(body.calibration.q_segment_from_sensor[seg],
                                               simulator.mounting[sid].q_segment_from_sensor))
                  for seg, sid in body.calibration.sensors.items()]
        rows.append(("body N/T-pose", feed.time_s - t0, body.calibration.quality.verdict,
                     f"mounting error ≤ {max(errors):.2f}° (online EKF orientations)"))
    return rows


def main() -> None:
    print(f"{'bundle':>6}  {'stage':<26} {'user s':>7}  {'verdict':<9} check")
    for bundle_size in (10, 5, 4):
        wall = time.perf_counter()
        rows = run_suit(bundle_size)
        for name, seconds, verdict, note in rows:
            print(f"{bundle_size:>6}  {name:<26} {seconds:7.1f}  {verdict:<9} {note}")
        total = sum(r[1] for r in rows)
        print(f"{bundle_size:>6}  {'TOTAL':<26} {total:7.1f}  ratio to the 180 s goal {total / GOAL_S:.2f} "
              f"(computed in {time.perf_counter() - wall:.1f} s wall)")


if __name__ == "__main__":
    main()
