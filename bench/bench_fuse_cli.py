"""``mimucap fuse`` of a long recording, as a whole process, against a Python script running VQF.

Run: ``.venv/bin/python bench/bench_fuse_cli.py [--samples 2000000] [--repeats 3]`` (needs
``vqf``: ``.venv/bin/pip install vqf``, or ``make bench``, which installs the ``bench`` extra).

The file: a BROAD-like HDF5 trial (``imu_gyr``, ``imu_acc``, ``imu_mag``, attribute
``sampling_rate``) of ``--samples`` samples of one sensor, made by joining the inertial
channels of the BROAD trials in ``../shared/data/broad`` (Laidig, Caruso, Cereatti, Seel,
"BROAD — A Benchmark for Robust Inertial Orientation Estimation", 2021) end to end, repeated
until long enough; at 286 Hz two million samples are almost two hours.

Timed, each in a fresh interpreter, from process start to exit (the best of ``--repeats``):

* ``mimucap fuse FILE --out Q.npy``: reading, the 9D EKF and writing the (N, 4) orientations.
  The kernels are those the process finds, printed in the header: after ``make install`` the
  module compiled ahead of time (:mod:`mimucap.core.fusion.aot`; no numba in the process),
  else numba's JIT kernels from its on-disk cache;
* a script doing what a VQF user writes: ``import vqf, h5py, numpy``, read the three channels,
  ``vqf.VQF(Ts).updateBatch(gyr, acc, mag)`` and ``numpy.save`` of ``quat9D`` (D. Laidig,
  T. Seel, "VQF: Highly Accurate IMU Orientation Estimation with Bias Estimation and Magnetic
  Disturbance Rejection", Information Fusion 91, 2023).

Both run as after an installation's first use: one untimed run of each comes first, and
Python may cache bytecode (``PYTHONDONTWRITEBYTECODE`` is removed from the children's
environment; without its cache every run would compile MimuCap's modules anew, which no
installed program does).

Printed: both times, wall and CPU (user + system; the steadier figure on a shared machine),
and the ratios VQF / mimucap (above 1: mimucap is faster). Both results
are (N, 4) ``q_world_from_sensor``; their mean angle apart is printed as a sanity check, not a
score (the filters differ, and VQF's world frame is ENU too).
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

BROAD_DIR = Path(__file__).resolve().parents[2] / "shared" / "data" / "broad"

VQF_SCRIPT = r"""
import sys
import h5py
import numpy as np
import vqf

with h5py.File(sys.argv[1], "r") as handle:
    gyr = np.ascontiguousarray(handle["imu_gyr"][()], dtype=np.float64)
    acc = np.ascontiguousarray(handle["imu_acc"][()], dtype=np.float64)
    mag = np.ascontiguousarray(handle["imu_mag"][()], dtype=np.float64)
    rate = float(np.asarray(handle.attrs["sampling_rate"]).reshape(-1)[0])
quat = vqf.VQF(1.0 / rate).updateBatch(gyr, acc, mag)["quat9D"]
np.save(sys.argv[2], quat)
"""

#: Prints which fusion kernels a mimucap process runs.
KERNELS_PROBE = """
from mimucap.core.fusion.kernel_selection import fusion_kernels
kernels = fusion_kernels()
print(f"compiled ahead of time ({kernels.origin})" if kernels.ahead_of_time else kernels.origin)
"""


def make_trial(path: Path, samples: int, broad_dir: Path) -> float:
    """Write the joined trial; returns its sampling rate (Hz)."""
    trials = sorted(broad_dir.glob("*.hdf5"))
    if not trials:
        raise SystemExit(f"no BROAD trials in {broad_dir}")
    parts: dict[str, list[np.ndarray]] = {"imu_gyr": [], "imu_acc": [], "imu_mag": []}
    rate = None
    total = 0
    while total < samples:
        for trial in trials:
            with h5py.File(trial, "r") as handle:
                trial_rate = float(np.asarray(handle.attrs["sampling_rate"]).reshape(-1)[0])
                channels = {name: handle[name][()] for name in parts}
            rate = trial_rate if rate is None else rate
            if trial_rate != rate:
                continue
            for name, values in channels.items():
                parts[name].append(values)
            total += len(channels["imu_gyr"])
            if total >= samples:
                break
    with h5py.File(path, "w") as handle:
        for name, values in parts.items():
            handle.create_dataset(name, data=np.concatenate(values)[:samples])
        handle.attrs["sampling_rate"] = rate
    return rate


def _children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def best_times(command: list[str], repeats: int, env: dict[str, str] | None = None) -> tuple[float, float]:
    """Shortest wall time and shortest CPU time (user + system), s, of ``repeats`` runs of
    ``command``, each a fresh process. On a shared machine the CPU time is the steadier figure."""
    walls, cpus = [], []
    for _ in range(repeats):
        cpu = _children_cpu_s()
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, env=env)
        walls.append(time.perf_counter() - start)
        cpus.append(_children_cpu_s() - cpu)
        if done.returncode != 0:
            raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr}")
    return min(walls), min(cpus)


def mean_angle_deg(q_a: np.ndarray, q_b: np.ndarray) -> float:
    dot = np.abs(np.sum(q_a * q_b, axis=1))
    valid = np.isfinite(dot)
    return float(np.degrees(2.0 * np.arccos(np.clip(dot[valid], 0.0, 1.0))).mean())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=2_000_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--broad", type=Path, default=BROAD_DIR, help="folder of BROAD trials")
    args = parser.parse_args()
    try:
        import vqf  # noqa: F401
    except ImportError:
        raise SystemExit("vqf is not installed: .venv/bin/pip install vqf") from None
    with tempfile.TemporaryDirectory(prefix="mimucap-fuse-bench-") as folder:
        trial = Path(folder) / "long_trial.hdf5"
        rate = make_trial(trial, args.samples, args.broad)
        ours_out, vqf_out = Path(folder) / "mimucap.npy", Path(folder) / "vqf.npy"
        env = {key: value for key, value in os.environ.items() if key != "PYTHONDONTWRITEBYTECODE"}
        kernels = subprocess.run([sys.executable, "-c", KERNELS_PROBE], capture_output=True, text=True,
                                 check=True, env=env).stdout.strip()
        ours = [sys.executable, "-m", "mimucap", "fuse", str(trial), "--out", str(ours_out)]
        theirs = [sys.executable, "-c", VQF_SCRIPT, str(trial), str(vqf_out)]
        for command in (ours, theirs):  # untimed: caches filled as after an installation's first use
            subprocess.run(command, capture_output=True, check=True, env=env)
        ours_s = best_times(ours, args.repeats, env)
        theirs_s = best_times(theirs, args.repeats, env)
        apart = mean_angle_deg(np.load(ours_out), np.load(vqf_out))
    print(f"Whole-process fusion of {args.samples:,} samples ({args.samples / rate / 3600:.2f} h at {rate:g} Hz, "
          f"9D), best of {args.repeats}; mimucap's kernels: {kernels}; load average {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} cores")
    print(f"{'':44s} {'wall':>8s} {'CPU':>8s}")
    print(f"{'mimucap fuse FILE --out Q.npy':44s} {ours_s[0]:7.2f}s {ours_s[1]:7.2f}s")
    print(f"{'python script: vqf.VQF(Ts).updateBatch':44s} {theirs_s[0]:7.2f}s {theirs_s[1]:7.2f}s")
    print(f"ratio VQF / mimucap: wall {theirs_s[0] / ours_s[0]:.2f}, CPU {theirs_s[1] / ours_s[1]:.2f} "
          f"(above 1: mimucap is faster); mean angle between the two results {apart:.1f}°")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
