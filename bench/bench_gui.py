"""GUI benchmark (issue 6, Performance; issue 27): the main window live on a simulated suit.

Run under a display: ``xvfb-run -a -s "-screen 0 1920x1200x24" .venv/bin/python bench/bench_gui.py``
(``make bench`` does). Loads, all at 100 Hz with 4 live plots: the simulated suit in process
with 10 sensors (ten segments) and 17 sensors (fifteen segments), and 17 emulated wireless
boards in another process sending over loopback UDP, read by an acquisition worker process
(fifteen segments, poses from the sensors' orientations). Measured over ``MEASURE_S`` seconds
after a warm-up:

* 3D view frame rate (pictures shown per second; target 60),
* plot refresh rate (target >= 30 Hz),
* CPU use of the whole application: the GUI process (all its threads, the OpenGL driver's
  included) and every process it started (acquisition workers), as process CPU time / wall
  time in % of one core (target < 80 %). The emulator that stands in for the sensors is not
  part of the application and is not counted; neither is the X server, whose CPU (presenting
  the frames on a machine without a GPU) is printed apart,
* how long the GUI thread waited, ready to run, for a core taken by other work (``queued``;
  a shared machine's perturbation, printed so that a low frame rate can be told apart),
* latency from a sample's arrival (its host time) to the moment the picture of the pose it
  belongs to is shown (p50/p95; target p95 < 30 ms),

and each figure's ratio to its target (> 1 is better than the target). The GUI process's CPU
is split into the 3D view's part (drawing and presenting its frames), the plots' part
(refreshing and painting) and the rest (pipeline, panels, Qt). ``--without-rasteriser`` runs
the loads on Mesa's no-op driver (``GALLIUM_NOOP=true``: every OpenGL call is made, nothing is
rasterised), a lower bound for the drawing on a GPU.
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
from PyQt5 import QtCore, QtWidgets
from vtkmodules.vtkRenderingCore import vtkRenderer

from bench_acquisition import cpu_seconds  # bench/ is on sys.path when a bench script runs
from mimucap.gui.main_window import MainWindow
from mimucap.gui.vtk_widget import VtkWidget
from mimucap.session.live.live_session import open_live_session

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


def _children() -> dict[int, list[int]]:
    """Every running process's children: pid -> child pids (from /proc)."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            fields = open(f"/proc/{entry}/stat").read().rsplit(")", 1)[1].split()
        except OSError:
            continue  # ended meanwhile
        children.setdefault(int(fields[1]), []).append(int(entry))
    return children


def application_processes(excluded: set[int]) -> list[int]:
    """This process and all its descendants, but not ``excluded`` ones (nor theirs)."""
    children = _children()
    found, stack = [], [os.getpid()]
    while stack:
        pid = stack.pop()
        if pid in excluded:
            continue
        found.append(pid)
        stack.extend(children.get(pid, ()))
    return found


def _cpu_of(pids: list[int]) -> dict[int, float]:
    """CPU seconds so far of each of ``pids`` that is still running."""
    seconds = {}
    for pid in pids:
        try:
            seconds[pid] = cpu_seconds(pid)
        except OSError:
            pass
    return seconds


def queued_s() -> float:
    """How long (s) the GUI thread has waited, ready to run, for a core (Linux schedstat; NaN
    elsewhere): on a shared machine, the time other work took from it."""
    try:
        return int(open(f"/proc/self/task/{threading.get_native_id()}/schedstat").read().split()[1]) / 1e9
    except (OSError, IndexError, ValueError):
        return float("nan")


def x_server_pid() -> int | None:
    """The Xvfb process serving ``$DISPLAY``, if that is what serves it."""
    display = os.environ.get("DISPLAY", "").split(".")[0]
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            command = open(f"/proc/{entry}/cmdline", "rb").read().split(b"\0")
        except OSError:
            continue
        if command and command[0].endswith(b"Xvfb") and display.encode() in command:
            return int(entry)
    return None


def run(window: MainWindow, prepare=None, excluded: set[int] = frozenset()) -> dict[str, float]:
    """Show ``window`` live; after the warm-up (and ``prepare(window)``), measure. Processes
    in ``excluded`` (and their children) are not part of the application."""
    window.set_camera_preset("front")
    window.resize(1280, 800)  # the size measured (a larger screen opens the window larger)
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

    # The 3D view's cost: drawing and presenting its frames.
    view.render = timed("3d", view.render)
    window.plots.refresh = timed("plots", window.plots.refresh)
    painting = _PaintTimer(window.plots.layout_widget, spent, state)
    _run_event_loop(WARMUP_S)
    if prepare is not None:
        prepare(window)
        _run_event_loop(WARMUP_S)
    live = window.live

    def note_its_time(frame_id, _geometry) -> None:
        if live.time_s == live.time_s:
            data_time.setdefault(frame_id, live.t0_host_s + live.time_s)

    # Noted before the 3D view takes the frame (it may draw it at once, inside the event).
    live.events.frame.disconnect(view.show_frame)
    live.events.frame.connect(note_its_time)
    live.events.frame.connect(view.show_frame)
    _run_event_loop(0.5)
    processes = application_processes(set(excluded))
    x_server = x_server_pid()
    frames0, plots0 = view.frames_rendered, window.plots.refresh_count
    wall0, cpu0 = time.perf_counter(), time.process_time()
    others0 = _cpu_of([pid for pid in processes if pid != os.getpid()])
    x0 = cpu_seconds(x_server)
    queued0 = queued_s()
    state["measuring"] = True
    _run_event_loop(MEASURE_S)
    wall = time.perf_counter() - wall0
    cpu = time.process_time() - cpu0
    others1 = _cpu_of(list(others0))
    others = sum(others1[pid] - others0[pid] for pid in others1)
    result = {
        "fps": (view.frames_rendered - frames0) / wall,
        "plot_hz": (window.plots.refresh_count - plots0) / wall,
        "cpu_pct": 100.0 * cpu / wall,
        "others_pct": 100.0 * others / wall,
        "processes": len(others1) + 1,
        "x_pct": 100.0 * (cpu_seconds(x_server) - x0) / wall,
        "queued_pct": 100.0 * (queued_s() - queued0) / wall,
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

        return run(window, assign, excluded={emulator.pid})
    finally:
        emulator.terminate()
        emulator.wait(10)


def empty_frame_cpu_ms(size: tuple[int, int], frames: int = 100) -> tuple[str, float]:
    """The OpenGL renderer's name and the CPU (ms, this process) of one frame of an *empty*
    3D view of ``size`` shown on screen: what a frame costs before anything is drawn (clear,
    copy to the window, present)."""
    widget = VtkWidget()
    widget.resize(*size)
    widget.render_window.AddRenderer(vtkRenderer())
    widget.show()
    QtWidgets.QApplication.processEvents()
    for _ in range(5):
        widget.render()
    renderer = widget.render_window.ReportCapabilities().split("OpenGL renderer string:")[-1].splitlines()[0].strip()
    start = time.process_time()
    for _ in range(frames):
        widget.render()
    cpu_ms = 1000.0 * (time.process_time() - start) / frames
    widget.Finalize()
    widget.close()
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
                        help="run the loads with Mesa's no-op driver (see the module doc)")
    args = parser.parse_args(argv)
    if args.without_rasteriser and os.environ.get("GALLIUM_NOOP") != "true":
        return _run_again(args, {"GALLIUM_NOOP": "true"})
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(["bench_gui"])
    nothing = ", Mesa's no-op driver (nothing rasterised)" if os.environ.get("GALLIUM_NOOP") == "true" else ""
    print(f"GUI benchmark: main window 1280x800, 4 live plots, 100 Hz sensors, {MEASURE_S:.0f} s per load; "
          f"3D view drawn in the GUI process{nothing}")
    print(f"{'load':<40}{'fps':>7}{'/60':>6}{'plot Hz':>9}{'/30':>6}{'lat p50':>9}{'lat p95':>9}{'30/p95':>8}"
          f"{'GUI %':>7}{'3D %':>6}{'plots %':>9}{'rest %':>8}{'others %':>10}{'total %':>9}{'80/total':>10}"
          f"{'X %':>6}{'queued %':>10}")
    loads = [(name, run_load) for key, (name, run_load) in LOADS.items() if not args.load or key in args.load]
    view = None
    for name, load in loads:
        r = load()
        view = r["view"]
        label = f"{name}, {r['segments']} seg."
        total = r["cpu_pct"] + r["others_pct"]
        x_column = f"{r['x_pct']:.0f}" if r["x_pct"] == r["x_pct"] else "-"
        print(f"{label:<40}{r['fps']:7.1f}{r['fps'] / 60:6.2f}{r['plot_hz']:9.1f}{r['plot_hz'] / 30:6.2f}"
              f"{r['lat_p50_ms']:9.1f}{r['lat_p95_ms']:9.1f}{30 / r['lat_p95_ms']:8.2f}"
              f"{r['cpu_pct']:7.0f}{r['cpu_3d_pct']:6.0f}{r['cpu_plots_pct']:9.0f}"
              f"{r['cpu_pct'] - r['cpu_3d_pct'] - r['cpu_plots_pct']:8.0f}"
              f"{r['others_pct']:10.0f}{total:9.0f}{80 / total:10.2f}{x_column:>6}{r['queued_pct']:10.0f}")
    renderer, empty = empty_frame_cpu_ms(tuple(view))
    print("CPU in % of one core (process CPU time / wall time). GUI = the GUI process, all threads:")
    print("3D = drawing and presenting the 3D view, plots = refreshing and painting the plots, rest =")
    print("pipeline (fusion, angles), panels, Qt; others = the processes the application started")
    print("(acquisition workers); total = GUI + others, the whole application (the UDP emulator, the")
    print("sensors' stand-in, not counted). X = the X server (Xvfb), not part of the application.")
    print("queued = time the GUI thread was ready to run but waited for a core (other work on the machine):")
    print("where it is more than a few %, the frame rate and the latency are the machine's, not the program's.")
    print(f"OpenGL: {renderer}; an empty {view[0]}x{view[1]} 3D frame on screen costs {empty:.2f} ms of CPU "
          f"({empty * 60 / 10:.0f} % of a core at 60 fps)")
    app.processEvents()
    return 0


def _run_again(args: argparse.Namespace, env: dict[str, str]) -> int:
    """Run the chosen loads again in a child process with ``env`` added to the environment."""
    command = [sys.executable, str(Path(__file__).resolve())]
    for load in args.load or ():
        command += ["--load", load]
    return subprocess.call(command, env={**os.environ, **env})


if __name__ == "__main__":
    sys.exit(main())
