"""Benchmark: fitting 10 000 magnetometer samples.

Compares MimuCap's fit (``fit_ellipsoid``: thinning, Li & Griffiths ellipsoid-specific fit or
the general quadric, iterated outlier rejection) and the whole ``calibrate`` call (fit plus
quality figures) with a plain numpy ``lstsq`` quadric fit (no normalisation, no robustness:
the peer). Prints the median wall time of repeated runs (ms), the ratio to the peer, and the
centre error of each against the truth.

Run: ``.venv/bin/python bench/bench_magcal.py [--samples 10000] [--repeats 20]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mimucap.core.magcal.calibrate import calibrate
from mimucap.core.magcal.fit import FitSettings, fit_ellipsoid


def lstsq_quadric_centre(mag: np.ndarray) -> np.ndarray:
    """The peer: ``a1x²+…+2a9z = 1`` by ``np.linalg.lstsq``; centre ``−M⁻¹u``."""
    x, y, z = mag.T
    d = np.column_stack((x * x, y * y, z * z, 2 * y * z, 2 * x * z, 2 * x * y, 2 * x, 2 * y, 2 * z))
    v, *_ = np.linalg.lstsq(d, np.ones(len(mag)), rcond=None)
    a, b, c, f, g, h, p, q, r = v
    m = np.array([[a, h, g], [h, b, f], [g, f, c]])
    return -np.linalg.solve(m, np.array([p, q, r]))


def median_ms(function, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return 1000.0 * float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=10_000)
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    u = rng.normal(size=(args.samples, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    a = np.array([[1.1, 0.05, -0.02], [0.05, 0.95, 0.03], [-0.02, 0.03, 1.0]])
    b = np.array([35.0, -20.0, 12.0])
    mag = 49.3 * u @ a.T + b + rng.normal(scale=0.6, size=u.shape)
    mag[rng.choice(args.samples, 50, replace=False)] += 30.0  # a few spikes

    cases = [
        ("numpy lstsq quadric (peer)", lambda: lstsq_quadric_centre(mag)),
        ("fit_ellipsoid quadric", lambda: fit_ellipsoid(mag, FitSettings(method="quadric")).offset_uT),
        ("fit_ellipsoid ellipsoid (default)", lambda: fit_ellipsoid(mag).offset_uT),
        ("calibrate (fit + quality)", lambda: calibrate(mag, "bench").fit.offset_uT),
    ]
    peer_ms = None
    print(f"Fitting {args.samples} samples (0.6 µT noise, 50 spikes), median of {args.repeats} runs")
    print(f"{'method':<36} {'time_ms':>9} {'ratio':>7} {'centre_err_uT':>14}")
    for name, function in cases:
        elapsed = median_ms(function, args.repeats)
        peer_ms = peer_ms or elapsed
        error = float(np.linalg.norm(function() - b))
        print(f"{name:<36} {elapsed:>9.2f} {elapsed / peer_ms:>7.2f} {error:>14.4f}")


if __name__ == "__main__":
    main()
