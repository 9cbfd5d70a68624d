"""How long a user waits for the first window: from typing ``mimucap`` to the window on screen.

Run under a display: ``xvfb-run -a -s "-screen 0 1366x768x24" .venv/bin/python bench/bench_first_window.py``
(``--python build/wheel-check-venv/bin/python`` measures the wheel installed by ``make
wheel-check`` instead of this checkout's environment).

Each start is a fresh program with user folders of its own (no settings, no calibrations, no
log: a first start), on the simulated suit, as ``mimucap gui --source simulated --screenshot
PNG --after 0``. The display is watched from outside the program (``xwininfo``, every 10 ms)
for the main window, titled "MimuCap", to be viewable; so the figure includes the interpreter's
start, every import and the window's construction, as a user sees it. Printed per start: the
window on screen, then the first live data drawn (the screenshot written) and the program's CPU
time (user + system) by the time the window showed and in all, which depends less on how busy
the machine is than the wall times.

The peer is an empty PyQt5 window started the same way by the same interpreter: the least any
PyQt5 program waits for its window on this machine; the ratio says what MimuCap adds.
Target (issue "Ship it"): the installed wheel's first window in under 3 s.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_S = 3.0

#: The peer: the smallest PyQt5 program that shows a window titled like ours.
EMPTY_WINDOW = """
import sys
from PyQt5 import QtCore, QtWidgets
app = QtWidgets.QApplication(sys.argv)
window = QtWidgets.QMainWindow()
window.setWindowTitle("MimuCap")
window.resize(1280, 720)
window.show()
QtCore.QTimer.singleShot(300, app.quit)
app.exec_()
"""


def _viewable(title: str) -> bool:
    """True when a window named ``title`` is mapped and viewable on the display."""
    done = subprocess.run(["xwininfo", "-name", title], capture_output=True, text=True)
    return done.returncode == 0 and "IsViewable" in done.stdout


def _user_env(folder: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "MIMUCAP_FUSION_KERNELS")}
    env.update(HOME=str(folder / "home"), XDG_CONFIG_HOME=str(folder / "config"), XDG_DATA_HOME=str(folder / "share"),
               XDG_STATE_HOME=str(folder / "state"), XDG_CACHE_HOME=str(folder / "cache"),
               MIMUCAP_DATA_DIR=str(folder / "data"), QT_API="pyqt5")
    return env


def _cpu_s(pid: int) -> float:
    """CPU seconds (user + system) process ``pid`` has used so far (Linux ``/proc``)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def one_start(command: list[str], cwd: Path, tries: int = 3) -> dict[str, float]:
    """Start ``command``; return seconds to the window on screen and the program's CPU seconds
    by then, then seconds to the program's end and its CPU seconds in all (with its children)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    process = subprocess.Popen(command, cwd=cwd, env=_user_env(cwd), stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True)
    shown = shown_cpu = None
    while process.poll() is None and shown is None:
        if _viewable("MimuCap"):
            shown = time.perf_counter() - started
            shown_cpu = _cpu_s(process.pid)
        else:
            time.sleep(0.01)
    _, errors = process.communicate(timeout=300)
    ended = time.perf_counter() - started
    if process.returncode != 0 and "could not connect to display" in errors and tries > 1:
        # The virtual display now and then refuses a connection while it is being polled; the
        # start did not happen, so it is made again.
        return one_start(command, cwd, tries - 1)
    if process.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed ({process.returncode}):\n{errors}")
    if shown is None:
        raise SystemExit(f"{' '.join(command)}: no window titled 'MimuCap' was seen on the display")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"window_s": shown, "window_cpu_s": shown_cpu, "end_s": ended, "cpu_s": cpu}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--python", default=sys.executable,
                        help="interpreter of the installation to measure (default: this one)")
    parser.add_argument("--starts", type=int, default=3, help="starts of each program (default 3)")
    args = parser.parse_args(argv)
    if not (os.environ.get("DISPLAY")):
        print("bench_first_window: needs an X display (run it under xvfb-run)", file=sys.stderr)
        return 1
    python = str(Path(args.python).absolute())
    ours, peer = [], []
    for index in range(args.starts):
        with tempfile.TemporaryDirectory(prefix="mimucap-first-window-") as folder:
            folder = Path(folder)
            peer.append(one_start([python, "-c", EMPTY_WINDOW], folder))
            ours.append(one_start([python, "-m", "mimucap", "gui", "--source", "simulated", "--screenshot",
                                   str(folder / "first.png"), "--after", "0"], folder))
        print(f"start {index + 1}: MimuCap window on screen {ours[-1]['window_s']:.2f} s "
              f"(CPU {ours[-1]['window_cpu_s']:.2f} s), first live data drawn "
              f"{ours[-1]['end_s']:.2f} s (CPU {ours[-1]['cpu_s']:.2f} s); empty PyQt5 window "
              f"{peer[-1]['window_s']:.2f} s")
    window = statistics.median(s["window_s"] for s in ours)
    window_cpu = statistics.median(s["window_cpu_s"] for s in ours)
    empty = statistics.median(s["window_s"] for s in peer)
    print(f"median of {args.starts}: MimuCap's first window {window:.2f} s "
          f"(CPU {window_cpu:.2f} s; {window / empty:.1f}x an empty PyQt5 window's {empty:.2f} s); first live data drawn "
          f"{statistics.median(s['end_s'] for s in ours):.2f} s; target: window under {TARGET_S:.0f} s "
          f"({'met' if window < TARGET_S else 'NOT met'})")
    print(f"interpreter: {python}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
