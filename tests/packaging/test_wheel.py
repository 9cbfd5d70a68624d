"""The wheel installed into a clean environment (``make wheel-check``, which CI runs after
``make test``), and the first start of an installation without fitting compiled kernels.

``MIMUCAP_WHEEL_PYTHON`` names the interpreter of the environment the wheel was installed into
(``make wheel-check``: ``build/wheel-check-venv/bin/python``); without it these tests are skipped,
so that ``make test`` builds no wheel. Each program runs with user folders of its own.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.gui.test_gui_command import assert_shows_the_uncalibrated_skeleton

WHEEL_ENV = "MIMUCAP_WHEEL_PYTHON"
if not os.environ.get(WHEEL_ENV):
    pytest.skip(f"the installed wheel's tests run in `make wheel-check` ({WHEEL_ENV} names its interpreter)",
                allow_module_level=True)

REPO = Path(__file__).resolve().parents[2]

#: Run by the installed wheel's interpreter, outside this checkout: where mimucap comes from,
#: which fusion kernels it loads, the name the installed kernel sources give the module for this
#: machine's architecture (the fingerprint), and whether numba was imported.
KERNELS = """
import json, sys
import mimucap
from mimucap.core.fusion import aot, kernel_selection
kernels = kernel_selection.fusion_kernels()
print(json.dumps({"package": mimucap.__file__, "origin": kernels.origin, "ahead_of_time": kernels.ahead_of_time,
                  "generic": aot.module_path(next(t for t in aot.target_ids() if t.startswith("generic:"))).name,
                  "numba_imported": "numba" in sys.modules}))
"""

#: A first start where no compiled kernels fit (a pure wheel, another CPU, edited sources):
#: numba's JIT kernels with an empty cache. While the kernels are prepared, the window is used
#: (its event loop runs a menu command, View → Toggle Body/World, and a timer); then the live
#: view starts.
FIRST_START_WITHOUT_KERNELS = """
import json, sys
from PyQt5 import QtCore, QtWidgets
app = QtWidgets.QApplication(sys.argv)
from mimucap.gui.main_window import MainWindow
win = MainWindow("simulated:demo")
win.show()
win.start()
ticks = []
timer = QtCore.QTimer(interval=20, timeout=lambda: ticks.append(win.starting))
timer.start()
mode = lambda: next(k for k, a in win.display_actions.items() if a.isChecked())
before = mode()
used = []
def use():
    win.action_toggle_display.trigger()  # View -> Toggle Body/World, from the event loop
    used.append((win.starting, mode() != before))
QtCore.QTimer.singleShot(500, use)
deadline = QtCore.QDeadlineTimer(600_000)
while not (win.live.started and win.live.samples_received > 0) and not deadline.hasExpired():
    app.processEvents(QtCore.QEventLoop.AllEvents, 50)
report = win._warm_up.result  # the preparation's report (None if it never finished)
print(json.dumps({"used": used, "ticks_while_starting": sum(ticks), "live": win.live.samples_received > 0,
                  "report": None if report is None else {"ahead_of_time": report.ahead_of_time,
                  "cached": report.cached, "compiled_in_child": report.compiled_in_child}}))
win.close()
"""


def _user_env(folder: Path, **extra: str) -> dict[str, str]:
    return {**{k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "MIMUCAP_FUSION_KERNELS")},
            "HOME": str(folder / "home"), "XDG_CONFIG_HOME": str(folder / "config"),
            "XDG_DATA_HOME": str(folder / "share"),
            "XDG_STATE_HOME": str(folder / "state"), "MIMUCAP_DATA_DIR": str(folder / "data"), **extra}


@pytest.fixture(scope="module")
def python() -> Path:
    return Path(os.environ[WHEEL_ENV])


def test_the_installed_wheel_runs_its_compiled_kernels_without_numba(python, tmp_path):
    done = subprocess.run([str(python), "-c", KERNELS], cwd=tmp_path, env=_user_env(tmp_path), capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert not Path(found["package"]).is_relative_to(REPO / "app")  # the installed package, not this checkout's
    # The module the wheel carries is the one its own kernel sources name: compiled from them.
    assert found["ahead_of_time"] and found["origin"] == found["generic"]
    assert not found["numba_imported"]


def test_the_installed_wheels_first_window(python, tmp_path):
    """The first start of the installed program: the window, the live simulated suit, a screenshot.
    Its wall time is printed (the issue's measure: under 3 s), not asserted."""
    out = tmp_path / "first.png"
    command = [str(python.parent / "mimucap"), "gui", "--source", "simulated", "--screenshot", str(out),
               "--after", "1.5"]
    started = time.perf_counter()
    done = subprocess.run(command, cwd=tmp_path, env=_user_env(tmp_path), capture_output=True, text=True,
                          timeout=300)
    print(f"first start of the installed wheel, to a screenshot after 1.5 s of live data: "
          f"{time.perf_counter() - started:.1f} s")
    assert done.returncode == 0, done.stderr
    assert_shows_the_uncalibrated_skeleton(out)


@pytest.mark.slow
@pytest.mark.timeout(900)  # numba compiles the kernels from nothing: half a minute of CPU
def test_without_fitting_compiled_kernels_the_window_is_usable_while_they_compile(tmp_path):
    """This checkout's program, with numba's JIT kernels and an empty cache, as an installation
    whose compiled kernels do not fit: they are compiled by a child process while the window
    runs its menu commands, and the live view starts once they are ready."""
    env = _user_env(tmp_path, PYTHONPATH=str(REPO / "app"), MIMUCAP_FUSION_KERNELS="jit",
                    NUMBA_CACHE_DIR=str(tmp_path / "numba-cache"))
    done = subprocess.run([sys.executable, "-c", FIRST_START_WITHOUT_KERNELS], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found["used"] == [[True, True]]  # the command took effect while the kernels were compiling
    assert found["ticks_while_starting"] > 10
    assert found["live"]
    assert found["report"] == {"ahead_of_time": False, "cached": False, "compiled_in_child": True}
    assert any((tmp_path / "numba-cache").rglob("*.nbc"))  # compiled (by the child) into the cache
