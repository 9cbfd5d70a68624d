"""The first window opens without what only later work needs.

A user waits for the first window through every import its construction makes; the wizards
(the clinical-test wizard alone pulls in scipy.signal and scipy.stats) load when one is first
opened. Checked in a fresh interpreter, through ``sys.modules``: what the test process itself
imported does not count. ``bench/bench_first_window.py`` measures the wait.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

from mimucap.gui.main_window import WIZARDS

LATER = ["scipy.signal", "scipy.stats"] + [module for module, _ in WIZARDS.values()]

PROBE = r"""
import json, sys
from PyQt5 import QtWidgets
app = QtWidgets.QApplication(["probe"])
from mimucap.gui.main_window import MainWindow, wizard_class
window = MainWindow("simulated:demo")
window.show()
app.processEvents()
later = json.loads(sys.argv[1])
at_first_window = sorted(name for name in later if name in sys.modules)
opened = wizard_class("clinical_test").__name__
window.close()
print(json.dumps({"at_first_window": at_first_window, "opened": opened,
                  "after": sorted(name for name in later if name in sys.modules)}))
"""


def test_the_first_window_imports_no_wizard_and_no_signal_processing(tmp_path):
    env_home = {"HOME": str(tmp_path), "XDG_CONFIG_HOME": str(tmp_path / "config"),
                "XDG_DATA_HOME": str(tmp_path / "share"), "XDG_STATE_HOME": str(tmp_path / "state")}
    done = subprocess.run([sys.executable, "-c", PROBE, json.dumps(LATER)], capture_output=True, text=True,
                          timeout=300, cwd=tmp_path, env={**os.environ, **env_home})
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found["at_first_window"] == []
    # The probe can see them: opening a wizard's class imports it and what it needs.
    assert found["opened"] == "ClinicalTestWizard"
    assert {"scipy.signal", "mimucap.gui.wizards.clinical_test"} <= set(found["after"])
