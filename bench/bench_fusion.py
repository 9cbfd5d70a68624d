"""Throughput of the orientation filters: MimuCap's batch EKF against VQF, imufusion and ahrs.

Plain script: ``.venv/bin/python bench/bench_fusion.py [--repeat N]``.

All filters run on the same 9D data: the BROAD trials of ``../shared/data/broad``
concatenated (gyro rad/s, accelerometer m/s², magnetometer µT at 285.7 Hz). Fast filters get
the whole set, the per-sample Python filters (imufusion's Python loop, ahrs EKF/Madgwick, our
own kernel run as plain Python) a slice of it, so the run stays short; samples per second are
comparable either way. Each measurement is the best of ``--repeat`` runs after one warm-up
(numba compiles once, cached on disk). Printed: samples/s and the ratio of our 9D batch EKF to
each row (> 1: ours is faster).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from mimucap.core.fusion import kernels
from mimucap.core.fusion.ekf import OrientationEKF, fuse
from mimucap.core.fusion.offline import fuse_offline
from mimucap.io.broad import list_broad_trials, read_broad

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
    args = parser.parse_args()
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

    npy = ns // 10  # the pure-Python kernel is slow: a tenth of the slow slice

    def pure_python_kernel():
        ekf = OrientationEKF()
        out_q, out_b, out_f = np.empty((npy, 4)), np.empty((npy, 3)), np.zeros(npy, np.uint8)
        st = ekf.state
        e4, e3, e66, e33 = np.zeros((0, 4)), np.zeros((0, 3)), np.zeros((0, 6, 6)), np.zeros((0, 3, 3))
        kernels.ekf_block.py_func(ekf._packed, t[:npy], gyr[:npy], acc[:npy], mag[:npy],
                                  st.q_world_from_sensor[0], st.bias_rad_s[0], st.cov[0], st.aux[0],
                                  out_q, out_b, out_f, False, e4, e3, e66, e66, e33)

    add("mimucap EKF kernel without numba (pure Python)", npy, pure_python_kernel)

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


if __name__ == "__main__":
    main()
