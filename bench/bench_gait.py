"""Benchmark: gait-event and stride-length accuracy against independent references.

1. The gaitmap example (``../shared/data/gait/gaitmap_example``: foot IMUs at 204.8 Hz with
   optical gait events and heel-marker stride positions; MIT licence, Küderle et al. 2024),
   analysed as ``mimucap gait`` does (each sensor's axes found in its own samples), compared
   with the straight reference strides (optical heading change ≤ 45°), as recorded and as other
   sensors would have recorded it (:data:`~mimucap.session.recorded.gait_validation.GAITMAP_VARIANTS`:
   the raw samples resampled to 102.4 and 100 Hz, turned on the foot by 20-45° about the
   mediolateral axis and 10-20° about the vertical, both signs): one table per variant.
2. The simulated suit (``demo`` scenario with BNO055-like sensors: on-board orientation, body
   calibration from its N-pose/T-pose, session written without truth, review and analysis),
   with foot sensors (17-sensor suit, fifteen segments) and with shank sensors only (ten
   segments), compared with the simulator's contact truth in its steady walks.

3. Where the optical initial contact of the gaitmap walk sits on its own markers: the delay
   from it to the toe marker's highest point, to the heel marker's lowest point and to the heel
   marker's horizontal speed falling below 0.5 m/s (markers at 100 Hz), medians over the
   straight strides.

Prints per data set and side: |IC error| and |FC error| median and 95th percentile (ms), missed
and extra strides, stride-length error mean, SD and mean absolute (cm), and how many initial
contacts were timed at the heel strike's impact (the rest by the angular-rate rule). Goals:
median |IC| ≤ 20 ms, median |FC| ≤ 30 ms, no missed or extra straight stride, stride length
MAE ≤ 5 cm; each table says which it meets.

Run: ``.venv/bin/python bench/bench_gait.py [--data ../shared/data/gait/gaitmap_example]``
"""

from __future__ import annotations

import argparse
import csv
import math
import tempfile
from pathlib import Path

import numpy as np

from mimucap.core.analysis.gait import GaitAnalysis
from mimucap.core.simulate.config import SimulationConfig
from mimucap.session.recorded.gait_validation import (
    GAITMAP_VARIANTS,
    compare,
    gaitmap_variant_analysis,
    simulated_analysis,
    simulated_reference,
    straight_reference,
    walk_windows,
)

DEFAULT_DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "gait" / "gaitmap_example"
GOALS = {"ic_median_ms": 20.0, "fc_median_ms": 30.0, "length_mae_cm": 5.0}


def side_rows(gait: GaitAnalysis, reference: list, windows=None) -> list[tuple[str, dict, str]]:
    """(side, figures, impacts "k/n") for left, right and both."""
    rows = []
    for side in ("left", "right", "both"):
        sides = ("left", "right") if side == "both" else (side,)
        figures = compare([s for s in gait.strides if s.side in sides], [r for r in reference if r.side in sides],
                          windows=windows).summary()
        events = [gait.events[s] for s in sides if s in gait.events]
        impacts = f"{sum(int(e.ic_at_impact.sum()) for e in events)}/{sum(len(e) for e in events)}"
        rows.append((side, figures, impacts))
    return rows


def verdict(figures: dict) -> str:
    failed = [f"{key} {figures[key]:.1f} > {goal:g}" for key, goal in GOALS.items()
              if math.isfinite(figures[key]) and figures[key] > goal]
    if figures["missed"] or figures["extra"]:
        failed.append(f"{figures['missed']} missed, {figures['extra']} extra")
    return "meets every goal" if not failed else "misses: " + ", ".join(failed)


def print_table(title: str, rows: list[tuple[str, dict, str]]) -> None:
    print(f"\n{title}")
    print(f"  {'side':6s} {'strides':>7s} {'IC med/p95 ms':>14s} {'FC med/p95 ms':>14s} {'missed':>6s} {'extra':>5s} "
          f"{'length mean/SD/MAE cm':>22s} {'IC at impact':>12s}")
    for side, f, impacts in rows:
        print(f"  {side:6s} {f['n_reference']:7d} {f['ic_median_ms']:6.1f}/{f['ic_p95_ms']:<7.1f} "
              f"{f['fc_median_ms']:6.1f}/{f['fc_p95_ms']:<7.1f} {f['missed']:6d} {f['extra']:5d} "
              f"{f['length_mean_cm']:+7.1f}/{f['length_sd_cm']:.1f}/{f['length_mae_cm']:.1f}  {impacts:>12s}")
    print(f"  both sides: {verdict(rows[-1][1])}")


def simulated_rows(n_sensors: int, seed: int) -> list[tuple[str, dict, str]]:
    config = SimulationConfig(scenario="demo", duration_s=30.0, n_sensors=n_sensors, errors="bno055", seed=seed)
    with tempfile.TemporaryDirectory() as folder:
        result, analysis = simulated_analysis(config, folder)
    windows = walk_windows(result.markers, float(result.truth.t_s[-1]))
    return side_rows(analysis.gait, simulated_reference(result), windows)


def marker_delays_ms(folder: Path, reference: list) -> dict[str, float]:
    """Median delays (ms) from the optical initial contact to marker features (module doc)."""
    with open(folder / "mocap_sample.csv", newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    columns = {(marker, axis): k for k, (marker, axis) in enumerate(zip(rows[0], rows[1]))}
    values = np.array(rows[2:], dtype=float) / 1000.0   # mm → m
    rate_hz = 100.0
    names = ("toe marker at its highest", "heel marker at its lowest", "heel marker below 0.5 m/s")
    delays: dict[str, list[float]] = {name: [] for name in names}
    for r in reference:
        letter = "L" if r.side == "left" else "R"
        heel = values[:, [columns[(f"{letter}_FCC", a)] for a in "xyz"]]
        toe_z = values[:, columns[(f"{letter}_TOE", "z")]]
        speed = np.hypot(*np.gradient(heel[:, :2], axis=0).T) * rate_hz
        at = int(round(r.ic * rate_hz))
        span = slice(at - 8, at + 9)   # ± 80 ms
        first = at - 8
        delays["toe marker at its highest"].append(first + int(np.argmax(toe_z[span])) - r.ic * rate_hz)
        delays["heel marker at its lowest"].append(first + int(np.argmin(heel[span, 2])) - r.ic * rate_hz)
        delays["heel marker below 0.5 m/s"].append(first + int(np.argmax(speed[span] < 0.5)) - r.ic * rate_hz)
    return {name: float(np.median(v)) * 1000.0 / rate_hz for name, v in delays.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--seed", type=int, default=3)
    args = parser.parse_args()
    for variant in GAITMAP_VARIANTS:
        gait, reference = gaitmap_variant_analysis(args.data.resolve(), variant)
        print_table(f"gaitmap example, foot IMUs, {variant.name}", side_rows(gait, straight_reference(reference)))
    delays = marker_delays_ms(args.data.resolve(), straight_reference(reference))
    print("\ngaitmap example: from the optical initial contact to "
          + ", ".join(f"the {name}: {value:+.0f} ms" for name, value in delays.items()) + " (medians)")
    print_table("simulated suit, foot sensors (17)", simulated_rows(17, args.seed))
    print_table("simulated suit, shank sensors (10)", simulated_rows(10, args.seed))


if __name__ == "__main__":
    main()
