"""The compiled kernels match the current settings/state layout (stale-cache guard)."""

from __future__ import annotations

from numba import njit

from mimucap.core.fusion import disturbance, kernels
from mimucap.core.fusion.jit import LAYOUT_FINGERPRINT, refresh_if_stale


def test_loaded_kernels_use_the_current_layout():
    assert kernels._compiled_layout() == LAYOUT_FINGERPRINT
    assert disturbance._compiled_layout() == LAYOUT_FINGERPRINT


def test_stale_fingerprint_empties_the_module_caches(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    flushed = []

    class Cache:
        def flush(self):
            flushed.append(True)

    @njit
    def kernel(x):
        return x + 1

    kernel._cache = Cache()
    namespace = {"__name__": kernel.py_func.__module__, "kernel": kernel}
    assert refresh_if_stale(namespace, LAYOUT_FINGERPRINT) is False
    assert flushed == []
    assert refresh_if_stale(namespace, LAYOUT_FINGERPRINT + 1) is True
    assert flushed == [True]
