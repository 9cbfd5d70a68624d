"""Compile the fusion kernels before they are needed.

numba compiles each kernel on its first call, which takes seconds, unless the compiled code is
already cached on disk (``cache=True``, under ``__pycache__`` or numba's user cache directory).
The first call of a fresh install would therefore stall whatever thread makes it.
:func:`compile_kernels` makes those first calls on a few samples of a resting sensor, so an
application can run it off its GUI thread at start.

``python -m mimucap.core.fusion.warmup`` runs once, at installation (``make install``):

1. it compiles the kernels ahead of time into an extension module (:mod:`.aot_build`, target
   ``host`` where the CPU can be identified, else ``generic``), which every later process loads
   without importing numba (:mod:`.aot`), unless a current one exists already;
2. it calls the JIT kernels once, so that numba writes them to its cache directory
   (``__pycache__`` beside the kernels' sources when writable, else the user's cache;
   ``NUMBA_CACHE_DIR`` overrides both): they serve whenever the compiled module is missing or
   stale, and then load in milliseconds instead of compiling;
3. it checks that both give the same orientations (within :data:`AGREEMENT`) on a recording
   of a turning sensor, and removes the compiled module if they do not.

If the module cannot be built (no C compiler, a read-only installation), step 1 says so and the
JIT kernels serve: slower to start, same results.
"""

from __future__ import annotations

import time

import numpy as np

from mimucap.core.fusion import aot, kernel_selection
from mimucap.core.fusion.ekf import OrientationEKF, fuse
from mimucap.core.fusion.offline import fuse_offline

#: Samples fed to each entry point (a resting sensor at 100 Hz, field 50 µT, 60° dip).
WARM_UP_SAMPLES = 8
#: Largest difference (quaternion components) allowed between the compiled module and the
#: JIT kernels; with the ``host`` target they agree bitwise.
AGREEMENT = 1e-12


def compile_kernels() -> None:
    """Call every fusion entry point the application uses once, on a resting sensor: the
    online filter with and without the magnetometer, and the offline smoother."""
    t = np.arange(WARM_UP_SAMPLES) / 100.0
    gyr = np.zeros((WARM_UP_SAMPLES, 3))
    acc = np.tile([0.0, 0.0, 9.81], (WARM_UP_SAMPLES, 1))
    mag = np.tile([0.0, 25.0, -43.3], (WARM_UP_SAMPLES, 1))
    for use_mag in (True, False):
        OrientationEKF(use_mag=use_mag).update_batch(t, gyr, acc, mag if use_mag else None)
    fuse_offline(t, gyr, acc, mag)


def turning_sensor(n: int = 3000, rate_hz: float = 100.0, seed: int = 0):
    """``(t_s, gyr, acc, mag)`` of a sensor turning about changing axes, with noise and a
    stretch at rest: enough to take every branch of the filter that matters to a comparison."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate_hz
    gyr = np.column_stack([np.sin(0.7 * t), np.cos(0.5 * t), 0.5 * np.sin(0.3 * t)]) * 1.5
    gyr[n // 3:n // 2] = 0.0
    gyr += rng.normal(0.0, 0.01, (n, 3))
    acc = np.tile([0.0, 0.0, 9.81], (n, 1)) + rng.normal(0.0, 0.3, (n, 3))
    mag = np.tile([0.0, 25.0, -43.3], (n, 1)) + rng.normal(0.0, 1.0, (n, 3))
    return t, gyr, acc, mag


def largest_difference(first: aot.FusionKernels, second: aot.FusionKernels) -> float:
    """Largest difference of the online and smoothed orientations of :func:`turning_sensor`
    computed with ``first`` and with ``second`` (``inf`` when their flags differ)."""
    data = turning_sensor()
    results = []
    for kernels in (first, second):
        with kernel_selection.kernels_in_use(kernels):
            results.append((fuse(*data), fuse_offline(*data)))
    worst = 0.0
    for one, other in zip(*results):
        if not np.array_equal(one.flags, other.flags):
            return float("inf")
        worst = max(worst, float(np.max(np.abs(one.q_world_from_sensor - other.q_world_from_sensor))))
    return worst


def install() -> None:
    """Build the compiled module, fill numba's cache, compare the two (see the module doc)."""
    started = time.perf_counter()
    target = "host" if aot.cpu_signature() is not None else "generic"
    path = None
    current = aot.load_ahead_of_time()
    if current is not None:
        print(f"fusion kernels compiled ahead of time: {current.origin} is up to date")
    else:
        try:
            from mimucap.core.fusion.aot_build import build

            path = build(target)
            print(f"fusion kernels compiled ahead of time ({target}) into {path} in "
                  f"{time.perf_counter() - started:.1f} s")
        except (ImportError, OSError, ValueError) as error:
            print(f"fusion kernels not compiled ahead of time ({error}); numba's JIT kernels will serve")
    started = time.perf_counter()
    jit = kernel_selection.jit_kernels()
    with kernel_selection.kernels_in_use(jit):
        compile_kernels()
    print(f"fusion kernels compiled into numba's cache in {time.perf_counter() - started:.1f} s")
    if path is None:
        return
    compiled = aot.load_ahead_of_time(path.parent)
    difference = float("inf") if compiled is None else largest_difference(compiled, jit)
    if difference > AGREEMENT:
        path.unlink(missing_ok=True)
        print(f"the compiled module {path.name} disagrees with the JIT kernels (by {difference:.3g}) "
              "and was removed; numba's JIT kernels will serve")
    else:
        print(f"compiled module and JIT kernels agree (largest difference {difference:.3g})")


if __name__ == "__main__":
    install()
