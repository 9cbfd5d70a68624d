"""GUI benchmark (issue 6, Performance): the main window live on a simulated suit.

Run under a display: ``xvfb-run -a -s "-screen 0 1920x1200x24" .venv/bin/python bench/bench_gui.py``
(``make bench`` does). Loads, all at 100 Hz with 4 live plots: the simulated suit in process
with 10 sensors (ten segments) and 17 sensors (fifteen segments), and 17 emulated wireless
boards in another process sending over loopback UDP (fifteen segments, poses from the
sensors' orientations). Measured over ``MEASURE_S`` seconds after a warm-up:

* 3D view frame rate (``Render()`` calls per second; target 60),
* plot refresh rate (target >= 30 Hz),
* CPU use of the GUI process (process CPU time / wall time; target < 50 % of one core;
  under Xvfb the software OpenGL renderer runs inside this process and is counted),
* latency from a sample's arrival (its host time) to the end of the ``Render()`` that shows
  the pose it belongs to (p50/p95; target p95 < 30 ms),

and each figure's ratio to its target (> 1 is better than the target). The CPU is also split by
thread (Linux ``/proc``): the GUI thread, the software OpenGL rasteriser's threads (``llvmpipe-*``,
work a GPU would do) and any others. The last line names the OpenGL implementation and what an
empty 3D frame of the same size costs on it.

On software OpenGL the same loads then run again in a child process with Mesa's no-op driver
(``GALLIUM_NOOP=true``: every OpenGL call is made, nothing is rasterised, read-backs return
blank pictures). That second table estimates the window on a machine whose GPU does the
drawing, *without* the GPU driver's own CPU cost: a lower bound, not a measurement on a GPU.
``--without-rasteriser`` runs only that second pass.
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from PyQt5 import QtCore, QtWidgets
from vtkmodules.vtkCommonCore import vtkUnsignedCharArray
from vtkmodules.vtkRenderingCore import vtkRenderer, vtkRenderWindow

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


def _free_udp_port() -> int:
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    return port


def thread_cpu_s() -> dict[str, float]:
    """CPU time (s) so far of this process's threads by group: ``gui`` (the main thread),
    ``gl`` (Mesa's llvmpipe rasteriser threads), ``other``; empty where ``/proc`` is missing."""
    groups = {"gui": 0.0, "gl": 0.0, "other": 0.0}
    ticks = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
    try:
        tasks = os.listdir("/proc/self/task")
    except OSError:
        return {}
    for tid in tasks:
        try:
            with open(f"/proc/self/task/{tid}/comm") as f:
                name = f.read().strip()
            with open(f"/proc/self/task/{tid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue  # the thread ended meanwhile
        group = "gui" if int(tid) == os.getpid() else "gl" if name.startswith("llvmpipe") else "other"
        groups[group] += (int(fields[11]) + int(fields[12])) / ticks  # utime + stime
    return groups


def run(window: MainWindow, prepare=None) -> dict[str, float]:
    """Show ``window`` live; after the warm-up (and ``prepare(window)``), measure."""
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
    spent = {"3d": 0.0, "plots": 0.0}

    def timed(part: str, function):
        def wrapper(*args):
            start = time.process_time()
            try:
                return function(*args)
            finally:
                if state["measuring"]:
                    spent[part] += time.process_time() - start
        return wrapper

    view = window.scene_view.vtk_widget
    view.render = timed("3d", view.render)
    window.plots.refresh = timed("plots", window.plots.refresh)
    painting = _PaintTimer(window.plots.layout_widget, spent, state)
    _run_event_loop(WARMUP_S)
    if prepare is not None:
        prepare(window)
        _run_event_loop(WARMUP_S)
    frames0, plots0 = window.scene_view.frames_rendered, window.plots.refresh_count
    wall0, cpu0, threads0 = time.perf_counter(), time.process_time(), thread_cpu_s()
    state["measuring"] = True
    _run_event_loop(MEASURE_S)
    wall = time.perf_counter() - wall0
    cpu = time.process_time() - cpu0
    threads = {group: 100.0 * (value - threads0[group]) / wall for group, value in thread_cpu_s().items()}
    result = {
        "fps": (window.scene_view.frames_rendered - frames0) / wall,
        "plot_hz": (window.plots.refresh_count - plots0) / wall,
        "cpu_pct": 100.0 * cpu / wall,
        "lat_p50_ms": 1000.0 * float(np.percentile(latencies, 50)) if latencies else float("nan"),
        "lat_p95_ms": 1000.0 * float(np.percentile(latencies, 95)) if latencies else float("nan"),
        "segments": len(window.live.model.segment_names),
        "view": window.scene_view.vtk_widget.render_window.GetSize(),
        "cpu_3d_pct": 100.0 * spent["3d"] / wall,
        "cpu_plots_pct": 100.0 * spent["plots"] / wall,
        "threads_pct": threads,
    }
    window.close()
    del painting
    return result


class _PaintTimer(QtCore.QObject):
    """Adds the CPU time of painting a ``QGraphicsView`` (the plots) to ``spent["plots"]``."""

    def __init__(self, view: QtWidgets.QGraphicsView, spent: dict, state: dict) -> None:
        super().__init__(view)
        self.view, self.spent, self.state = view, spent, state
        view.viewport().installEventFilter(self)

    def eventFilter(self, watched, event) -> bool:  # noqa: N802 (Qt API)
        if event.type() != QtCore.QEvent.Paint or not self.state["measuring"]:
            return False
        start = time.process_time()
        self.view.viewportEvent(event)  # paint now, timed; the event is then consumed
        self.spent["plots"] += time.process_time() - start
        return True


def run_simulated(n_sensors: int) -> dict[str, float]:
    """The simulated suit, in this process (its simulation cost is counted)."""
    return run(MainWindow("simulated:walk", session_factory=lambda spec: open_live_session(spec, n_sensors=n_sensors)))


def run_udp(n_sensors: int) -> dict[str, float]:
    """``n_sensors`` emulated wireless boards in another process, sending over loopback UDP,
    read by an acquisition worker; sensor i drives segment i of the fifteen-segment model."""
    port = _free_udp_port()
    emulator = subprocess.Popen(
        [str(Path(sys.executable).with_name("mimucap")), "emulate", "udp", "--sensors", str(n_sensors),
         "--rate", "100", "--scenario", "walk", "--target", f"127.0.0.1:{port}",
         "--duration", str(3 * WARMUP_S + MEASURE_S + 10)],
        stdout=subprocess.DEVNULL)
    try:
        window = MainWindow(f"udp:127.0.0.1:{port}",
                            session_factory=lambda spec: open_live_session(spec, model_name="fifteen_segment"))

        def assign(win: MainWindow) -> None:
            deadline = time.monotonic() + 30.0  # a cold start compiles the fusion kernels first
            while len(win.live.sensor_ids) < n_sensors and time.monotonic() < deadline:
                _run_event_loop(0.1)
            if len(win.live.sensor_ids) < n_sensors:
                raise RuntimeError(f"only {len(win.live.sensor_ids)} of {n_sensors} emulated boards were heard")
            segments = win.live.model.segment_names
            win.apply_assignment(dict(zip(win.live.sensor_ids, segments)))

        return run(window, assign)
    finally:
        emulator.terminate()
        emulator.wait(10)


def empty_frame_cpu_ms(size: tuple[int, int], frames: int = 100) -> tuple[str, float]:
    """The OpenGL renderer's name and the CPU (ms) of one frame of an *empty* offscreen VTK
    window of ``size``: what it costs before anything is drawn (clear, finish, read-back)."""
    window = vtkRenderWindow()
    window.SetMultiSamples(0)
    window.OffScreenRenderingOn()
    window.SetSize(*size)
    window.AddRenderer(vtkRenderer())
    for _ in range(5):
        window.Render()
    renderer = window.ReportCapabilities().split("OpenGL renderer string:")[-1].splitlines()[0].strip()
    start = time.process_time()
    pixels = vtkUnsignedCharArray()
    for _ in range(frames):
        window.Render()
        window.GetRGBACharPixelData(0, 0, size[0] - 1, size[1] - 1, 0, pixels, 0)
    cpu_ms = 1000.0 * (time.process_time() - start) / frames
    window.Finalize()
    return renderer, cpu_ms


#: The loads: command-line name -> (label, run).
LOADS = {
    "sim10": ("simulated suit, 10 sensors", lambda: run_simulated(10)),
    "sim17": ("simulated suit, 17 sensors", lambda: run_simulated(17)),
    "udp": ("17 UDP boards (emulator process)", lambda: run_udp(17)),
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--load", choices=LOADS, action="append",
                        help="run only this load (repeatable); default: all three. To compare two "
                             "versions, alternate single-load runs with PYTHONPATH=<other checkout>/app.")
    parser.add_argument("--without-rasteriser", action="store_true",
                        help="run the loads with Mesa's no-op driver only (see the module doc)")
    args = parser.parse_args(argv)
    no_op = os.environ.get("GALLIUM_NOOP") == "true"  # this process draws nothing
    if args.without_rasteriser and not no_op:
        return _run_without_rasteriser(args.load)
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(["bench_gui"])
    if no_op:
        print("Without rasterisation (Mesa's no-op driver): a lower bound for the same window on a GPU")
    else:
        print(f"GUI benchmark: main window 1280x800, 4 live plots, 100 Hz sensors, {MEASURE_S:.0f} s per load")
    print(f"{'load':<40}{'fps':>7}{'/60':>6}{'plot Hz':>9}{'/30':>6}{'CPU %':>8}{'50/CPU':>8}"
          f"{'lat p50':>9}{'lat p95':>9}{'30/p95':>8}{'3D %':>7}{'plots %':>9}{'rest %':>8}"
          f"{'GUI thr.':>10}{'GL thr.':>9}")
    loads = [(name, run_load) for key, (name, run_load) in LOADS.items() if not args.load or key in args.load]
    view = None
    for name, load in loads:
        r = load()
        view = r["view"]
        label = f"{name}, {r['segments']} seg."
        print(f"{label:<40}{r['fps']:7.1f}{r['fps'] / 60:6.2f}{r['plot_hz']:9.1f}{r['plot_hz'] / 30:6.2f}"
              f"{r['cpu_pct']:8.0f}{50 / r['cpu_pct']:8.2f}{r['lat_p50_ms']:9.1f}{r['lat_p95_ms']:9.1f}"
              f"{30 / r['lat_p95_ms']:8.2f}{r['cpu_3d_pct']:7.0f}{r['cpu_plots_pct']:9.0f}"
              f"{r['cpu_pct'] - r['cpu_3d_pct'] - r['cpu_plots_pct']:8.0f}"
              f"{r['threads_pct'].get('gui', float('nan')):10.0f}{r['threads_pct'].get('gl', float('nan')):9.0f}")
    renderer, empty = empty_frame_cpu_ms(tuple(view))
    if not no_op:
        print("CPU % is of one core (process CPU time / wall time); 3D = rendering and reading back the 3D view,")
        print("plots = refreshing and painting the plots, rest = pipeline (fusion, angles), panels, Qt;")
        print("GUI thr. = the main thread, GL thr. = the software rasteriser's threads (a GPU's work), % of a core.")
    print(f"OpenGL: {renderer}; an empty {view[0]}x{view[1]} 3D frame costs {empty:.2f} ms of CPU "
          f"({empty * 60 / 10:.0f} % of a core at 60 fps)")
    app.processEvents()
    if "llvmpipe" in renderer:  # software OpenGL: estimate the window without its work
        print()
        sys.stdout.flush()
        return _run_without_rasteriser(args.load)
    return 0


def _run_without_rasteriser(loads: list[str] | None) -> int:
    """Run ``loads`` (all when ``None``) again in a child process on Mesa's no-op driver."""
    command = [sys.executable, str(Path(__file__).resolve()), "--without-rasteriser"]
    for load in loads or ():
        command += ["--load", load]
    return subprocess.call(command, env={**os.environ, "GALLIUM_NOOP": "true"})


if __name__ == "__main__":
    sys.exit(main())
