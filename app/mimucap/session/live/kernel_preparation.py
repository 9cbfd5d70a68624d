"""Prepare the fusion kernels for this process without holding up its other threads.

After ``make install`` the kernels are compiled ahead of time (:mod:`mimucap.core.fusion.kernel_selection`):
then :meth:`KernelPreparation.run` loads that module and returns at once, numba is not even
imported, and the first start has nothing to compile. The rest concerns numba's JIT kernels,
the fallback when that module is missing or stale.

numba compiles a kernel on its first call, which takes seconds. In a thread of the GUI process
that work holds Python's global interpreter lock in long stretches and freezes the window
(``bench/bench_cold_start.py`` shows it). So :func:`prepare_fusion_kernels` compiles them in a
child process (started with ``spawn``, like the acquisition workers), which leaves the compiled
code in numba's on-disk cache (``cache=True``; the same cache directory for both processes,
since it is chosen from the kernels' source files and the environment); this process then
loads them from that cache. When the cache holds them already (every start but the first), no
child is started: :func:`load_cached_kernels` makes the warm-up's calls while refusing any
compilation in its thread, which tells at once whether one is due.

If the child fails, or ends without leaving a usable cache (a read-only install without a
writable user cache, for example), the kernels are compiled in the calling thread: slower for
the GUI, never wrong. :class:`KernelPreparation` reports which way was taken.
"""

from __future__ import annotations

import logging
import multiprocessing
import threading
import time
from dataclasses import dataclass

from mimucap.core.fusion.kernel_selection import fusion_kernels
from mimucap.core.fusion.warmup import compile_kernels

log = logging.getLogger(__name__)

#: Longest wait (s) for the compiling child before this process compiles the kernels itself.
CHILD_TIMEOUT_S = 300.0
#: How often (s) the wait for the child looks whether the preparation was cancelled.
CANCEL_POLL_S = 0.1


@dataclass(frozen=True)
class PreparationReport:
    """How the kernels were made ready: ``ahead_of_time`` they came compiled at installation (no
    child, no numba); ``cached`` they were all in numba's cache already (no child was started); else ``child_exit_code`` of the compiling child (``None`` if it was
    stopped), ``child_s`` its wall time (s); ``load_s`` the wall time (s) of the first calls
    in this process (milliseconds when they came from the cache)."""

    child_exit_code: int | None
    child_s: float
    load_s: float
    cached: bool = False
    ahead_of_time: bool = False

    @property
    def compiled_in_child(self) -> bool:
        return self.child_exit_code == 0


class KernelPreparation:
    """Compiles the fusion kernels in a child process, then loads them here.

    :meth:`run` blocks (call it off the GUI thread); :meth:`cancel`, from any thread, stops
    the child (a window closing during a first start need not wait for the compiler) and
    makes :meth:`run` return without compiling here.
    """

    def __init__(self, timeout_s: float = CHILD_TIMEOUT_S) -> None:
        if not timeout_s > 0:
            raise ValueError(f"KernelPreparation: timeout_s must be > 0 s, got {timeout_s}")
        self.timeout_s = float(timeout_s)
        self._process = None
        self._cancel = threading.Event()

    def run(self) -> PreparationReport | None:
        """Load the kernels from the cache if it holds them all; otherwise compile them in a
        child, then load them here. ``None`` if cancelled before loading."""
        if self._cancel.is_set():
            return None
        loading = time.monotonic()
        if fusion_kernels().ahead_of_time:
            return PreparationReport(None, 0.0, time.monotonic() - loading, cached=True, ahead_of_time=True)
        if load_cached_kernels():
            return PreparationReport(None, 0.0, time.monotonic() - loading, cached=True)
        started = time.monotonic()
        exit_code = self._compile_in_child()
        child_s = time.monotonic() - started
        if self._cancel.is_set():
            return None
        if exit_code != 0:
            log.warning("compiling the fusion kernels in a child process failed (exit code %s); "
                        "compiling them in this process", exit_code)
        loading = time.monotonic()
        compile_kernels()
        return PreparationReport(exit_code, child_s, time.monotonic() - loading)

    def cancel(self) -> None:
        """Stop the preparation: the child is terminated (now, or as soon as :meth:`run` has
        started it) and nothing is compiled here."""
        self._cancel.set()

    def _compile_in_child(self) -> int | None:
        """The child's exit code, or ``None`` if it was stopped (cancelled, timed out) or could
        not start."""
        if self._cancel.is_set():
            return None
        context = multiprocessing.get_context("spawn")
        process = context.Process(target=compile_kernels, name="mimucap-compile-kernels", daemon=True)
        self._process = process
        try:
            process.start()
        except OSError as error:
            log.warning("could not start a process to compile the fusion kernels: %s", error)
            return None
        deadline = time.monotonic() + self.timeout_s
        # Waiting on the cancel event too: a cancel() at any moment, even while the child was
        # starting, stops it within CANCEL_POLL_S.
        while process.is_alive() and time.monotonic() < deadline and not self._cancel.is_set():
            process.join(min(CANCEL_POLL_S, max(deadline - time.monotonic(), 0.0)))
        if process.is_alive():
            process.terminate()
            process.join(5.0)
            return None
        return process.exitcode


class _CompilationRefused(Exception):
    """A kernel was about to be compiled where only loading it from the cache was allowed."""


def _refusing_listener(thread_id: int):
    """A numba event listener that stops, at its start, any compilation made by the thread
    ``thread_id`` (numba's listeners hear every thread: another thread's compilations go on).
    Built on demand: numba is imported only when its JIT kernels are used."""
    from numba.core import event

    class RefuseCompilation(event.Listener):
        def on_start(self, compilation: event.Event) -> None:
            if threading.get_ident() == thread_id:
                raise _CompilationRefused(str(compilation.data.get("dispatcher")))

        def on_end(self, compilation: event.Event) -> None:
            pass

    return event, RefuseCompilation()


def load_cached_kernels() -> bool:
    """Make :func:`~mimucap.core.fusion.warmup.compile_kernels`'s calls in this thread if
    numba's on-disk cache holds every kernel they need: ``True`` when all were loaded from it,
    ``False`` (at the first kernel missing from the cache, without compiling it) otherwise.
    Milliseconds either way."""
    event, listener = _refusing_listener(threading.get_ident())
    try:
        with event.install_listener("numba:compile", listener):
            compile_kernels()
    except _CompilationRefused:
        return False
    return True


def prepare_fusion_kernels(timeout_s: float = CHILD_TIMEOUT_S) -> PreparationReport | None:
    """:meth:`KernelPreparation.run` of a new preparation (see the module doc)."""
    return KernelPreparation(timeout_s).run()
