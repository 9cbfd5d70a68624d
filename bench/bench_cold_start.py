"""Start-up responsiveness of the main window: the longest pauses of its event loop.

Run under a display: ``xvfb-run -a -s "-screen 0 1920x1200x24" .venv/bin/python bench/bench_cold_start.py``.

Two starts of ``MainWindow("simulated:walk")``, each in a fresh interpreter:

* **cold**: numba's cache is an empty temporary folder (``NUMBA_CACHE_DIR``), as after an
  installation: the fusion kernels are compiled before the first sample (in a child
  process, :mod:`mimucap.session.live.kernel_preparation`), and then the live session starts;
* **warm**: the same folder, now holding the compiled kernels.

With ``--installed`` a single start runs with numba's own cache location instead (no
``NUMBA_CACHE_DIR``), as the installed application finds it: run right after
``rm -rf .venv && make install``, whose last step compiles the kernels into that cache
(``python -m mimucap.core.fusion.warmup``), it is the user's first start (target: live data
within 10 s of the window opening).

numba's cache matters only where the fusion kernels come from numba's JIT: after ``make
install`` a process loads the module compiled ahead of time (:mod:`mimucap.core.fusion.aot`)
and compiles nothing, cold or warm. ``MIMUCAP_FUSION_KERNELS=jit`` in the environment measures
the JIT path (the fallback when that module is missing or stale).

A 5 ms ``QTimer`` runs from the moment the window is shown; a pause is the time between two of
its ticks. Printed per start: the time until the first sample (s), the three longest pauses
(ms, with when they happened) and the share of the time spent in pauses longer than 50 ms.
A window that never pauses for more than ~100 ms feels responsive (target).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

PAUSE_TARGET_MS = 100.0

#: Runs in the child interpreter: show the window, tick, report (JSON on the last line).
CHILD = r"""
import json, sys, time
from PyQt5 import QtCore, QtWidgets
from mimucap.gui.main_window import MainWindow

def main(seconds):
    app = QtWidgets.QApplication(["bench"])
    window = MainWindow("simulated:walk")
    window.show()
    t0 = time.perf_counter()
    window.start()
    ticks = [t0]
    first_sample = []
    def tick():
        now = time.perf_counter()
        ticks.append(now)
        if not first_sample and window.live is not None and window.live.samples_received:
            first_sample.append(now - t0)
            QtCore.QTimer.singleShot(int(1000 * seconds), app.quit)  # then some live time
    timer = QtCore.QTimer()
    timer.setInterval(5)
    timer.timeout.connect(tick)
    timer.start()
    QtCore.QTimer.singleShot(300_000, app.quit)  # never wait for ever
    app.exec_()
    window.close()
    pauses = sorted(((b - a, b - t0) for a, b in zip(ticks, ticks[1:])), reverse=True)
    long_s = sum(p for p, _ in pauses if p > 0.05)
    print(json.dumps({"first_sample_s": first_sample[0] if first_sample else None,
                      "longest": [(1000 * p, at) for p, at in pauses[:3]],
                      "long_share": long_s / (ticks[-1] - t0)}))

if __name__ == "__main__":
    main(float(sys.argv[1]))
"""


def start(cache_dir: str | None, live_s: float) -> dict:
    """One start in a fresh interpreter; ``cache_dir`` None: numba's own cache location."""
    env = dict(os.environ)
    env.pop("NUMBA_CACHE_DIR", None)
    if cache_dir is not None:
        env["NUMBA_CACHE_DIR"] = cache_dir
    done = subprocess.run([sys.executable, "-c", CHILD, str(live_s)], env=env, capture_output=True,
                          text=True, timeout=400)
    if done.returncode != 0:
        raise RuntimeError(f"the window did not start:\n{done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--live", type=float, default=5.0, help="seconds of live data after the first sample")
    parser.add_argument("--installed", action="store_true",
                        help="one start with numba's own cache, as after make install (the first start after it)")
    args = parser.parse_args()
    print(f"Main window start-up, simulated suit; pauses of the GUI event loop (target: none over "
          f"{PAUSE_TARGET_MS:.0f} ms)")
    print(f"{'start':9s} {'first sample':>13s}  {'longest pauses (ms at s)':40s} {'time in pauses > 50 ms':>22s}")
    with tempfile.TemporaryDirectory(prefix="mimucap-numba-") as cache_dir:
        for name in (("installed",) if args.installed else ("cold", "warm")):
            result = start(None if args.installed else cache_dir, args.live)
            longest = ", ".join(f"{ms:.0f} at {at:.1f}" for ms, at in result["longest"])
            first = result["first_sample_s"]
            first_text = "never" if first is None else f"{first:.1f} s"
            ratio = PAUSE_TARGET_MS / max(result["longest"][0][0], 1e-3)
            print(f"{name:9s} {first_text:>13s}  {longest:40s} {100 * result['long_share']:21.1f} %"
                  f"   target/longest {ratio:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
