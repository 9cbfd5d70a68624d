"""Compile the fusion kernels before they are needed.

numba compiles each kernel on its first call, which takes seconds, unless the compiled code is
already cached on disk (``cache=True``, under ``__pycache__`` or numba's user cache directory).
The first call of a fresh install would therefore stall whatever thread makes it. :func:`compile_kernels` makes those first calls on
a few samples of a resting sensor, so an application can run it off its GUI thread at start.

``python -m mimucap.core.fusion.warmup`` does it once, at installation (``make install``):
numba writes the compiled code to its cache directory (``__pycache__`` beside the kernels'
sources when writable, else the user's cache; ``NUMBA_CACHE_DIR`` overrides both), the same
one the application reads later, so its first start loads the compiled kernels instead of
compiling them.
"""

from __future__ import annotations

import time

import numpy as np

from mimucap.core.fusion.ekf import OrientationEKF
from mimucap.core.fusion.offline import fuse_offline

#: Samples fed to each entry point (a resting sensor at 100 Hz, field 50 µT, 60° dip).
WARM_UP_SAMPLES = 8


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


if __name__ == "__main__":
    started = time.perf_counter()
    compile_kernels()
    print(f"fusion kernels compiled into numba's cache in {time.perf_counter() - started:.1f} s")
