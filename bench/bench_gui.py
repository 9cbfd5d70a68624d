"""GUI benchmark (issue 6, Performance): the main window live on a simulated suit.

Run under a display: ``xvfb-run -a -s "-screen 0 1920x1200x24" .venv/bin/python bench/bench_gui.py``
(``make bench`` does). Loads, all at 100 Hz with 4 live plots: the simulated suit in process
with 10 sensors (ten segments) and 17 sensors (fifteen segments), and 17 emulated wireless
boards in another process sending over loopback UDP (fifteen segments, poses from the
sensors' orientations). Measured over ``MEASURE_S`` seconds after a warm-up:

* 3D view frame rate (pictures shown per second; target 60),
* plot refresh rate (target >= 30 Hz),
* CPU use of the GUI process (process CPU time / wall time; target < 50 % of one core),
* latency from a sample's arrival (its host time) to the moment the picture of the pose it
  belongs to is shown (p50/p95; target p95 < 30 ms),

and each figure's ratio to its target (> 1 is better than the target). The GUI process's CPU
is split into the 3D view's part (sending the scene to the render process and showing its
pictures, or drawing them itself), the plots' part (refreshing and painting) and the rest
(pipeline, panels, Qt). ``render %`` is the CPU of the render process that draws the 3D view
(``mimucap.gui.scene.render_process``): on this machine Mesa's software rasteriser, on a
machine with a GPU mostly the GPU's work. ``total %`` is both processes.

The same loads then run again in a child process with the 3D view drawn inside the GUI
process (``MIMUCAP_RENDER_PROCESS=0``, the fallback when no render process can start), for
comparison. ``--in-process`` runs only that pass; ``--without-rasteriser`` runs the loads on
Mesa's no-op driver (``GALLIUM_NOOP=true``: every OpenGL call is made, nothing is rasterised),
a lower bound for the drawing on a GPU.
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

from bench_acquisition import cpu_seconds  # bench/ is on sys.path when a bench script runs
from mimucap.gui.main_window import MainWindow
from mimucap.gui.scene.view import RENDER_PROCESS_VARIABLE, render_process_wanted
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


def run(window: MainWindow, prepare=None) -> dict[str, float]:
    """Show ``window`` live; after the warm-up (and ``prepare(window)``), measure."""
    window.set_camera_preset("follow")
    window.show()
    window.start()
    latencies: list[float] = []
    state = {"measuring": False}
    data_time: dict[object, float] = {}  # frame id -> host time (s) of the newest sample in it
    view = window.scene_view

    def on_render(now_perf: float) -> None:
        arrived = data_time.get(view.shown_frame_id)
        if state["measuring"] and arrived is not None:
            latencies.append(time.monotonic() - arrived)

    view.frame_rendered.connect(on_render)
    spent = {"3d": 0.0, "plots": 0.0}

    def timed(part: str, function):
        def wrapper(*args, **kwargs):
            start = time.process_time()
            try:
                return function(*args, **kwargs)
            finally:
                if state["measuring"]:
                    spent[part] += time.process_time() - start
        return wrapper

    # The 3D view's cost in this process: drawing here, or sending the scene to the render
    # process and showing its pictures.
    view.render = timed("3d", view.render)
    if view.render_client is not None:
        view.vtk_widget.show_frame = timed("3d", view.vtk_widget.show_frame)
    window.plots.refresh = timed("plots", window.plots.refresh)
    painting = _PaintTimer(window.plots.layout_widget, spent, state)
    _run_event_loop(WARMUP_S)
    if prepare is not None:
        prepare(window)
        _run_event_loop(WARMUP_S)
    live = window.live

    def frame_with_its_time():
        frame = live.frame()
        if frame is not None and live.time_s == live.time_s:
            data_time.setdefault(frame[0], live.t0_host_s + live.time_s)
        return frame

    view.set_frame_provider(frame_with_its_time)
    _run_event_loop(0.5)
    render_pid = view.render_client.pid if view.render_client is not None else None
    frames0, plots0 = view.frames_rendered, window.plots.refresh_count
    wall0, cpu0 = time.perf_counter(), time.process_time()
    render0 = cpu_seconds(render_pid)
    state["measuring"] = True
    _run_event_loop(MEASURE_S)
    wall = time.perf_counter() - wall0
    cpu = time.process_time() - cpu0
    result = {
        "fps": (view.frames_rendered - frames0) / wall,
        "plot_hz": (window.plots.refresh_count - plots0) / wall,
        "cpu_pct": 100.0 * cpu / wall,
        "render_pct": 100.0 * (cpu_seconds(render_pid) - render0) / wall,
        "render_failure": view.render_failure,
        "lat_p50_ms": 1000.0 * float(np.percentile(latencies, 50)) if latencies else float("nan"),
        "lat_p95_ms": 1000.0 * float(np.percentile(latencies, 95)) if latencies else float("nan"),
        "segments": len(window.live.model.segment_names),
        "view": view.vtk_widget.render_window.GetSize(),
        "cpu_3d_pct": 100.0 * spent["3d"] / wall,
        "cpu_plots_pct": 100.0 * spent["plots"] / wall,
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
    parser.add_argument("--in-process", action="store_true",
                        help="only draw the 3D view inside the GUI process (MIMUCAP_RENDER_PROCESS=0)")
    parser.add_argument("--without-rasteriser", action="store_true",
                        help="run the loads with Mesa's no-op driver (see the module doc)")
    args = parser.parse_args(argv)
    if args.in_process and os.environ.get(RENDER_PROCESS_VARIABLE) != "0":
        return _run_again(args, {RENDER_PROCESS_VARIABLE: "0"})
    if args.without_rasteriser and os.environ.get("GALLIUM_NOOP") != "true":
        return _run_again(args, {"GALLIUM_NOOP": "true"})
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(["bench_gui"])
    in_process = not render_process_wanted()
    where = "drawn in the GUI process" if in_process else "drawn by the render process"
    nothing = ", Mesa's no-op driver (nothing rasterised)" if os.environ.get("GALLIUM_NOOP") == "true" else ""
    print(f"GUI benchmark: main window 1280x800, 4 live plots, 100 Hz sensors, {MEASURE_S:.0f} s per load; "
          f"3D view {where}{nothing}")
    print(f"{'load':<40}{'fps':>7}{'/60':>6}{'plot Hz':>9}{'/30':>6}{'CPU %':>8}{'50/CPU':>8}"
          f"{'lat p50':>9}{'lat p95':>9}{'30/p95':>8}{'3D %':>7}{'plots %':>9}{'rest %':>8}"
          f"{'render %':>10}{'total %':>9}")
    loads = [(name, run_load) for key, (name, run_load) in LOADS.items() if not args.load or key in args.load]
    view = None
    for name, load in loads:
        r = load()
        view = r["view"]
        label = f"{name}, {r['segments']} seg."
        drawn_apart = r["render_pct"] == r["render_pct"]  # NaN without a render process
        render = r["render_pct"] if drawn_apart else 0.0
        render_column = f"{render:.0f}" if drawn_apart else "-"
        print(f"{label:<40}{r['fps']:7.1f}{r['fps'] / 60:6.2f}{r['plot_hz']:9.1f}{r['plot_hz'] / 30:6.2f}"
              f"{r['cpu_pct']:8.0f}{50 / r['cpu_pct']:8.2f}{r['lat_p50_ms']:9.1f}{r['lat_p95_ms']:9.1f}"
              f"{30 / r['lat_p95_ms']:8.2f}{r['cpu_3d_pct']:7.0f}{r['cpu_plots_pct']:9.0f}"
              f"{r['cpu_pct'] - r['cpu_3d_pct'] - r['cpu_plots_pct']:8.0f}"
              f"{render_column:>10}{r['cpu_pct'] + render:9.0f}")
        if r["render_failure"]:
            print(f"  the render process failed ({r['render_failure']}); the 3D view was drawn in the GUI process")
    renderer, empty = empty_frame_cpu_ms(tuple(view))
    print("CPU % = the GUI process (process CPU time / wall time, % of one core): 3D = the 3D view's part,")
    print("plots = refreshing and painting the plots, rest = pipeline (fusion, angles), panels, Qt;")
    print("render % = the render process (a GPU's work on a machine with one); total % = both.")
    print(f"OpenGL: {renderer}; an empty {view[0]}x{view[1]} 3D frame costs {empty:.2f} ms of CPU "
          f"({empty * 60 / 10:.0f} % of a core at 60 fps)")
    app.processEvents()
    if not in_process and not args.in_process and not args.without_rasteriser:
        print()
        sys.stdout.flush()
        return _run_again(args, {RENDER_PROCESS_VARIABLE: "0"})
    return 0


def _run_again(args: argparse.Namespace, env: dict[str, str]) -> int:
    """Run the chosen loads again in a child process with ``env`` added to the environment."""
    command = [sys.executable, str(Path(__file__).resolve())]
    for load in args.load or ():
        command += ["--load", load]
    return subprocess.call(command, env={**os.environ, **env})


if __name__ == "__main__":
    sys.exit(main())
