"""Compiling the kernels ahead leaves nothing to compile at the first real call."""

from __future__ import annotations

import numpy as np
import pytest
from numba.core.registry import CPUDispatcher

from mimucap.core.fusion import OrientationEKF, fuse_offline, kernel_selection, disturbance, kernels, offline, propagation, state
from mimucap.core.fusion.warmup import compile_kernels


def _compiled_signatures() -> dict[str, int]:
    """Every numba kernel of the fusion package → how many signatures it has compiled."""
    found = {}
    for module in (kernels, offline, propagation, disturbance, state):
        for name, value in vars(module).items():
            if isinstance(value, CPUDispatcher):
                found[f"{module.__name__}.{name}"] = len(value.signatures)
    return found


@pytest.fixture(autouse=True)
def jit_kernels():
    """These tests are about numba's JIT kernels, whether or not a compiled module exists."""
    with kernel_selection.kernels_in_use(kernel_selection.jit_kernels()):
        yield


def test_after_the_warm_up_real_calls_compile_nothing_more():
    compile_kernels()
    before = _compiled_signatures()
    assert before and any(before.values())
    rng = np.random.default_rng(0)
    n = 300
    t = np.arange(n) / 100.0
    gyr = rng.normal(0.0, 0.3, (n, 3))
    acc = np.tile([0.0, 0.0, 9.81], (n, 1)) + rng.normal(0.0, 0.1, (n, 3))
    mag = np.tile([0.0, 25.0, -43.3], (n, 1)) + rng.normal(0.0, 0.5, (n, 3))
    for use_mag in (True, False):   # as the live pipeline uses the filter, block after block
        ekf = OrientationEKF(use_mag=use_mag)
        for start in range(0, n, 7):
            result = ekf.update_batch(t[start:start + 7], gyr[start:start + 7], acc[start:start + 7],
                                      mag[start:start + 7] if use_mag else None)
            assert np.all(np.isfinite(result.q_world_from_sensor))
    assert np.all(np.isfinite(fuse_offline(t, gyr, acc, mag).q_world_from_sensor))
    assert _compiled_signatures() == before
