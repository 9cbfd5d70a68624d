"""``mimucap gui``: the screenshot command shows the skeleton; no display gives one clear line."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
from PyQt5 import QtGui

from mimucap.gui.main_window import WINDOW_SIZE_PX

MESSAGE = "mimucap gui: no display found; run it under a virtual screen: xvfb-run -a mimucap gui"


#: Height of the main window's status bar at the bottom of a screenshot (px), with margin.
STATUS_BAR_PX = 30


def _pixels(path) -> np.ndarray:
    image = QtGui.QImage(str(path)).convertToFormat(QtGui.QImage.Format_RGB888)
    ptr = image.constBits()
    ptr.setsize(image.byteCount())
    rows = np.frombuffer(ptr, np.uint8).reshape(image.height(), image.bytesPerLine())
    return rows[:, : 3 * image.width()].reshape(image.height(), image.width(), 3).astype(int)


def assert_shows_the_uncalibrated_skeleton(path) -> None:
    """The screenshot at ``path`` is the main window (:data:`WINDOW_SIZE_PX` on the test screen,
    which has room for it) with the simulated suit's
    figure in the middle of its 3D view. Before a magnetometer calibration the figure is tinted
    amber (sensors "magnetometer not calibrated"): far redder than the grey floor and the slate
    background. Its pixels sit in the middle of the 3D view, below the menu bar."""
    pixels = _pixels(path)
    height, width, _ = pixels.shape
    assert (width, height) == WINDOW_SIZE_PX
    amber = (pixels[..., 0].astype(int) - pixels[..., 2]) > 60
    amber[height - STATUS_BAR_PX:] = False  # the status bar's warnings are orange too
    rows, cols = np.nonzero(amber)
    assert rows.size > 2000
    assert 0.3 * width < np.median(cols) < 0.7 * width
    assert rows.min() > 20 and rows.max() < height - STATUS_BAR_PX - 20


def test_screenshot_command_shows_the_skeleton(tmp_path):
    out = tmp_path / "main.png"
    done = subprocess.run(
        [sys.executable, "-m", "mimucap", "gui", "--source", "simulated", "--screenshot", str(out), "--after", "1.5"],
        capture_output=True, text=True, timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert_shows_the_uncalibrated_skeleton(out)


def test_no_display_prints_one_line_and_exits_1():
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM")}
    done = subprocess.run([sys.executable, "-m", "mimucap", "gui"], capture_output=True, text=True, env=env, timeout=60)
    assert done.returncode == 1
    assert (done.stdout + done.stderr).strip() == MESSAGE


def test_a_missing_replay_file_is_one_clear_line(tmp_path):
    missing = tmp_path / "gone.h5"
    done = subprocess.run(
        [sys.executable, "-m", "mimucap", "gui", "--source", f"replay:{missing}", "--screenshot", str(tmp_path / "x.png")],
        capture_output=True, text=True, timeout=120,
    )
    assert done.returncode == 1
    lines = [line for line in done.stderr.splitlines() if line.startswith("mimucap")]
    assert lines == [f"mimucap gui: error: cannot open source replay:{missing}: replay file {missing} does not exist"]
    assert not (tmp_path / "x.png").exists()


def test_a_remembered_source_that_went_away_falls_back_to_the_simulated_suit(qtbot, tmp_path):
    from mimucap.gui.main_window import MainWindow
    from mimucap.gui.settings import gui_settings

    settings = gui_settings()
    settings.setValue("source/spec", f"replay:{tmp_path / 'gone.h5'}")
    settings.sync()
    window = MainWindow()
    try:
        assert window.live.label == "simulated:demo"
        assert "gone.h5" in window.source_error
    finally:
        window.close()


def test_review_option_opens_the_session_and_a_missing_file_is_one_line(tmp_path):
    session = tmp_path / "walk.h5"
    made = subprocess.run([sys.executable, "-m", "mimucap", "simulate", "--scenario", "walk", "--duration", "3",
                           "--out", str(session)], capture_output=True, text=True, timeout=120)
    assert made.returncode == 0, made.stderr
    out = tmp_path / "review.png"
    done = subprocess.run(
        [sys.executable, "-m", "mimucap", "gui", "--source", "simulated", "--review", str(session),
         "--screenshot", str(out), "--after", "1.5"],
        capture_output=True, text=True, timeout=120,
    )
    assert done.returncode == 0, done.stderr
    pixels = _pixels(out)
    blue = (pixels[..., 2] - pixels[..., 0]) > 60  # the figure, shown in the Review workspace
    assert np.count_nonzero(blue) > 2000
    missing = tmp_path / "gone.h5"
    done = subprocess.run([sys.executable, "-m", "mimucap", "gui", "--review", str(missing)],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 1
    assert done.stderr.strip() == f"mimucap gui: error: session file not found: {missing}"
