"""The fusion kernels are compiled in a child process and loaded here from numba's cache."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from mimucap.core.fusion import kernel_selection
from mimucap.session.live.kernel_preparation import KernelPreparation

#: Run in a fresh interpreter with an empty numba cache: prepare, then count the kernel
#: signatures it made ready in *this* process and those of them not loaded from the cache
#: (compiled here); then prepare again, as a later start would.
COLD_START = """
import importlib, json, pkgutil
from numba.core.registry import CPUDispatcher
import mimucap.core.fusion as fusion
from mimucap.session.live.kernel_preparation import prepare_fusion_kernels

kernels = [value for info in pkgutil.iter_modules(fusion.__path__, "mimucap.core.fusion.")
           for value in vars(importlib.import_module(info.name)).values() if isinstance(value, CPUDispatcher)]
before = {id(kernel): set(kernel.overloads) for kernel in kernels}  # the import's layout guards
report = prepare_fusion_kernels()
new = [(kernel, sig) for kernel in kernels for sig in set(kernel.overloads) - before[id(kernel)]]
again = prepare_fusion_kernels()
print(json.dumps({"cached": report.cached, "child_exit_code": report.child_exit_code,
                  "compiled_in_child": report.compiled_in_child, "signatures": len(new),
                  "compiled_here": sum(kernel.stats.cache_hits[sig] == 0 for kernel, sig in new),
                  "again_cached": again.cached, "again_child": again.child_exit_code}))
"""


@pytest.fixture(autouse=True)
def jit_kernels():
    """These tests are about numba's JIT kernels, whether or not a compiled module exists (with
    one, the preparation has nothing to do: tests/core/fusion/test_aot.py)."""
    with kernel_selection.kernels_in_use(kernel_selection.jit_kernels()):
        yield


def test_a_cold_start_compiles_in_a_child_and_this_process_only_loads_from_the_cache(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache"), kernel_selection.KERNELS_ENV: "jit"}
    done = subprocess.run([sys.executable, "-c", COLD_START], env=env, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert not result["cached"] and result["child_exit_code"] == 0 and result["compiled_in_child"]
    assert result["compiled_here"] == 0  # nothing was compiled in the calling process
    assert result["signatures"] >= 2     # the online filter's kernel and the offline smoother's
    assert any((tmp_path / "numba-cache").rglob("*.nbc"))  # the child left its code on disk
    assert result["again_cached"] and result["again_child"] is None  # a later start spawns nothing


def test_a_child_that_does_not_finish_in_time_is_stopped_and_the_kernels_are_compiled_here(monkeypatch):
    from mimucap.session.live import kernel_preparation as module

    monkeypatch.setattr(module, "load_cached_kernels", lambda: False)  # as if the cache were empty
    preparation = KernelPreparation(timeout_s=1e-3)
    report = preparation.run()   # compiled here: instant, this process has the kernels already
    assert report is not None and not report.cached
    assert report.child_exit_code is None and not report.compiled_in_child
    assert preparation._process is not None and not preparation._process.is_alive()


def test_cancelling_while_the_child_starts_stops_it_and_compiles_nothing_here(monkeypatch):
    import threading
    import time

    from mimucap.session.live import kernel_preparation as module

    monkeypatch.setattr(module, "load_cached_kernels", lambda: False)  # as if the cache were empty
    preparation = KernelPreparation()
    outcome = []
    worker = threading.Thread(target=lambda: outcome.append(preparation.run()))
    worker.start()
    deadline = time.monotonic() + 10.0
    while preparation._process is None and time.monotonic() < deadline:
        time.sleep(0.001)
    preparation.cancel()   # the child is still starting (spawn re-imports the package)
    worker.join(10.0)
    assert not worker.is_alive() and outcome == [None]
    assert preparation._process.exitcode is not None and preparation._process.exitcode < 0  # terminated


def test_with_every_kernel_in_the_cache_no_child_is_started():
    from mimucap.core.fusion.warmup import compile_kernels

    compile_kernels()   # this process has them now (from the cache, or compiled into it)
    preparation = KernelPreparation()
    report = preparation.run()
    assert report is not None and report.cached and preparation._process is None


def test_a_cancelled_preparation_starts_no_child_and_loads_nothing():
    preparation = KernelPreparation()
    preparation.cancel()
    assert preparation.run() is None


def test_a_timeout_must_be_positive():
    with pytest.raises(ValueError, match="timeout_s must be > 0"):
        KernelPreparation(timeout_s=0.0)


def test_only_the_preparing_thread_is_refused_compilation(monkeypatch):
    """While the preparation checks the cache, another thread (the Review workspace loading a
    recording, say) may still compile: the refusal is for the preparing thread alone."""
    import threading

    from numba import njit

    from mimucap.session.live import kernel_preparation as module

    compiled_elsewhere = []

    def warm_up_while_another_thread_compiles():
        @njit(cache=False)
        def twice(x):
            return 2.0 * x

        other = threading.Thread(target=lambda: compiled_elsewhere.append(twice(1.5)))
        other.start()
        other.join()

        @njit(cache=False)
        def thrice(x):   # compiled by the preparing thread itself: refused
            return 3.0 * x

        thrice(1.0)

    monkeypatch.setattr(module, "compile_kernels", warm_up_while_another_thread_compiles)
    assert module.load_cached_kernels() is False
    assert compiled_elsewhere == [3.0]
