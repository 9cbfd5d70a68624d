"""GUI benchmark (issue 6, Performance): the main window live on a simulated suit.

Run under a display: ``xvfb-run -a -s "-screen 0 1920x1200x24" .venv/bin/python bench/bench_gui.py``
(``make bench`` does). Loads: 10 sensors (ten segments) and 17 sensors (fifteen segments), both
at 100 Hz, 4 live plots. Measured over ``MEASURE_S`` seconds after a warm-up:

* 3D view frame rate (``Render()`` calls per second; target 60),
* plot refresh rate (target >= 30 Hz),
* CPU use of the GUI process (process CPU time / wall time; target < 50 % of one core;
  under Xvfb the software OpenGL renderer runs inside this process and is counted),
* latency from a sample's arrival (its host time) to the end of the ``Render()`` that shows
  the pose it belongs to (p50/p95; target p95 < 30 ms),

and each figure's ratio to its target (> 1 is better than the target).
"""

from __future__ import annotations

import sys
import time

import numpy as np
from PyQt5 import QtCore, QtWidgets

from mimucap.gui.main_window import MainWindow
from mimucap.session.live import open_live_session

WARMUP_S = 2.0
MEASURE_S = 8.0


def _run_event_loop(seconds: float) -> None:
    """Run Qt's event loop for ``seconds``, idle-waiting as the application does (a loop of
    ``processEvents`` calls would spin and count its own polling as GUI CPU use)."""
    loop = QtCore.QEventLoop()
    QtCore.QTimer.singleShot(int(round(1000 * seconds)), loop.quit)
    loop.exec_()


def run(n_sensors: int, app: QtWidgets.QApplication) -> dict[str, float]:
    window = MainWindow("simulated:walk", session_factory=lambda spec: open_live_session(spec, n_sensors=n_sensors))
    window.set_camera_preset("follow")
    window.show()
    window.start()
    latencies: list[float] = []
    state = {"measuring": False}

    def on_render(now_perf: float) -> None:
        live = window.live
        if state["measuring"] and live is not None and live.time_s == live.time_s:
            latencies.append(time.monotonic() - (live.t0_host_s + live.time_s))

    window.scene_view.frame_rendered.connect(on_render)
    _run_event_loop(WARMUP_S)
    frames0, plots0 = window.scene_view.frames_rendered, window.plots.refresh_count
    wall0, cpu0 = time.perf_counter(), time.process_time()
    state["measuring"] = True
    _run_event_loop(MEASURE_S)
    wall = time.perf_counter() - wall0
    cpu = time.process_time() - cpu0
    result = {
        "fps": (window.scene_view.frames_rendered - frames0) / wall,
        "plot_hz": (window.plots.refresh_count - plots0) / wall,
        "cpu_pct": 100.0 * cpu / wall,
        "lat_p50_ms": 1000.0 * float(np.percentile(latencies, 50)) if latencies else float("nan"),
        "lat_p95_ms": 1000.0 * float(np.percentile(latencies, 95)) if latencies else float("nan"),
        "samples_per_s": window.live.samples_received / (time.monotonic() - window.live.t0_host_s),
        "segments": len(window.live.model.segment_names),
    }
    window.close()
    return result


def main() -> int:
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(["bench_gui"])
    print(f"GUI benchmark: main window 1280x800, 4 live plots, simulated suit at 100 Hz, {MEASURE_S:.0f} s per load")
    print(f"{'load':<26}{'fps':>7}{'/60':>6}{'plot Hz':>9}{'/30':>6}{'CPU %':>8}{'50/CPU':>8}"
          f"{'lat p50':>9}{'lat p95':>9}{'30/p95':>8}")
    for n in (10, 17):
        r = run(n, app)
        label = f"{n} sensors, {r['segments']} segments"
        print(f"{label:<26}{r['fps']:7.1f}{r['fps'] / 60:6.2f}{r['plot_hz']:9.1f}{r['plot_hz'] / 30:6.2f}"
              f"{r['cpu_pct']:8.0f}{50 / r['cpu_pct']:8.2f}{r['lat_p50_ms']:9.1f}{r['lat_p95_ms']:9.1f}"
              f"{30 / r['lat_p95_ms']:8.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
