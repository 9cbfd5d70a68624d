"""``mimucap bench orientation DIR [--algorithm A ...] [--json]``: the propagation comparison of
Zhang, Gao, Zhou ("Head attitude sensing algorithm based on IMU in VR device") on BROAD.

Runs the orientation algorithms on every BROAD trial in DIR and prints, per trial, per
category (undisturbed, tapping, vibration, magnets) and as the mean over trials, the total /
heading / inclination RMSE in degrees with BROAD's metric
(:mod:`mimucap.core.fusion.evaluation`) and the time taken. Algorithms: ``ekf-taylor3``,
``ekf-rk4``, ``taylor3``, ``rk4`` (gyro-only after the initial alignment) and the smoothed
``ekf-taylor3-offline`` / ``ekf-rk4-offline``. If the ``vqf`` package is installed, VQF 9D
with default parameters (online ``vqf`` and ``vqf-offline``) is added as a reference row.
Every algorithm uses the same default parameters on every trial. A trial on which an
algorithm leaves no sample to evaluate (e.g. an accelerometer that is NaN throughout) is
skipped, named with its reason on stderr, in the table and under ``skipped`` in the JSON; the
means are over the other trials, and a folder in which every trial is skipped is an error.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from mimucap.core.fusion.algorithms import ALGORITHMS

if TYPE_CHECKING:
    import numpy as np

    from mimucap.io.broad_trials import BroadTrial

OUR_ALGORITHMS = ("ekf-taylor3", "ekf-taylor3-offline", "ekf-rk4", "ekf-rk4-offline",
                  "taylor3", "rk4")
DEFAULT_ALGORITHMS = ("ekf-taylor3", "ekf-taylor3-offline", "ekf-rk4", "taylor3", "rk4")
VQF_ALGORITHMS = ("vqf", "vqf-offline")
CATEGORIES = ("undisturbed", "tapping", "vibration", "magnets")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("bench", help="accuracy benchmarks on public data sets",
                                   description="Accuracy benchmarks on public data sets.")
    parser.set_defaults(func=lambda args: (parser.print_help(), 2)[1])
    sub = parser.add_subparsers(dest="bench_command", metavar="BENCH")
    orientation = sub.add_parser(
        "orientation", help="orientation RMSE on BROAD trials",
        description="Total/heading/inclination RMSE (deg) of the orientation algorithms on "
                    "every BROAD trial in DIR, with VQF as reference if installed.")
    orientation.add_argument("directory", type=Path, help="folder with BROAD *.hdf5 trials")
    orientation.add_argument("--algorithm", action="append",
                             choices=OUR_ALGORITHMS + VQF_ALGORITHMS,
                             help=f"repeatable; default: {', '.join(DEFAULT_ALGORITHMS)} "
                                  "(+ vqf, vqf-offline when installed)")
    orientation.add_argument("--json", action="store_true", help="print one JSON object")
    orientation.set_defaults(func=run_orientation)


def _vqf_available() -> bool:
    try:
        import vqf  # noqa: F401
    except ImportError:
        return False
    return True


def estimate(trial: BroadTrial, algorithm: str) -> np.ndarray:
    """``q_world_from_sensor`` (N, 4) of one algorithm on one trial: ours through the
    per-sensor chain of the processing path (:class:`mimucap.core.pipeline.chain.SensorChain`,
    the trial's magnetometer as the data set calibrated it), VQF through its own package."""
    import numpy as np

    from mimucap.core.pipeline.chain import SensorChain
    from mimucap.core.pipeline.settings import RESULT_LIVE, RESULT_REPROCESSED

    if algorithm in VQF_ALGORITHMS:
        import vqf

        gyr = np.ascontiguousarray(trial.gyr_rad_s)
        acc = np.ascontiguousarray(trial.acc_m_s2)
        mag = np.ascontiguousarray(trial.mag_uT)
        ts = 1.0 / trial.sampling_rate_hz
        if algorithm == "vqf":
            return vqf.VQF(ts).updateBatch(gyr, acc, mag)["quat9D"]
        return vqf.offlineVQF(gyr, acc, mag, ts, {})["quat9D"]
    offline = algorithm.endswith("-offline")
    name = algorithm.removesuffix("-offline")
    if name not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {algorithm!r}")
    chain = SensorChain(trial.name, algorithm=name, doubt=False)
    return chain.process(trial.samples(), RESULT_REPROCESSED if offline else RESULT_LIVE).q_world_from_sensor


def _trial_errors(trial: BroadTrial, algorithm: str) -> dict:
    """One algorithm's errors (deg) and time (s) on one trial; ``ValueError`` naming the
    algorithm when no sample can be evaluated."""
    from mimucap.core.fusion.evaluation import orientation_errors

    if trial.n_samples == 0:
        raise ValueError("no samples (0 rows)")
    start = time.perf_counter()
    q = estimate(trial, algorithm)
    elapsed = time.perf_counter() - start
    try:
        errors = orientation_errors(q, trial.q_ref_world_from_sensor, trial.movement)
    except ValueError as error:
        raise ValueError(f"{algorithm}: {error}") from None
    return {"total_deg": errors.total_deg, "heading_deg": errors.heading_deg,
            "inclination_deg": errors.inclination_deg, "time_s": elapsed}


def evaluate(directory: Path, algorithms: list[str]) -> dict:
    """Per-trial, per-category and mean errors; the structure printed by ``--json``."""
    import numpy as np

    from mimucap.io.broad_trials import list_broad_trials, read_broad

    trials = []
    paths = list_broad_trials(directory)
    first = read_broad(paths[0])
    warm_up = replace(first, gyr_rad_s=first.gyr_rad_s[:50], acc_m_s2=first.acc_m_s2[:50],
                      mag_uT=first.mag_uT[:50])
    for algorithm in algorithms:
        estimate(warm_up, algorithm)  # load compiled kernels before anything is timed
    skipped = []
    for path in paths:
        trial = read_broad(path)
        if trial.q_ref_world_from_sensor is None or trial.movement is None:
            raise ValueError(f"{path}: needs the reference datasets opt_quat and movement")
        try:
            rows = {algorithm: _trial_errors(trial, algorithm) for algorithm in algorithms}
        except ValueError as error:  # nothing to evaluate on this trial: go on with the others
            skipped.append({"trial": trial.name, "file": str(path), "reason": str(error)})
            continue
        trials.append({"trial": trial.name, "category": trial.category,
                       "samples": trial.n_samples, "results": rows})
    if not trials:
        reasons = "; ".join(f"{s['trial']}: {s['reason']}" for s in skipped)
        raise ValueError(f"{directory}: no trial could be evaluated ({reasons})")

    def mean_of(selected: list[dict]) -> dict:
        return {algorithm: {key: float(np.mean([t["results"][algorithm][key] for t in selected]))
                            for key in ("total_deg", "heading_deg", "inclination_deg", "time_s")}
                for algorithm in algorithms}

    categories = {c: mean_of([t for t in trials if t["category"] == c])
                  for c in CATEGORIES if any(t["category"] == c for t in trials)}
    return {"algorithms": algorithms, "trials": trials, "skipped": skipped, "categories": categories,
            "mean": mean_of(trials),
            "metric": "RMSE (deg) over movement samples of q_est ⊗ q_ref⁻¹; mean over trials"}


def format_table(report: dict) -> str:
    """Plain-text table: one column per algorithm, cells ``total/heading/inclination``."""
    algorithms = report["algorithms"]
    cell = 20
    lines = ["Orientation RMSE on BROAD, degrees: total/heading/inclination per cell",
             f"{'trial':38s}" + "".join(f"{a:>{cell}s}" for a in algorithms)]

    def cells(results: dict) -> str:
        return "".join(f"{results[a]['total_deg']:>{cell - 12}.2f}/{results[a]['heading_deg']:5.2f}/"
                       f"{results[a]['inclination_deg']:5.2f}" for a in algorithms)

    for trial in report["trials"]:
        lines.append(f"{trial['trial'][:38]:38s}" + cells(trial["results"]))
    lines.append("")
    for category, results in report["categories"].items():
        lines.append(f"{'mean ' + category:38s}" + cells(results))
    lines.append(f"{'MEAN over ' + str(len(report['trials'])) + ' trials':38s}" + cells(report["mean"]))
    lines.append(f"{'time per trial (s)':38s}" + "".join(
        f"{report['mean'][a]['time_s']:>{cell}.3f}" for a in algorithms))
    for item in report["skipped"]:
        lines.append(f"skipped {item['trial']}: {item['reason']}")
    return "\n".join(lines)


def run_orientation(args: argparse.Namespace) -> int:
    algorithms = list(args.algorithm or DEFAULT_ALGORITHMS)
    if not args.algorithm and _vqf_available():
        algorithms += list(VQF_ALGORITHMS)
    for algorithm in algorithms:
        if algorithm in VQF_ALGORITHMS and not _vqf_available():
            raise ValueError(f"{algorithm}: the vqf package is not installed (pip install vqf)")
    report = evaluate(args.directory, algorithms)
    for item in report["skipped"]:
        print(f"mimucap bench: skipped trial {item['trial']} ({item['file']}): {item['reason']}", file=sys.stderr)
    if args.json:
        print(json.dumps(report, indent=1))
    else:
        print(format_table(report))
    return 0
