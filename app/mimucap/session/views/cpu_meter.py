"""Process diagnostics for the status bar: CPU use of this process (percent of one core)."""

from __future__ import annotations

import time


class CpuMeter:
    """CPU time used by this process between two :meth:`sample` calls, as % of one core."""

    def __init__(self) -> None:
        self._wall = time.perf_counter()
        self._cpu = time.process_time()

    def sample(self) -> float:
        wall, cpu = time.perf_counter(), time.process_time()
        elapsed = wall - self._wall
        percent = 100.0 * (cpu - self._cpu) / elapsed if elapsed > 0 else 0.0
        self._wall, self._cpu = wall, cpu
        return percent
