"""How right the doubtful-seconds flags are: the ``<joint>_ok`` columns of ``mimucap angles``
against the simulator's truth, on the demo with and without a magnetic disturbance, over seeds.

For each seed the command-line route runs as a user would (``simulate --scenario demo --duration
90 --seed K [--disturbance 30,-20,10,34,90]`` → ``magcal fit --save`` into a store of its own →
``bodycal --out CAL.json`` → ``angles --calibration CAL.json``, reprocessed and ``--live``); the
disturbed session is also processed with the clean session's body calibration (the same subject
and sensors, calibrated before the field changed). Per knee and hip, flexion against the truth:

* ``ok walk``: the share of the walking samples flagged 1 (a flag that is always 0 is useless);
* ``ok all``: the share of all samples flagged 1;
* ``worst ok``: the largest flexion error (deg) where flagged 1 (the flag's promise: ≤ 5°);
* ``>10° caught``: of the samples off by more than 10°, the share flagged 0 (should be 1), and
  how many there are.

Run: ``.venv/bin/python bench/bench_doubt.py [--seeds 0-3]``.
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
from mimucap.io.angles_export import read_angles_csv
from mimucap.io.session import read_session
from mimucap.session.evaluation import truth_at

DISTURBANCE = "30,-20,10,34,90"
JOINTS = ("knee_l", "knee_r", "hip_l", "hip_r")


def seeds_of(text: str) -> list[int]:
    low, _sep, high = text.partition("-")
    return list(range(int(low), int(high or low) + 1))


def run(args: list[str]) -> None:
    with contextlib.redirect_stdout(io.StringIO()):
        status = main(args)
    if status not in (0, 3):  # 3: a poor body calibration, written all the same
        raise SystemExit(f"mimucap {' '.join(args)} exited {status}")


def route(folder: Path, name: str, seed: int, extra: list[str]) -> tuple[Path, Path]:
    os.environ["MIMUCAP_DATA_DIR"] = str(folder / f"data_{name}")
    session = folder / f"{name}.h5"
    run(["simulate", "--scenario", "demo", "--duration", "90", "--seed", str(seed), "--out", str(session)] + extra)
    run(["magcal", "fit", str(session), "--save"])
    calibration = folder / f"{name}_cal.json"
    run(["bodycal", str(session), "--out", str(calibration)])
    return session, calibration


def measure(folder: Path, session: Path, calibration: Path, live: bool) -> dict[str, tuple]:
    os.environ["MIMUCAP_DATA_DIR"] = str(folder / f"data_{session.stem}")
    out = folder / f"{session.stem}_{calibration.stem}_{'live' if live else 'reprocessed'}.csv"
    run(["angles", str(session), "--calibration", str(calibration), "--out", str(out), "--accept-poor"]
        + (["--live"] if live else []))
    table = read_angles_csv(out)
    recorded = read_session(session)
    walking = np.zeros(len(table.t_s), dtype=bool)
    for start, end in phases.phase_windows(recorded.markers, phases.WALK, float(table.t_s[-1])):
        walking |= (table.t_s >= start) & (table.t_s < end)
    found = {}
    for joint in JOINTS:
        column = f"{joint}_flexion_deg"
        error = np.abs(table.angles_deg[column] - truth_at(table.t_s, recorded.truth.t_s,
                                                           recorded.truth.joint_angles_deg[column]))
        ok = table.ok[joint]
        big = error > 10.0
        found[joint] = (float(np.mean(ok[walking])), float(np.mean(ok)),
                        float(error[ok].max()) if ok.any() else float("nan"),
                        float(np.mean(~ok[big])) if big.any() else float("nan"), int(np.count_nonzero(big)))
    return found


def main_bench() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="0-3", help="seeds, e.g. 3 or 0-3")
    args = parser.parse_args()
    print(f"{'seed':>4} {'case':<28} {'result':<11} {'joint':<7} {'ok walk':>8} {'ok all':>7} "
          f"{'worst ok':>9} {'>10° caught':>12}")
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        for seed in seeds_of(args.seeds):
            clean = route(folder, f"clean{seed}", seed, [])
            disturbed = route(folder, f"disturbed{seed}", seed, ["--disturbance", DISTURBANCE])
            cases = (("clean", clean[0], clean[1]), ("disturbed", disturbed[0], disturbed[1]),
                     ("disturbed, clean calibration", disturbed[0], clean[1]))
            for case, session, calibration in cases:
                for live in (False, True):
                    for joint, (walk, share, worst, caught, big) in measure(folder, session, calibration, live).items():
                        print(f"{seed:>4} {case:<28} {'live' if live else 'reprocessed':<11} {joint:<7} "
                              f"{walk:8.2f} {share:7.2f} {worst:9.1f} {caught:7.2f} ({big:>4})")


if __name__ == "__main__":
    main_bench()
