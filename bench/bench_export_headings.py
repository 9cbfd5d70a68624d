"""Segment headings of the command-line route's exports against the simulator's, over seeds.

The route of the README: ``mimucap simulate --scenario demo`` → ``magcal fit --save`` (into a
throwaway calibration store) → ``bodycal --out CAL.json`` → the motion every export writes
(:func:`mimucap.session.review.load_review` with ``calibration_file=CAL.json``; the tests read
the C3D, BVH and OpenSense files back with other programs and find the same figures). Per
segment, the heading error is the turn about the world's vertical of the exported segment from
the true one (the twist of ``q_estimate ⊗ q_true⁻¹`` about ENU z). Printed per seed: the largest
|mean| over the held part of each N-pose and the largest RMS while walking (from a second after
each ``walk`` marker to the next marker), with the segments; and, for comparison, the same
body calibration applied with every sensor's raw magnetic field, which is what the export did
before a body calibration carried its magnetometer calibrations (the constant per-segment
offsets of issue 31).

Run: ``.venv/bin/python bench/bench_export_headings.py [--seeds 0-7] [--duration 46]``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import tempfile
from pathlib import Path

import numpy as np

from mimucap.cli import main
from mimucap.core import phases
from mimucap.core import rotation as rot
from mimucap.session.calibrations import AppliedCalibrations
from mimucap.session.review import build_review, load_review


def heading_error_deg(q_estimate: np.ndarray, q_true: np.ndarray) -> np.ndarray:
    """The twist about world z of ``q_estimate ⊗ q_true⁻¹`` (deg, wrapped to ±180)."""
    relative = rot.multiply(q_estimate, rot.conjugate(q_true))
    return (np.degrees(2.0 * np.arctan2(relative[..., 3], relative[..., 0])) + 180.0) % 360.0 - 180.0


def worst(review) -> tuple[float, str, float, str]:
    """(largest |mean| N-pose error, its segment, largest walking RMS, its segment), deg."""
    truth = review.truth
    index = np.clip(np.searchsorted(truth.t_s, review.t_s - 1e-9), 0, len(truth.t_s) - 1)
    t = review.t_s
    still = [(a + 1.0, b - 0.3) for a, b in phases.phase_windows(review.markers, phases.NPOSE, review.end_s)]
    walking = [(a + 1.0, b) for a, b in phases.phase_windows(review.markers, phases.WALK, review.end_s)]
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


def run(seed: int, duration_s: float, folder: Path) -> tuple[tuple, tuple]:
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
    return worst(review), worst(raw)


def main_() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="0-7", help="seeds, e.g. 0-7 or 3,5")
    parser.add_argument("--duration", type=float, default=46.0, help="demo length (s; its walk begins at 35 s)")
    args = parser.parse_args()
    print(f"demo of {args.duration:g} s, command-line route; heading error (deg) of the exported segments")
    print("seed | N-pose worst |mean| | walking worst RMS | with the raw field (before): N-pose / walking")
    rows = []
    for seed in seeds_of(args.seeds):
        with tempfile.TemporaryDirectory() as scratch:
            now, before = run(seed, args.duration, Path(scratch))
        rows.append(now)
        print(f"{seed:4d} | {now[0]:5.2f} ({now[1]}) | {now[2]:5.2f} ({now[3]}) | "
              f"{before[0]:6.1f} ({before[1]}) / {before[2]:6.1f} ({before[3]})", flush=True)
    figures = np.array([[r[0], r[2]] for r in rows])
    print(f"over {len(rows)} seeds: N-pose worst {figures[:, 0].min():.2f}-{figures[:, 0].max():.2f}, "
          f"walking worst {figures[:, 1].min():.2f}-{figures[:, 1].max():.2f}")


if __name__ == "__main__":
    main_()
