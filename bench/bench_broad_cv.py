"""Leave-one-trial-out cross-validation of the orientation filter's free settings on BROAD.

Plain script: ``.venv/bin/python bench/bench_broad_cv.py [DIR]`` (DIR defaults to
``$MIMUCAP_TEST_DATA/broad``, else ``../shared/data/broad``; VQF rows need the ``vqf`` package of
the ``bench`` extra). About 7 minutes on one core: every combination of :data:`GRID` and of
:data:`SMOOTHER_GRID` runs on every trial.

The free settings are those without a value from the sensor's noise figures: the heading noise
from the field's quality (``heading_field_error_gain``), the gyroscope's scale-factor noise
(``gyr_scale_noise_sqrt_s``) and the hard-iron tracking's memory and least offset
(``mag_offset_tau_s``, ``mag_offset_min_uT``). Every combination runs online (:func:`fuse`)
and offline (:func:`fuse_offline`) on every trial. For each trial in turn, the combination with
the lowest mean of the online and offline total RMSE on the *other* trials is chosen (one
parameter set serves both, as in the pipeline), and its scores on the left-out trial are the
held-out scores: what the settings achieve on a trial they were not chosen on.

The smoother's own magnetometer weighting (``smoother_heading_field_error_gain``,
``smoother_mag_ref_tau_s``: :meth:`~mimucap.core.fusion.params.FusionParams.smoother_pass`)
only changes the offline result; every combination of :data:`SMOOTHER_GRID` runs offline on
every trial (the other settings at their defaults), and the held-out offline score is that of
the combination with the lowest offline mean on the other trials.

Printed per trial and per category (from the trial names): BROAD's total RMSE (deg) of the
defaults (:data:`DEFAULT_FUSION_PARAMS`), of the held-out choices and of the defaults without
the hard-iron tracking, online and offline, beside VQF 9D with default parameters online
(``vqf.VQF(Ts).updateBatch``) and offline (``vqf.offlineVQF``). Then the held-out choices, the
combinations chosen on all trials, the held-out scores of the hard-iron settings alone and of the
heading noise's field-quality gain alone (:data:`SINGLE_CHOICES`, the other settings at their
defaults), the best combination that keeps the trials ``tests/core/fusion/test_broad_scores.py``
bounds below VQF's online score (:data:`BOUNDED_TRIALS`), the held-out scores of a choice made
only among the combinations within the bounds of the training trials, and the gyroscope's white
noise density measured in the trials' rest samples.
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
GRID: dict[str, tuple] = {
    "heading_field_error_gain": (2.0, 3.0, 4.0, 5.0),
    "gyr_scale_noise_sqrt_s": (0.00025, 0.0005, 0.00075),
    "mag_offset_tau_s": (2.0, 3.0, 5.0),
    "mag_offset_min_uT": (2.0, 3.0, 5.0),
}

#: The smoother's own magnetometer weighting (:meth:`FusionParams.smoother_pass`), cross-validated
#: on the offline scores alone (it does not touch the online filter), the other settings at
#: their defaults.
SMOOTHER_GRID: dict[str, tuple] = {
    "smoother_heading_field_error_gain": (4.0, 6.0, 8.0, 10.0, 12.0, 16.0),
    "smoother_mag_ref_tau_s": (300.0, 1000.0, 3000.0, 10000.0),
}

#: The settings of the hard-iron tracking (:mod:`mimucap.core.fusion.hard_iron`).
HARD_IRON_SETTINGS = ("mag_offset_tau_s", "mag_offset_min_uT")

#: Settings also cross-validated alone (the others at their defaults), each group's held-out
#: scores printed: the hard-iron tracking's, and the heading noise's gain from the field's
#: quality (an online setting only: the smoother has its own).
SINGLE_CHOICES = (HARD_IRON_SETTINGS, ("heading_field_error_gain",))

#: The defaults without the hard-iron tracking: what the filter did before it.
WITHOUT_TRACKING = {"mag_offset_tau_s": 0.0}

#: Trials ``tests/core/fusion/test_broad_scores.py`` holds below VQF's online score, online and
#: offline.
BOUNDED_TRIALS = ("24_disturbed_tapping_A", "26_disturbed_phone_vibration_A", "32_disturbed_attached_magnet_1cm")

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
    """The gyroscope's white noise density (rad/s/√Hz, rms of the axes) over the samples the
    filter flags as resting: successive differences cancel a slowly varying bias and hold
    twice the white noise's variance, ``N²/dt`` per sample."""
    result = fuse(trial.t_s, trial.gyr_rad_s, trial.acc_m_s2, trial.mag_uT)
    rest = result.flag_masks()["rest"]
    pairs = rest[1:] & rest[:-1]
    diff = np.diff(trial.gyr_rad_s, axis=0)[pairs]
    return float(np.sqrt(np.mean(diff ** 2) / (2.0 * trial.sampling_rate_hz)))


def offline_score(trial: BroadTrial, params) -> float:
    """Total RMSE (deg) of the offline smoother of one parameter set on one trial."""
    return total_rmse_deg(trial, fuse_offline(trial.t_s, trial.gyr_rad_s, trial.acc_m_s2, trial.mag_uT,
                                              params=params).q_world_from_sensor)


def leave_one_out(scores: np.ndarray, allowed: np.ndarray | None = None) -> list[int]:
    """``scores`` (combinations, trials, 2: online/offline); per trial the combination whose
    mean of online and offline over the other trials is lowest, among those ``allowed`` by the
    other trials ((combinations, trials) bool: a combination is allowed in a fold when every
    training trial allows it; None: all)."""
    objective = scores.mean(axis=2)  # (combinations, trials)
    n = objective.shape[1]
    total = objective.sum(axis=1)
    picks = []
    for i in range(n):
        mean_others = (total - objective[:, i]) / (n - 1)
        if allowed is not None:
            mean_others = np.where(np.delete(allowed, i, axis=1).all(axis=1), mean_others, np.inf)
        picks.append(int(np.argmin(mean_others)))
    return picks


def fmt(values) -> str:
    return " ".join(f"{v:7.2f}" for v in values)


def describe(combo: dict) -> str:
    return ", ".join(f"{key}={value:g}" for key, value in combo.items())


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
    before = np.array([our_scores(trial, replace(DEFAULT_FUSION_PARAMS, **WITHOUT_TRACKING))
                       for trial in trials])
    vqf_rows = np.array([vqf_scores(trial) for trial in trials])
    picks = leave_one_out(scores)
    held = np.array([scores[pick, i] for i, pick in enumerate(picks)])
    all_fit = int(np.argmin(scores.mean(axis=(1, 2))))
    smoother_combos = [dict(zip(SMOOTHER_GRID, values)) for values in itertools.product(*SMOOTHER_GRID.values())]
    smoother_scores = np.array([[offline_score(trial, replace(DEFAULT_FUSION_PARAMS, **combo)) for trial in trials]
                                for combo in smoother_combos])
    bounded = [i for i, trial in enumerate(trials) if trial.name in BOUNDED_TRIALS]
    smoother_allowed = None
    if bounded and not np.isnan(vqf_rows[bounded, 0]).any():
        # (combinations, trials): the smoother within VQF's online score where bounded
        smoother_allowed = np.ones(smoother_scores.shape, dtype=bool)
        smoother_allowed[:, bounded] = smoother_scores[:, bounded] < vqf_rows[bounded, 0][None, :]
    smoother_picks = leave_one_out(smoother_scores[:, :, None], smoother_allowed)
    grid_held_offline = held[:, 1].copy()
    # the held-out offline score: the smoother's settings chosen on the other trials (within
    # their bounds, as the defaults are chosen)
    held[:, 1] = [smoother_scores[pick, i] for i, pick in enumerate(smoother_picks)]
    smoother_fit = int(np.argmin(smoother_scores.mean(axis=1)))

    print(f"BROAD, {len(trials)} trials in {args.directory}: total RMSE (deg) over movement samples")
    print(f"grid: {'; '.join(f'{k} {list(v)}' for k, v in GRID.items())}; {len(combos)} combinations; "
          f"smoother grid: {'; '.join(f'{k} {list(v)}' for k, v in SMOOTHER_GRID.items())}; "
          f"{len(smoother_combos)} combinations; {time.perf_counter() - started:.0f} s")
    print("held-out: online with the grid's settings chosen on the other trials, offline with the "
          "smoother grid's")
    print(f"{'trial':44s} {'default':>7s} {'':>7s} {'held-out':>7s} {'':>7s} {'no track':>7s} {'':>7s} "
          f"{'VQF':>7s} {'VQF':>7s}")
    print(f"{'':44s}" + " {:>7s} {:>7s}".format("online", "offline") * 4)
    for i, trial in enumerate(trials):
        print(f"{trial.name[:44]:44s} {fmt([*defaults[i], *held[i], *before[i], *vqf_rows[i]])}")
    print()
    names = [category(trial.name) for trial in trials]
    groups = [(label, [i for i, n in enumerate(names) if n == label]) for label, _ in CATEGORIES]
    groups.append(("undisturbed", [i for i, t in enumerate(trials) if "undisturbed" in t.name]))
    groups.append(("disturbed", [i for i, t in enumerate(trials) if "undisturbed" not in t.name]))
    groups.append((f"over {len(trials)} trials", list(range(len(trials)))))
    for label, rows in groups:
        if rows:
            print(f"{'mean ' + label + f' ({len(rows)})':44s} "
                  f"{fmt([*defaults[rows].mean(0), *held[rows].mean(0), *before[rows].mean(0), *vqf_rows[rows].mean(0)])}")
    print()
    print("held-out choices (folds: combination): " + "; ".join(
        f"{count}: {describe(combos[c])}" for c, count in Counter(picks).most_common()))
    print(f"chosen on all {len(trials)} trials: {describe(combos[all_fit])} "
          f"(online {scores[all_fit, :, 0].mean():.3f}, offline {scores[all_fit, :, 1].mean():.3f})")
    print("smoother held-out choices, within the bounds of the training trials (folds: combination): " + "; ".join(
        f"{count}: {describe(smoother_combos[c])}" for c, count in Counter(smoother_picks).most_common()))
    print(f"smoother chosen on all {len(trials)} trials: {describe(smoother_combos[smoother_fit])} "
          f"(offline {smoother_scores[smoother_fit].mean():.3f}); held-out offline of the grid's "
          f"choice (smoother at its defaults): {grid_held_offline.mean():.3f}")
    print(f"defaults: online {defaults[:, 0].mean():.3f}, offline {defaults[:, 1].mean():.3f}; "
          f"without the hard-iron tracking: online {before[:, 0].mean():.3f}, offline {before[:, 1].mean():.3f}")
    for chosen in SINGLE_CHOICES:
        own = [c for c, combo in enumerate(combos)
               if all(value == getattr(DEFAULT_FUSION_PARAMS, key) for key, value in combo.items()
                      if key not in chosen)]
        if own:
            own_picks = leave_one_out(scores[own])
            own_held = np.array([scores[own[pick], i] for i, pick in enumerate(own_picks)])
            print(f"held-out, choosing only {', '.join(chosen)} (the others at their defaults): "
                  f"online {own_held[:, 0].mean():.3f}, offline {own_held[:, 1].mean():.3f} (folds: " + "; ".join(
                      f"{count}: {describe({key: combos[own[c]][key] for key in chosen})}"
                      for c, count in Counter(own_picks).most_common()) + ")")
    if bounded and not np.isnan(vqf_rows[bounded, 0]).any():
        # (combinations, trials): within VQF's online score, online and offline, where bounded
        allowed = np.ones(scores.shape[:2], dtype=bool)
        allowed[:, bounded] = (scores[:, bounded, :] < vqf_rows[bounded, 0][None, :, None]).all(axis=2)
        within = np.flatnonzero(allowed.all(axis=1))
        if within.size:
            best = within[np.argmin(scores[within].mean(axis=(1, 2)))]
            print(f"best within the VQF bounds of {', '.join(trials[i].name[:2] for i in bounded)}: "
                  f"{describe(combos[best])} (online {scores[best, :, 0].mean():.3f}, "
                  f"offline {scores[best, :, 1].mean():.3f})")
        bounded_picks = leave_one_out(scores, allowed)
        bounded_held = np.array([scores[pick, i] for i, pick in enumerate(bounded_picks)])
        print(f"held-out, choosing within the bounds of the training trials: online "
              f"{bounded_held[:, 0].mean():.3f}, offline {bounded_held[:, 1].mean():.3f} (folds: " + "; ".join(
                  f"{count}: {describe(combos[c])}" for c, count in Counter(bounded_picks).most_common()) + ")")
    if smoother_allowed is not None:
        within = np.flatnonzero(smoother_allowed.all(axis=1))
        if within.size:
            best = within[np.argmin(smoother_scores[within].mean(axis=1))]
            print(f"smoother, best within the VQF bounds: {describe(smoother_combos[best])} "
                  f"(offline {smoother_scores[best].mean():.3f})")
        free_picks = leave_one_out(smoother_scores[:, :, None])
        free_held = np.array([smoother_scores[pick, i] for i, pick in enumerate(free_picks)])
        print(f"smoother held-out, choosing without the bounds: offline {free_held.mean():.3f} (folds: "
              + "; ".join(f"{count}: {describe(smoother_combos[c])}" for c, count in Counter(free_picks).most_common())
              + ")")
    density = [rest_noise_density(trial) for trial in trials]
    print(f"gyroscope white noise at rest: {np.mean(density) / DEG:.4f} °/s/√Hz "
          f"(trials {min(density) / DEG:.4f}-{max(density) / DEG:.4f}); default gyr_noise_rad_s_sqrt_hz "
          f"{DEFAULT_FUSION_PARAMS.gyr_noise_rad_s_sqrt_hz / DEG:.4f} °/s/√Hz")
    return 0


if __name__ == "__main__":
    sys.exit(main())
