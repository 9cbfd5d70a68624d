"""Throughput of the orientation filters: MimuCap's batch EKF against VQF, imufusion and ahrs.

Plain script: ``.venv/bin/python bench/bench_fusion.py [--repeat N] [--no-accuracy]``.

All filters run on the same 9D data: the BROAD trials of ``../shared/data/broad``
concatenated (gyro rad/s, accelerometer m/s², magnetometer µT at 285.7 Hz). Fast filters get
the whole set, the per-sample Python filters (imufusion's Python loop, ahrs EKF/Madgwick, our
own filter run as plain Python with numba switched off) a slice of it, so the run stays short; samples per second are
comparable either way. Each measurement is the best of ``--repeat`` runs after one warm-up
(numba compiles once, cached on disk). Printed: samples/s and the ratio of our 9D batch EKF to
each row (> 1: ours is faster).

A second part reports accuracy against ground truth: heading and tilt RMSE on simulated suits
(:mod:`mimucap.core.simulate`: walking, turning, the demo loop, and the demo loop with a
magnetic disturbance episode), and gyro-only integration of a coning motion against exact
increments (the error order of each method when the step halves).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from mimucap.core import rotation as rot
from mimucap.core.fusion.evaluation import error_angles_rad
from mimucap.core.fusion.propagation import integrate_gyro, integrate_increments
from mimucap.core.fusion.ekf import fuse
from mimucap.core.fusion.offline import fuse_offline
from mimucap.io.broad_trials import list_broad_trials, read_broad

BROAD_DIR = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "broad"
SLOW_SAMPLES = 20_000


def load_data():
    trials = [read_broad(path) for path in list_broad_trials(BROAD_DIR)]
    rate = trials[0].sampling_rate_hz
    gyr = np.ascontiguousarray(np.concatenate([t.gyr_rad_s for t in trials]))
    acc = np.ascontiguousarray(np.concatenate([t.acc_m_s2 for t in trials]))
    mag = np.ascontiguousarray(np.concatenate([t.mag_uT for t in trials]))
    return rate, np.arange(gyr.shape[0]) / rate, gyr, acc, mag


def best_time(func, repeat: int) -> float:
    func()  # warm-up (JIT compile / caches)
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per filter (best kept)")
    parser.add_argument("--no-accuracy", action="store_true", help="skip the accuracy part")
    args = parser.parse_args()
    throughput(args)
    if not args.no_accuracy:
        simulated_accuracy()
        propagation_orders()


def throughput(args: argparse.Namespace) -> None:
    rate, t, gyr, acc, mag = load_data()
    n = gyr.shape[0]
    ns = min(SLOW_SAMPLES, n)
    dt = 1.0 / rate
    rows: list[tuple[str, int, float]] = []

    def add(name: str, samples: int, func) -> None:
        seconds = best_time(func, args.repeat)
        rows.append((name, samples, seconds))
        print(f"  measured {name:46s} {samples / seconds / 1e6:8.3f} M samples/s", flush=True)

    print(f"data: {n} samples of 9D BROAD data at {rate:.1f} Hz")
    add("mimucap EKF 9D batch (taylor3)", n, lambda: fuse(t, gyr, acc, mag))
    add("mimucap EKF 9D batch (rk4)", n, lambda: fuse(t, gyr, acc, mag, algorithm="ekf-rk4"))
    add("mimucap EKF 6D batch (no magnetometer)", n, lambda: fuse(t, gyr, acc, None))
    add("mimucap offline (EKF + RTS smoother)", n, lambda: fuse_offline(t, gyr, acc, mag))
    add("mimucap gyro-only taylor3", n, lambda: fuse(t, gyr, acc, mag, algorithm="taylor3"))
    s17 = 17
    n17 = n // s17
    g17, a17, m17 = (x[: n17 * s17].reshape(s17, n17, 3).copy() for x in (gyr, acc, mag))
    add("mimucap EKF 9D, 17 sensors in one call", n17 * s17, lambda: fuse(t[:n17], g17, a17, m17))

    npy = 2000
    seconds = pure_python_seconds(npy, args.repeat)
    rows.append(("mimucap EKF 9D without numba (NUMBA_DISABLE_JIT)", npy, seconds))
    print(f"  measured {rows[-1][0]:46s} {npy / seconds / 1e6:8.3f} M samples/s", flush=True)

    try:
        import vqf
    except ImportError:
        print("  vqf not installed: pip install vqf")
    else:
        add("vqf VQF.updateBatch (C++)", n, lambda: vqf.VQF(dt).updateBatch(gyr, acc, mag))
        add("vqf offlineVQF (C++)", n, lambda: vqf.offlineVQF(gyr, acc, mag, dt, {}))
    try:
        import imufusion
    except ImportError:
        print("  imufusion not installed: pip install imufusion")
    else:
        gyr_dps, acc_g = np.degrees(gyr[:ns]), acc[:ns] / 9.81

        def run_imufusion():
            ahrs = imufusion.Ahrs()
            ahrs.set_sample_period(dt)
            for k in range(ns):
                ahrs.update(gyr_dps[k], acc_g[k], mag[k])

        add("imufusion Ahrs (C, per-sample Python loop)", ns, run_imufusion)
    try:
        from ahrs.filters import EKF, Madgwick
    except ImportError:
        print("  ahrs not installed: pip install ahrs")
    else:
        na = ns // 4
        add("ahrs EKF (numpy)", na, lambda: EKF(gyr=gyr[:na], acc=acc[:na], mag=mag[:na] / 100.0,
                                                frequency=rate))
        add("ahrs Madgwick (numpy)", na, lambda: Madgwick(gyr=gyr[:na], acc=acc[:na],
                                                          mag=mag[:na] / 100.0, frequency=rate))

    ours = rows[0][1] / rows[0][2]
    print()
    print(f"{'filter':50s} {'samples':>9s} {'time s':>9s} {'M samples/s':>12s} {'ours/this':>10s}")
    for name, samples, seconds in rows:
        speed = samples / seconds
        print(f"{name:50s} {samples:9d} {seconds:9.4f} {speed / 1e6:12.3f} {ours / speed:10.2f}")
    print("\nours/this = throughput of 'mimucap EKF 9D batch (taylor3)' divided by the row's.")
    speeds = {name: samples / seconds for name, samples, seconds in rows}
    pairs = (("mimucap EKF 9D batch (taylor3)", "vqf VQF.updateBatch (C++)"),
             ("mimucap offline (EKF + RTS smoother)", "vqf offlineVQF (C++)"))
    for ours_name, peer in pairs:
        if peer in speeds:
            print(f"{ours_name} / {peer}: {speeds[ours_name] / speeds[peer]:.2f}")


def pure_python_seconds(n: int, repeat: int) -> float:
    """Best time of the same EKF on ``n`` samples run as plain Python (numba switched off in a
    child process): what the compiled kernels earn."""
    code = (
        "import time, numpy as np\n"
        "from mimucap.core.fusion.ekf import fuse\n"
        f"n = {n}\n"
        "rng = np.random.default_rng(0)\n"
        "t = np.arange(n) / 100.0\n"
        "g = rng.normal(0, 0.5, (n, 3)); a = rng.normal(0, 1, (n, 3)) + [0, 0, 9.81]\n"
        "m = rng.normal(0, 1, (n, 3)) + [0, 20, -40]\n"
        "best = 1e9\n"
        f"for _ in range({max(1, repeat)}):\n"
        "    s = time.perf_counter(); fuse(t, g, a, m); best = min(best, time.perf_counter() - s)\n"
        "print(best)\n"
    )
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True)
    return float(out.stdout.strip().splitlines()[-1])


def simulated_accuracy() -> None:
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.core.simulate.suit import simulate_session
    from mimucap.core.simulate.magnetic_field import MagneticDisturbance

    episode = (MagneticDisturbance((30.0, 0.0, -15.0), 25.0, 40.0),)
    cases = [("walk", "walk", ()), ("turn", "turn", ()), ("demo", "demo", ()),
             ("demo + magnetic episode 25-40 s", "demo", episode)]
    print("\nAccuracy on simulated suits (3 sensors, 60 s at 100 Hz, default error model, "
          "magnetometers calibrated with the true hard/soft iron; RMSE after the first 5 s, deg)")
    print(f"{'scenario':34s} {'online head':>12s} {'online tilt':>12s} {'offline head':>13s} "
          f"{'offline tilt':>13s} {'mag rejected':>13s}")
    for label, scenario, disturbances in cases:
        result = simulate_session(SimulationConfig(scenario=scenario, duration_s=60.0, n_sensors=3,
                                                   rate_hz=100.0, seed=3, disturbances=disturbances))
        errors = []
        rejected = 0
        for sensor_id, samples in result.samples.items():
            parameters = result.parameters[sensor_id]
            mag = np.linalg.solve(parameters.mag_A, (samples.mag_uT - parameters.mag_b_uT).T).T
            truth = result.truth.q_world_from_sensor[sensor_id][
                np.searchsorted(result.truth.t_s, samples.t_s)]
            settled = samples.t_s > 5.0
            row = []
            for estimator in (fuse, fuse_offline):
                estimate = estimator(samples.t_s, samples.gyr, samples.acc, mag)
                _, heading, incl = error_angles_rad(estimate.q_world_from_sensor, truth)
                row += [np.sqrt(np.mean(heading[settled] ** 2)), np.sqrt(np.mean(incl[settled] ** 2))]
            rejected += estimate.counters[0]["mag_rejected"]
            errors.append(row)
        mean = np.degrees(np.mean(errors, axis=0))
        print(f"{label:34s} {mean[0]:12.2f} {mean[1]:12.2f} {mean[2]:13.2f} {mean[3]:13.2f} "
              f"{rejected:13d}")


def propagation_orders() -> None:
    omega, beta, duration = 2 * np.pi * 2.0, np.radians(10.0), 2.0

    def q_true(t):
        a = omega * t
        return rot.multiply(rot.multiply(rot.from_axis_angle([0, 0, 1], a),
                                         rot.from_axis_angle([1, 0, 0], np.full_like(a, beta))),
                            rot.from_axis_angle([0, 0, 1], -a))

    def rate(t):
        a = omega * t
        return omega * np.stack([-np.sin(beta) * np.sin(a), np.sin(beta) * np.cos(a),
                                 np.full_like(a, np.cos(beta) - 1.0)], axis=-1)

    nodes, weights = np.polynomial.legendre.leggauss(8)
    print("\nGyro-only integration of a coning motion (2 Hz, half-angle 10°, 2 s): final error "
          "(deg) and order p (error ∝ dt^p)")
    steps = (0.02, 0.01, 0.005)
    results = {"exact (increments, no coning term)": [], "taylor3 (increments, coning term)": [],
               "rk4 (sampled rates)": [], "taylor3 (sampled rates)": []}
    for dt in steps:
        t = np.arange(0.0, duration + dt / 2, dt)
        truth = q_true(t)
        inc = sum(w * rate(t[:-1] + dt * (x + 1) / 2) * dt / 2 for x, w in zip(nodes, weights))
        for key, q in (
            ("exact (increments, no coning term)", integrate_increments(truth[0], inc, "exact")),
            ("taylor3 (increments, coning term)", integrate_increments(truth[0], inc, "taylor3")),
        ):
            results[key].append(np.degrees(rot.angle_between(q[-1], truth[-1])))
        for key, method in (("rk4 (sampled rates)", "rk4"), ("taylor3 (sampled rates)", "taylor3")):
            q = integrate_gyro(truth[0], rate(t), t, method)
            results[key].append(np.degrees(rot.angle_between(q[-1], truth[-1])))
    print(f"{'method':38s}" + "".join(f"{'dt=' + str(dt):>12s}" for dt in steps) + f"{'order':>8s}")
    for key, errs in results.items():
        order = np.log2(errs[-2] / errs[-1])
        print(f"{key:38s}" + "".join(f"{e:12.2e}" for e in errs) + f"{order:8.2f}")


if __name__ == "__main__":
    main()
