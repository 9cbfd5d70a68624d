"""Benchmark: gait-event and stride-length accuracy against independent references.

1. The gaitmap example (``../shared/data/gait/gaitmap_example``: foot IMUs at 204.8 Hz with
   optical gait events and heel-marker stride positions; MIT licence, Küderle et al. 2024):
   analysed as ``mimucap gait`` does, compared with the straight reference strides (optical
   heading change ≤ 45°).
2. The simulated suit (``demo`` scenario with BNO055-like sensors: on-board orientation, body
   calibration from its N-pose/T-pose, session written without truth, review and analysis),
   with foot sensors (17-sensor suit, fifteen segments) and with shank sensors only (ten
   segments), compared with the simulator's contact truth in its steady walks.

Prints per data set: |IC error| and |FC error| median and 95th percentile (ms), missed and extra
strides, stride-length error mean, SD and mean absolute (cm). Goals (gaitmap): median |IC| ≤
20 ms, median |FC| ≤ 30 ms, no missed or extra straight stride, stride length MAE ≤ 5 cm.

Run: ``.venv/bin/python bench/bench_gait.py [--data ../shared/data/gait/gaitmap_example]``
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from mimucap.core.analysis.gait import GaitInput, analyse_gait
from mimucap.core.simulate.config import SimulationConfig
from mimucap.io.gait_csv import read_foot_imu_csv, read_gaitmap_reference
from mimucap.session.analysis_evaluation import (
    compare,
    simulated_analysis,
    simulated_reference,
    straight_reference,
    walk_windows,
)

DEFAULT_DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "gait" / "gaitmap_example"


def gaitmap_figures(folder: Path) -> dict:
    feet = read_foot_imu_csv(folder / "imu_sample.csv", 204.8, "deg/s")
    gait = analyse_gait([GaitInput(side, "foot", side, imu.t_s, imu.sagittal_rate, imu.acc, imu.gyr)
                         for side, imu in feet.items()])
    return compare(gait.strides, straight_reference(read_gaitmap_reference(folder))).summary()


def simulated_figures(n_sensors: int, seed: int) -> dict:
    config = SimulationConfig(scenario="demo", duration_s=30.0, n_sensors=n_sensors, errors="bno055", seed=seed)
    with tempfile.TemporaryDirectory() as folder:
        result, analysis = simulated_analysis(config, folder)
    windows = walk_windows(result.markers, float(result.truth.t_s[-1]))
    return compare(analysis.gait.strides, simulated_reference(result), windows=windows).summary()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--seed", type=int, default=3)
    args = parser.parse_args()
    rows = [("gaitmap example, foot IMUs", gaitmap_figures(args.data.resolve())),
            ("simulated suit, foot sensors (17)", simulated_figures(17, args.seed)),
            ("simulated suit, shank sensors (10)", simulated_figures(10, args.seed))]
    print(f"{'data':36s} {'strides':>8s} {'IC med/p95 ms':>14s} {'FC med/p95 ms':>14s} {'missed':>6s} {'extra':>5s} "
          f"{'length mean/SD/MAE cm':>22s}")
    for name, f in rows:
        print(f"{name:36s} {f['n_reference']:8d} {f['ic_median_ms']:6.1f}/{f['ic_p95_ms']:<7.1f} "
              f"{f['fc_median_ms']:6.1f}/{f['fc_p95_ms']:<7.1f} {f['missed']:6d} {f['extra']:5d} "
              f"{f['length_mean_cm']:+7.1f}/{f['length_sd_cm']:.1f}/{f['length_mae_cm']:.1f}")


if __name__ == "__main__":
    main()
