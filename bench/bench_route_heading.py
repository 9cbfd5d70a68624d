"""Heading of the command-line route's exported segments across seeds, and where its error comes from.

For each seed, the README's route runs on a simulated demo session: ``simulate --scenario demo
--duration 46 --seed S`` → ``magcal fit --save`` → ``bodycal --out CAL.json`` → ``export
--calibration CAL.json --format sto``. The exported virtual sensors (one per segment, read back
as OpenSense table) are compared with the simulator's true segments stored in the session: the
heading error (the twist about the world vertical of ``q_estimate ⊗ q_true⁻¹``) as its mean over
each held N-pose (from 1 s after its marker to 0.3 s before the next) and its RMS while walking
(from 1 s after each walk marker), the figures of ``tests/cli/test_session_route.py``. No command
reads the truth.

The body calibration sets each segment from the sensor's N-pose orientation, which ``bodycal``
takes from the still sensor's accelerometer and calibrated field (the TRIAD alignment), while the
export turns every later instant by the reprocessed filter's orientation. The heading error of an
exported segment is therefore, to first order, the filter's heading error at that instant minus
the alignment's heading error in the N-pose, plus the error of the body's forward axis. The bench
prints these parts for the segment with the worst figure.

``--exact-gyro-scale`` repeats every seed with the simulated units' gyroscope scale factors
exact (the sensor error model's ``gyr_scale_error`` 0, every other error as before, the same
random draws): the difference between the two tables is what the gyroscopes' scale errors
(1 % per axis by default, a consumer MEMS unit's) cost the exported headings.

Run: ``.venv/bin/python bench/bench_route_heading.py [--seeds 0-7] [--duration 46]
[--exact-gyro-scale]``.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import json
import os
import tempfile
from pathlib import Path

import numpy as np
from mimucap.cli import main
from mimucap.core import phases
from mimucap.core import rotation as rot
from mimucap.io.session import read_session

LIMIT_DEG = 3.0


def heading_error_deg(q_estimate: np.ndarray, q_true: np.ndarray) -> np.ndarray:
    """The twist about the world's vertical (ENU z) of ``q_estimate ⊗ q_true⁻¹`` (deg, (N,))."""
    relative = rot.multiply(q_estimate, rot.conjugate(q_true))
    yaw = np.degrees(2.0 * np.arctan2(relative[..., 3], relative[..., 0]))
    return (yaw + 180.0) % 360.0 - 180.0


def at(t_s: np.ndarray, truth_t_s: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``q`` sampled on ``truth_t_s`` at the instants ``t_s`` (nearest sample at or after)."""
    return np.asarray(q)[np.clip(np.searchsorted(truth_t_s, t_s - 1e-9), 0, len(truth_t_s) - 1)]


def windows(markers, end_s: float) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    still = [(a + 1.0, b - 0.3) for a, b in phases.phase_windows(markers, phases.NPOSE, end_s)]
    walking = [(a + 1.0, b) for a, b in phases.phase_windows(markers, phases.WALK, end_s)]
    return still, walking


def mean_heading(error: np.ndarray, t_s: np.ndarray, window: tuple[float, float]) -> float:
    return float(np.mean(error[(t_s >= window[0]) & (t_s <= window[1])]))


def run_seed(folder: Path, seed: int, duration_s: float) -> dict:
    """The route on one seed; the exported segments' figures and the worst segment's parts."""
    from mimucap.cli.bodycal import static_npose_orientations
    from mimucap.cli.session_input import magnetometer_calibrations, orientation_table
    from mimucap.io.opensense import session_from_sto

    session, calibration, table = folder / "demo.h5", folder / "CAL.json", folder / "route.sto"
    os.environ["MIMUCAP_DATA_DIR"] = str(folder / "data")
    with contextlib.redirect_stdout(io.StringIO()):
        for command in (["simulate", "--scenario", "demo", "--duration", f"{duration_s:g}", "--seed", str(seed),
                         "--out", str(session)],
                        ["magcal", "fit", str(session), "--save"],
                        ["bodycal", str(session), "--out", str(calibration)],
                        ["export", str(session), "--calibration", str(calibration), "--format", "sto",
                         "--out", str(table)]):
            if main(command) != 0:
                raise SystemExit(f"seed {seed}: mimucap {' '.join(command)} failed")
    recorded = read_session(session)
    truth = recorded.truth
    still, walking = windows(recorded.markers, float(truth.t_s[-1]))
    exported = session_from_sto(table)
    start = float(exported.metadata["source"]["start_s"])
    figures = {}
    for stream in exported.sensors.values():
        t = stream.t_s + start
        error = heading_error_deg(stream.q_world_from_sensor, at(t, truth.t_s, truth.q_world_from_segment[stream.segment]))
        figures[stream.segment] = (max(abs(mean_heading(error, t, w)) for w in still),
                                   max(float(np.sqrt(np.mean(np.square(error[(t >= a) & (t <= b)])))) for a, b in walking))
    worst = max(figures, key=lambda s: max(figures[s]))

    # the worst segment's parts: the sensor's N-pose alignment, the filter's heading, the body's forward axis
    document = json.loads(calibration.read_text())
    sensor = document["segments"][worst]["sensor"]
    npose = tuple(document["npose_s"])
    mags = magnetometer_calibrations(recorded, None).magnetometer
    with contextlib.redirect_stdout(io.StringIO()):
        static = static_npose_orientations(recorded, mags, {worst: sensor}, npose)
        track = orientation_table(recorded, str(session), mags)
    inside = (truth.t_s >= npose[0]) & (truth.t_s <= npose[1])
    true_sensor = truth.sensors[sensor].q_world_from_sensor
    alignment = (float(heading_error_deg(static[sensor], rot.average(true_sensor[inside]))) if sensor in static
                 else float("nan"))
    filter_error = heading_error_deg(track.q_world_from_sensor[sensor], at(track.t_s, truth.t_s, true_sensor))
    true_body = rot.average(truth.q_world_from_segment["pelvis"][inside])
    forward = float(heading_error_deg(np.asarray(document["q_world_from_body"]), true_body))
    return {"figures": figures, "worst": worst, "sensor": sensor, "alignment": alignment, "forward": forward,
            "filter_npose": mean_heading(filter_error, track.t_s, npose),
            "filter_walk": [mean_heading(filter_error, track.t_s, w) for w in walking]}


def report(label: str, results: dict[int, dict]) -> None:
    print(f"\n{label}")
    print("  seed  worst N-pose / walking (deg)  worst segment   its sensor's heading error (deg): alignment in the "
          "N-pose, filter in the N-pose, filter walking (mean); body forward axis")
    for seed, r in results.items():
        npose = max(f[0] for f in r["figures"].values())
        walk = max(f[1] for f in r["figures"].values())
        flag = "" if max(npose, walk) <= LIMIT_DEG else f"  > {LIMIT_DEG:g}°"
        print(f"  {seed:4d}  {npose:6.2f} / {walk:5.2f}{flag:8s}        {r['worst']:12s}  {r['sensor']}  "
              f"{r['alignment']:+5.2f}, {r['filter_npose']:+5.2f}, "
              f"{', '.join(f'{v:+5.2f}' for v in r['filter_walk'])}; {r['forward']:+5.2f}")
    worst = [max(max(f) for f in r["figures"].values()) for r in results.values()]
    print(f"  worst over the seeds {max(worst):.2f}°, median {float(np.median(worst)):.2f}°; "
          f"seeds within {LIMIT_DEG:g}°: {sum(w <= LIMIT_DEG for w in worst)} of {len(worst)}")


def seeds_of(text: str) -> list[int]:
    if "-" in text:
        first, last = (int(v) for v in text.split("-"))
        return list(range(first, last + 1))
    return [int(v) for v in text.split(",")]


def main_bench() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0-7", help="seeds, e.g. 0-7 or 0,4,6 (default 0-7)")
    parser.add_argument("--duration", type=float, default=46.0, help="seconds simulated (default 46)")
    parser.add_argument("--exact-gyro-scale", action="store_true",
                        help="also run every seed with the simulated gyroscopes' scale factors exact")
    args = parser.parse_args()
    seeds = seeds_of(args.seeds)
    variants = [("default sensor errors", None)]
    if args.exact_gyro_scale:
        variants.append(("gyroscope scale factors exact (gyr_scale_error 0)", {"gyr_scale_error": 0.0}))
    from mimucap.core.simulate import sensor_errors

    default = sensor_errors.ERROR_PRESETS["default"]
    with tempfile.TemporaryDirectory() as tmp:
        for label, change in variants:
            sensor_errors.ERROR_PRESETS["default"] = dataclasses.replace(default, **(change or {}))
            results = {}
            for seed in seeds:
                folder = Path(tmp) / f"{len(results)}-{seed}-{bool(change)}"
                folder.mkdir()
                results[seed] = run_seed(folder, seed, args.duration)
            sensor_errors.ERROR_PRESETS["default"] = default
            report(f"{label}: simulate --scenario demo --duration {args.duration:g} → magcal fit → bodycal → "
                   "export --format sto", results)


if __name__ == "__main__":
    main_bench()
