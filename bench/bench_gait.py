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
   straight strides. The dataset's optical events are Zeni et al.'s ("Two simple methods for
   determining gait events during treadmill and overground walking using kinematic data",
   2008: heel strike where the heel leads the pelvis most); on the simulated walk (whose
   contacts are known) the bench shows where Zeni's heel strike and toe-off fall against them.
4. Initial-contact rules compared on every gaitmap variant (median |error| and signed median,
   ms, both feet): the impact's onset (adopted), its half-rise (the previous rule), the end of
   the foot's forward rotation (the zero crossing after the swing), Rampp et al.'s rule as
   gaitmap implements it (the maximum of the sensor's own x acceleration from 80 ms before to
   50 ms after the angular-rate minimum that follows the swing: its foot frame as the file
   gives it), and the same search for the antero-posterior deceleration in the axes found in
   the samples (the minimum of the anterior acceleration: "the foot decelerates rapidly").

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

from mimucap.core import rotation as rot
from mimucap.core import skeleton
from mimucap.core.analysis.gait import GaitAnalysis
from mimucap.core.analysis.gait_events import DEFAULT_EVENT_SETTINGS, detect_swing_events
from mimucap.core.analysis.sagittal import axes_from_data
from mimucap.core.analysis.signals import lowpass, zero_crossing_time
from mimucap.core.simulate.config import SimulationConfig
from mimucap.io.gaitmap import read_foot_imu_csv, read_gaitmap_reference
from mimucap.session.recorded.gait_validation import (
    GAITMAP_RATE_HZ,
    GAITMAP_VARIANTS,
    compare,
    gaitmap_variant_analysis,
    imu_variant,
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


def simulated_rows(n_sensors: int, seed: int) -> tuple[list[tuple[str, dict, str]], dict[str, float]]:
    """Table rows of the simulated suit, and (full suit) where Zeni's events fall."""
    config = SimulationConfig(scenario="demo", duration_s=30.0, n_sensors=n_sensors, errors="bno055", seed=seed)
    with tempfile.TemporaryDirectory() as folder:
        result, analysis = simulated_analysis(config, folder)
    windows = walk_windows(result.markers, float(result.truth.t_s[-1]))
    reference = simulated_reference(result)
    delays = zeni_delays_ms(result, reference) if "foot_r" in result.truth.q_world_from_segment else {}
    return side_rows(analysis.gait, reference, windows), delays


def zeni_delays_ms(result, reference: list) -> dict[str, float]:
    """Median delays (ms) of Zeni et al.'s events on the simulated markers after the true
    contacts: heel strike where the sole's heel point leads the pelvis root most along the walk,
    toe-off where the toe point trails it most (truth at 1 kHz would move these by < 1 ms)."""
    truth = result.truth
    t = np.asarray(truth.t_s, dtype=float)
    model = skeleton.load_model(result.model_name)
    heel_m, toe_m = skeleton.foot_sole_m(result.height_m)
    fk = skeleton.forward_kinematics(model, truth.q_world_from_segment, result.height_m, truth.root_position_m)
    delays: dict[str, list[float]] = {"heel strike": [], "toe-off": []}
    for r in reference:
        letter = r.side[0]
        q_foot = truth.q_world_from_segment[f"foot_{letter}"]
        ankle = fk[f"shank_{letter}"].distal_m
        forward = rot.rotate(truth.q_world_from_segment["pelvis"], np.array([1.0, 0.0, 0.0]))
        forward[:, 2] = 0.0
        forward /= np.linalg.norm(forward, axis=1, keepdims=True)
        for name, point, event, sign in (("heel strike", heel_m, r.ic, 1.0), ("toe-off", toe_m, r.tc, -1.0)):
            near = np.flatnonzero(np.abs(t - event) <= 0.15)
            lead = np.sum((ankle[near] + rot.rotate(q_foot[near], point) - truth.root_position_m[near]) * forward[near],
                          axis=1)
            delays[name].append(t[near][int(np.argmax(sign * lead))] - event)
    return {name: float(np.median(v)) * 1000.0 for name, v in delays.items()}


def ic_rules_ms(folder: Path, variant) -> dict[str, tuple[float, float]]:
    """Median |error| and signed median (ms) of each initial-contact rule (module doc) against the
    straight optical reference strides of the gaitmap walk recorded as ``variant``."""
    feet = read_foot_imu_csv(folder / "imu_sample.csv", GAITMAP_RATE_HZ, "deg/s")
    reference = straight_reference(read_gaitmap_reference(folder))
    settings = DEFAULT_EVENT_SETTINGS
    errors: dict[str, list[float]] = {}
    for side, recorded in feet.items():
        imu = imu_variant(recorded, GAITMAP_RATE_HZ, variant)
        rate_hz = variant.rate_hz or GAITMAP_RATE_HZ
        axes = axes_from_data(imu.acc, imu.gyr, rate_hz)
        t, rate, acc = imu.t_s, axes.rate(imu.gyr), axes.acceleration(imu.acc)
        events = detect_swing_events(t, rate, "foot", settings, acc)
        fast = lowpass(rate, rate_hz, settings.event_lowpass_hz)
        falls = np.flatnonzero((fast[:-1] > 0.0) & (fast[1:] <= 0.0))
        span = max(int(round(settings.impact_span_s * rate_hz)), 1)
        times: dict[str, list[float]] = {"onset (adopted)": list(events.t_ic_s[events.ic_at_impact])}
        for name in ("half-rise (before)", "rotation ends", "Rampp/gaitmap x max",
                     "Rampp found-axes min"):
            times[name] = []
        for fall in falls:
            times["rotation ends"].append(zero_crossing_time(t, fast, int(fall)))
            stop = min(fall + int(round(0.15 * rate_hz)), t.shape[0] - 1)
            minimum = fall + int(np.argmin(fast[fall:stop + 1]))
            a, b = max(minimum - int(0.08 * rate_hz), 0), min(minimum + int(0.05 * rate_hz), t.shape[0])
            times["Rampp/gaitmap x max"].append(float(t[a + int(np.argmax(imu.acc[a:b, 0]))]))
            times["Rampp found-axes min"].append(float(t[a + int(np.argmin(acc[a:b, 0]))]))
            first, last = fall - int(round(settings.heel_strike_window_s[0] * rate_hz)), \
                fall + int(round(settings.heel_strike_window_s[1] * rate_hz))
            window = acc[max(first, 0):last + 1]
            change = np.linalg.norm(window[span:] - window[:-span], axis=1)
            begins = np.flatnonzero(change >= settings.impact_min_m_s2)
            if begins.size:  # the previous rule: the first sample interval past half the rise
                k = max(first, 0) + int(begins[0])
                height = np.linalg.norm(acc[k:k + 2 * span + 1] - acc[k], axis=1)
                j = k + int(np.argmax(height >= 0.5 * height.max()))
                times["half-rise (before)"].append(float(0.5 * (t[j - 1] + t[j])))
        for name, found in times.items():
            found = np.asarray(found, dtype=float)
            for r in reference:
                if r.side == side and found.size:
                    d = found - r.ic
                    k = int(np.argmin(np.abs(d)))
                    if abs(d[k]) <= 0.15:
                        errors.setdefault(name, []).append(float(d[k]))
    return {name: (float(np.median(np.abs(v))) * 1000.0, float(np.median(v)) * 1000.0) for name, v in errors.items()}


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
    folder = args.data.resolve()
    for variant in GAITMAP_VARIANTS:
        gait, reference = gaitmap_variant_analysis(folder, variant)
        print_table(f"gaitmap example, foot IMUs, {variant.name}", side_rows(gait, straight_reference(reference)))
    delays = marker_delays_ms(folder, straight_reference(reference))
    print("\ngaitmap example: from the optical initial contact to "
          + ", ".join(f"the {name}: {value:+.0f} ms" for name, value in delays.items()) + " (medians)")
    rules = {variant.name: ic_rules_ms(folder, variant) for variant in GAITMAP_VARIANTS}
    names = list(next(iter(rules.values())))
    print("\ngaitmap example: initial-contact rules, median |error| / signed median (ms), both feet")
    print("  " + " " * 40 + "".join(f"{name:>24s}" for name in names))
    for variant, figures in rules.items():
        print(f"  {variant:40s}" + "".join(f"{figures[n][0]:>12.1f} /{figures[n][1]:+7.1f}  " for n in names))
    feet, zeni = simulated_rows(17, args.seed)
    print_table("simulated suit, foot sensors (17)", feet)
    print("simulated walk: Zeni et al.'s events after the true contacts: "
          + ", ".join(f"{name} {value:+.0f} ms" for name, value in zeni.items()) + " (medians)")
    print_table("simulated suit, shank sensors (10)", simulated_rows(10, args.seed)[0])


if __name__ == "__main__":
    main()
