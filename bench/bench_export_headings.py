"""Segment headings of the command-line route's exports against the simulator's, over seeds.

The route of the README: ``mimucap simulate --scenario demo`` → ``magcal fit --save`` (into a
throwaway calibration store) → ``bodycal --out CAL.json`` → the motion every export writes
(:func:`mimucap.session.recorded.review.load_review` with ``calibration_file=CAL.json``; the tests read
the C3D, BVH and OpenSense files back with other programs and find the same figures). Per
segment, the heading error is the turn about the world's vertical of the exported segment from
the true one (the twist of ``q_estimate ⊗ q_true⁻¹`` about ENU z). Printed per seed: the largest
|mean| over the held part of each N-pose and the largest RMS while walking (from a second after
each ``walk`` marker to the next marker), with the segments; and, for comparison, the same
body calibration applied with every sensor's raw magnetic field, which is what the export did
before a body calibration carried its magnetometer calibrations (the constant per-segment
offsets of issue 31).

Where the error comes from, for the worst segment of each seed: the body calibration sets a
segment from its sensor's N-pose orientation, which ``bodycal`` takes from the still sensor's
accelerometer and calibrated field (the TRIAD alignment), and the export turns it at every later
instant by the reprocessed filter's orientation; to first order the segment's heading error is
the filter's heading error at that instant minus the alignment's in the N-pose, plus the error
of the body's forward axis. Printed: the alignment's heading error, the filter's (mean over the
body calibration's N-pose window and over each walk) and the forward axis's, deg.

``--exact-gyro-scale`` repeats the seeds with the simulated units' gyroscope scale factors exact
(the sensor error model's ``gyr_scale_error`` 0; every other error and random draw as before):
the difference is what the gyroscopes' scale errors (1 % per axis by default, a consumer MEMS
unit's) still cost the exported headings through the filter once ``magcal fit`` has estimated
them from the turns (:mod:`mimucap.core.magcal.gyro_scale`).

Run: ``.venv/bin/python bench/bench_export_headings.py [--seeds 0-7] [--duration 46]
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
from mimucap.core import phase_markers
from mimucap.core import rotation as rot
from mimucap.session.recorded.calibration_choice import AppliedCalibrations
from mimucap.session.recorded.review import build_review, load_review


def heading_error_deg(q_estimate: np.ndarray, q_true: np.ndarray) -> np.ndarray:
    """The twist about world z of ``q_estimate ⊗ q_true⁻¹`` (deg, wrapped to ±180)."""
    relative = rot.multiply(q_estimate, rot.conjugate(q_true))
    return (np.degrees(2.0 * np.arctan2(relative[..., 3], relative[..., 0])) + 180.0) % 360.0 - 180.0


def worst(review) -> tuple[float, str, float, str]:
    """(largest |mean| N-pose error, its segment, largest walking RMS, its segment), deg."""
    truth = review.truth
    index = np.clip(np.searchsorted(truth.t_s, review.t_s - 1e-9), 0, len(truth.t_s) - 1)
    t = review.t_s
    still = [(a + 1.0, b - 0.3) for a, b in phase_markers.phase_windows(review.markers, phase_markers.NPOSE, review.end_s)]
    walking = [(a + 1.0, b) for a, b in phase_markers.phase_windows(review.markers, phase_markers.WALK, review.end_s)]
    n_worst, n_segment, w_worst, w_segment = 0.0, "", 0.0, ""
    for segment, q in review.q_world_from_segment.items():
        error = heading_error_deg(q, np.asarray(truth.q_world_from_segment[segment])[index])
        for a, b in still:
            value = abs(float(np.mean(error[(t >= a) & (t <= b)])))
            if value > n_worst:
                n_worst, n_segment = value, segment
        for a, b in walking:
            value = float(np.sqrt(np.mean(np.square(error[(t >= a) & (t <= b)]))))
            if value > w_worst:
                w_worst, w_segment = value, segment
    return n_worst, n_segment, w_worst, w_segment


def seeds_of(text: str) -> list[int]:
    if "-" in text:
        first, last = (int(v) for v in text.split("-"))
        return list(range(first, last + 1))
    return [int(v) for v in text.split(",")]


def mean_over(error: np.ndarray, t_s: np.ndarray, window: tuple[float, float]) -> float:
    return float(np.mean(error[(t_s >= window[0]) & (t_s <= window[1])]))


def parts(session_path: Path, calibration: Path, segment: str) -> str:
    """The heading errors (deg) behind one segment's: its sensor's N-pose alignment, the
    reprocessed filter's mean over the N-pose window and over each walk, the body's forward axis."""
    from mimucap.cli.bodycal import static_npose_orientations
    from mimucap.cli.session_input import magnetometer_calibrations, orientation_table
    from mimucap.io.session import read_session

    recorded = read_session(session_path)
    truth = recorded.truth
    document = json.loads(calibration.read_text())
    sensor = document["segments"][segment]["sensor"]
    npose = tuple(document["npose_s"])
    mags = magnetometer_calibrations(recorded, None).magnetometer
    with contextlib.redirect_stdout(io.StringIO()):
        track = orientation_table(recorded, str(session_path), mags)
        static = static_npose_orientations(recorded, mags, {segment: sensor}, npose, track)
    inside = (truth.t_s >= npose[0]) & (truth.t_s <= npose[1])
    true_sensor = np.asarray(truth.sensors[sensor].q_world_from_sensor)
    alignment = (float(heading_error_deg(static[sensor], rot.average(true_sensor[inside]))) if sensor in static
                 else float("nan"))
    index = np.clip(np.searchsorted(truth.t_s, track.t_s - 1e-9), 0, len(truth.t_s) - 1)
    filtered = heading_error_deg(track.q_world_from_sensor[sensor], true_sensor[index])
    walks = [(a + 1.0, b) for a, b in phase_markers.phase_windows(recorded.markers, phase_markers.WALK, float(truth.t_s[-1]))]
    forward = float(heading_error_deg(np.asarray(document["q_world_from_body"]),
                                      rot.average(np.asarray(truth.q_world_from_segment["pelvis"])[inside])))
    return (f"{segment} ({sensor}): alignment {alignment:+.2f}, filter N-pose {mean_over(filtered, track.t_s, npose):+.2f}"
            f" walking {', '.join(f'{mean_over(filtered, track.t_s, w):+.2f}' for w in walks)}, forward {forward:+.2f}")


def run(seed: int, duration_s: float, folder: Path) -> tuple[tuple, tuple, str]:
    os.environ["MIMUCAP_DATA_DIR"] = str(folder / "data")  # a throwaway calibration store
    session, calibration = folder / "demo.h5", folder / "CAL.json"
    with contextlib.redirect_stdout(io.StringIO()):
        for argv in (["simulate", "--scenario", "demo", "--duration", f"{duration_s:g}", "--seed", str(seed),
                      "--out", str(session)],
                     ["magcal", "fit", str(session), "--save"],
                     ["bodycal", str(session), "--out", str(calibration)]):
            if main(argv) != 0:
                raise RuntimeError(f"mimucap {' '.join(argv)} failed")
    review = load_review(session, calibration_file=calibration)
    raw = build_review(session, review.session,
                       calibrations=AppliedCalibrations(review.body_calibration, str(calibration)))
    now = worst(review)
    return now, worst(raw), parts(session, calibration, now[1] if now[0] >= now[2] else now[3])


def main_() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="0-7", help="seeds, e.g. 0-7 or 3,5")
    parser.add_argument("--duration", type=float, default=46.0, help="demo length (s; its walk begins at 35 s)")
    parser.add_argument("--exact-gyro-scale", action="store_true",
                        help="repeat the seeds with the simulated gyroscopes' scale factors exact")
    args = parser.parse_args()
    from mimucap.core.simulate import sensor_errors

    default = sensor_errors.ERROR_PRESETS["default"]
    variants = [("default sensor errors", default)]
    if args.exact_gyro_scale:
        variants.append(("gyroscope scale factors exact", dataclasses.replace(default, gyr_scale_error=0.0)))
    for label, errors in variants:
        sensor_errors.ERROR_PRESETS["default"] = errors
        print(f"\ndemo of {args.duration:g} s, command-line route, {label}; heading error (deg) of the exported segments")
        print("seed | N-pose worst |mean| | walking worst RMS | with the raw field (before): N-pose / walking")
        rows, behind = [], []
        for seed in seeds_of(args.seeds):
            with tempfile.TemporaryDirectory() as scratch:
                now, before, found = run(seed, args.duration, Path(scratch))
            rows.append(now)
            behind.append(f"{seed:4d} | {found}")
            print(f"{seed:4d} | {now[0]:5.2f} ({now[1]}) | {now[2]:5.2f} ({now[3]}) | "
                  f"{before[0]:6.1f} ({before[1]}) / {before[2]:6.1f} ({before[3]})", flush=True)
        sensor_errors.ERROR_PRESETS["default"] = default
        figures = np.array([[r[0], r[2]] for r in rows])
        print(f"over {len(rows)} seeds: N-pose worst {figures[:, 0].min():.2f}-{figures[:, 0].max():.2f}, "
              f"walking worst {figures[:, 1].min():.2f}-{figures[:, 1].max():.2f}")
        print("the worst segment's sensor, heading errors (deg) of its N-pose alignment, of the reprocessed filter "
              "(N-pose window, each walk) and of the body's forward axis:")
        print("\n".join(behind))


if __name__ == "__main__":
    main_()
