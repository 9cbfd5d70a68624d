"""Leave-one-trial-out cross-validation of the orientation filter's free settings on BROAD.

Plain script: ``.venv/bin/python bench/bench_broad_cv.py [DIR]`` (DIR defaults to
``$MIMUCAP_TEST_DATA/broad``, else ``../shared/data/broad``; VQF rows need the ``vqf`` package of
the ``bench`` extra).

The filter's free settings without a value from the sensor's noise figures are the two noise
terms that grow with what the data show: the heading noise from the field's quality
(``heading_field_error_gain``) and the gyroscope's scale-factor noise
(``gyr_scale_noise_sqrt_s``). Every combination of :data:`GRID` runs, online (:func:`fuse`)
and offline (:func:`fuse_offline`), on every trial. For each trial in turn, the combination with
the lowest mean of the online and offline total RMSE on the *other* trials is chosen (one
parameter set serves both, as in the pipeline), and its scores on the left-out trial are the
held-out scores: what the settings achieve on a trial they were not chosen on. The combination
chosen on all trials is printed beside the defaults (:data:`DEFAULT_FUSION_PARAMS`), which
should be that choice.

Printed per trial and per category (from the trial names): BROAD's total RMSE (deg) of the
defaults and of the held-out choice, online and offline, beside VQF 9D with default parameters
online (``vqf.VQF(Ts).updateBatch``) and offline (``vqf.offlineVQF``), and the gyroscope's white
noise density measured in the trials' rest samples next to the default
``gyr_noise_rad_s_sqrt_hz`` it stands for.
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import re
import sys
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np

from mimucap.core.fusion.ekf import fuse
from mimucap.core.fusion.evaluation import orientation_errors
from mimucap.core.fusion.offline import fuse_offline
from mimucap.core.fusion.params import DEFAULT_FUSION_PARAMS, DEG
from mimucap.io.broad_trials import BroadTrial, list_broad_trials, read_broad

#: The settings cross-validated and the values tried.
GRID: dict[str, tuple[float, ...]] = {
    "heading_field_error_gain": (0.0, 1.0, 2.0, 3.0, 4.0),
    "gyr_scale_noise_sqrt_s": (0.0, 0.00025, 0.0005, 0.00075),
}

#: Categories of the trial names, first match wins.
CATEGORIES = (
    ("rotation", re.compile(r"undisturbed_.*rotation")),
    ("translation", re.compile(r"undisturbed_.*translation")),
    ("tapping", re.compile(r"tapping")),
    ("vibration", re.compile(r"vibration")),
    ("stationary magnet", re.compile(r"stationary_magnet")),
    ("attached magnet", re.compile(r"attached_magnet")),
)


def default_directory() -> Path:
    root = os.environ.get("MIMUCAP_TEST_DATA")
    base = Path(root) if root else Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
    return base / "broad"


def category(name: str) -> str:
    for label, pattern in CATEGORIES:
        if pattern.search(name):
            return label
    return "other"


def total_rmse_deg(trial: BroadTrial, q_world_from_sensor: np.ndarray) -> float:
    return orientation_errors(q_world_from_sensor, trial.q_ref_world_from_sensor, trial.movement).total_deg


def our_scores(trial: BroadTrial, params) -> tuple[float, float]:
    """Total RMSE (deg) online and offline of one parameter set on one trial."""
    args = (trial.t_s, trial.gyr_rad_s, trial.acc_m_s2, trial.mag_uT)
    return (total_rmse_deg(trial, fuse(*args, params=params).q_world_from_sensor),
            total_rmse_deg(trial, fuse_offline(*args, params=params).q_world_from_sensor))


def vqf_scores(trial: BroadTrial) -> tuple[float, float]:
    """VQF 9D with default parameters, online and offline; NaN without the package."""
    try:
        import vqf
    except ImportError:
        return math.nan, math.nan
    gyr, acc, mag = (np.ascontiguousarray(a) for a in (trial.gyr_rad_s, trial.acc_m_s2, trial.mag_uT))
    ts = 1.0 / trial.sampling_rate_hz
    return (total_rmse_deg(trial, vqf.VQF(ts).updateBatch(gyr, acc, mag)["quat9D"]),
            total_rmse_deg(trial, vqf.offlineVQF(gyr, acc, mag, ts, {})["quat9D"]))


def rest_noise_density(trial: BroadTrial) -> float:
    """The gyroscope's white noise density (rad/s/√Hz, mean of the axes) over the samples the
    filter flags as resting: the rms of successive differences / √2 is the per-sample noise
    (a slowly varying bias cancels), divided by √(sampling rate)."""
    result = fuse(trial.t_s, trial.gyr_rad_s, trial.acc_m_s2, trial.mag_uT)
    rest = result.flag_masks()["rest"]
    pairs = rest[1:] & rest[:-1]
    diff = np.diff(trial.gyr_rad_s, axis=0)[pairs]
    per_sample = np.sqrt(np.mean(diff ** 2, axis=0) / 2.0)
    return float(np.mean(per_sample) / math.sqrt(trial.sampling_rate_hz))


def leave_one_out(scores: np.ndarray) -> list[int]:
    """``scores`` (combinations, trials, 2: online/offline); per trial the combination whose
    mean of online and offline over the other trials is lowest."""
    objective = scores.mean(axis=2)  # (combinations, trials)
    n = objective.shape[1]
    total = objective.sum(axis=1)
    return [int(np.argmin((total - objective[:, i]) / (n - 1))) for i in range(n)]


def fmt(values) -> str:
    return " ".join(f"{v:7.2f}" for v in values)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("directory", nargs="?", type=Path, default=default_directory())
    args = parser.parse_args(argv)
    paths = list_broad_trials(args.directory)
    trials = [read_broad(path) for path in paths]
    started = time.perf_counter()
    combos = [dict(zip(GRID, values)) for values in itertools.product(*GRID.values())]
    scores = np.array([[our_scores(trial, replace(DEFAULT_FUSION_PARAMS, **combo)) for trial in trials]
                       for combo in combos])
    defaults = np.array([our_scores(trial, DEFAULT_FUSION_PARAMS) for trial in trials])
    vqf_rows = np.array([vqf_scores(trial) for trial in trials])
    picks = leave_one_out(scores)
    held = np.array([scores[pick, i] for i, pick in enumerate(picks)])
    all_fit = int(np.argmin(scores.mean(axis=(1, 2))))
    density = [rest_noise_density(trial) for trial in trials]

    print(f"BROAD, {len(trials)} trials in {args.directory}: total RMSE (deg) over movement samples")
    print(f"grid: {', '.join(f'{k} {list(v)}' for k, v in GRID.items())}; {len(combos)} combinations, "
          f"{time.perf_counter() - started:.0f} s")
    header = f"{'trial':44s} {'default':>7s} {'':>7s} {'held-out':>7s} {'':>7s} {'VQF':>7s} {'VQF':>7s}"
    print(header)
    print(f"{'':44s} {'online':>7s} {'offline':>7s} {'online':>7s} {'offline':>7s} {'online':>7s} {'offline':>7s}")
    for i, trial in enumerate(trials):
        print(f"{trial.name[:44]:44s} {fmt([*defaults[i], *held[i], *vqf_rows[i]])}")
    print()
    names = [category(trial.name) for trial in trials]
    groups = [(label, [i for i, n in enumerate(names) if n == label]) for label, _ in CATEGORIES]
    groups.append(("undisturbed", [i for i, t in enumerate(trials) if "undisturbed" in t.name]))
    groups.append(("disturbed", [i for i, t in enumerate(trials) if "undisturbed" not in t.name]))
    for label, rows in groups:
        if rows:
            print(f"{'mean ' + label + f' ({len(rows)})':44s} "
                  f"{fmt([*defaults[rows].mean(0), *held[rows].mean(0), *vqf_rows[rows].mean(0)])}")
    print(f"{f'MEAN over {len(trials)} trials':44s} {fmt([*defaults.mean(0), *held.mean(0), *vqf_rows.mean(0)])}")
    print()
    chosen = Counter(picks)
    print("held-out choices (combination: folds): " + "; ".join(
        f"{', '.join(f'{k}={v:g}' for k, v in combos[c].items())}: {count}" for c, count in chosen.most_common()))
    best = combos[all_fit]
    current = {k: getattr(DEFAULT_FUSION_PARAMS, k) for k in GRID}
    print(f"chosen on all {len(trials)} trials: {best} (online {scores[all_fit, :, 0].mean():.3f}, "
          f"offline {scores[all_fit, :, 1].mean():.3f}); defaults {current}: "
          f"online {defaults[:, 0].mean():.3f}, offline {defaults[:, 1].mean():.3f}")
    off_terms = replace(DEFAULT_FUSION_PARAMS, **{k: 0.0 for k in GRID})
    without = np.array([our_scores(trial, off_terms) for trial in trials])
    print(f"defaults without both terms: online {without[:, 0].mean():.3f}, offline {without[:, 1].mean():.3f}")
    print(f"gyroscope white noise at rest: {np.mean(density) / DEG:.4f} °/s/√Hz "
          f"(trials {min(density) / DEG:.4f}-{max(density) / DEG:.4f}); default gyr_noise_rad_s_sqrt_hz "
          f"{DEFAULT_FUSION_PARAMS.gyr_noise_rad_s_sqrt_hz / DEG:.4f} °/s/√Hz")
    return 0


if __name__ == "__main__":
    sys.exit(main())
