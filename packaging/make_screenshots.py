"""``make screenshots``: PNGs of every workspace of the main window, and of its dialogs and
wizards, on a clinic laptop's screen (1366 × 768).

Usage: ``python packaging/make_screenshots.py OUT_DIR [--guide GUIDE_IMG_DIR]`` under a display
of 1366 × 768 (``make screenshots`` runs it under ``Xvfb -screen 0 1366x768x24`` with
``--guide resources/guide/img``; another screen size is refused); ``--guide`` copies the user
guide's pictures (:data:`GUIDE_PICTURES`) there. Every window
opens at the size it chooses on that screen (:mod:`mimucap.gui.screen_fit`), the subject id is
fixed (P001) and the home folder is a scratch folder, so the paths in view read ``~/sessions/…``
on every run. The main window on the simulated suit (on a clock four times as fast as the
wall's) is shown before any calibration; its magnetometers and body are calibrated by the
wizards' procedures and the subject walks (the Capture workspace); a session is recorded with
two markers and shown in the Review workspace (play head on the second marker) with its export
dialog, while the live capture runs on; a simulated session with gait and range-of-motion
markers is shown in the Analysis workspace (``packaging/analysis_screenshots.py``); a library of
simulated sessions in the Library workspace, with a comparison (``library_screenshots.py``);
then Assess → Clinical Test runs a Timed Up and Go, with its report and the subject's trend
(``packaging/clinical_screenshots.py``, which also shows the offer to pair unknown devices). The
calibration wizards' pictures are added by ``packaging/wizard_screenshots.py``.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

from PyQt5 import QtWidgets
from screenshots_common import wait as _wait


#: The screen every picture is taken on: a clinic laptop's (px).
SCREEN = (1366, 768)


def _helper(script: str):
    """The helper module ``packaging/<script>.py``."""
    spec = importlib.util.spec_from_file_location(script, Path(__file__).with_name(f"{script}.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def make_screenshots(out_dir: Path) -> list[Path]:
    out_dir.mkdir(parents=True, exist_ok=True)
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(["mimucap-screenshots"])
    screen = app.primaryScreen().geometry()
    if (screen.width(), screen.height()) != SCREEN:
        raise RuntimeError(f"the screen is {screen.width()} x {screen.height()}; the screenshots are taken on "
                           f"{SCREEN[0]} x {SCREEN[1]} (xvfb-run -a -s \"-screen 0 1366x768x24\")")
    written: list[Path] = []
    with tempfile.TemporaryDirectory() as scratch:
        home = os.environ.get("HOME")
        os.environ["HOME"] = scratch  # no temporary path in view, and the user's settings untouched
        folder = Path(scratch) / "sessions"
        folder.mkdir()
        try:
            written += _every_workspace(app, out_dir, Path(scratch), folder)
            written += _helper("clinical_screenshots").write_pairing_screenshot(app, out_dir)
        finally:
            if home is None:
                os.environ.pop("HOME", None)
            else:
                os.environ["HOME"] = home
    written.extend(_helper("wizard_screenshots").write_wizard_screenshots(out_dir))
    return written


#: Simulated seconds per wall-clock second while the screenshots are made.
SPEED_UP = 4.0


def _calibrate(app: QtWidgets.QApplication, window, folder: Path) -> None:
    """The magnetometer and body calibrations, as the wizards run them, on the window's live
    session (the simulated subject does what they ask)."""
    from mimucap.io.calibration_store import CalibrationStore
    from mimucap.session.procedures.body import BodycalProcedure
    from mimucap.session.sources.calibration_feed import LiveSessionFeed
    from mimucap.session.procedures.instructions import RESUME
    from mimucap.session.procedures.magnetometer import MagcalProcedure

    live = window.live
    feed = LiveSessionFeed(live)
    try:
        magcal = MagcalProcedure(feed, live.sensor_ids, store=CalibrationStore(folder / "calibrations"))
        magcal.start()
        _wait(app, lambda: magcal.step().phase != "recording", 120, "the magnetometer turns")
        for sensor_id in magcal.accept():
            live.apply_mag_calibration(magcal.outcomes[sensor_id].result.calibration, save=False)
        mapping = {segment: sensor for sensor, segment in live.sensor_segments.items()}
        body = BodycalProcedure(feed, mapping, height_m=live.height_m)
        body.start()
        _wait(app, lambda: body.step().phase not in ("npose", "tpose"), 60, "the body calibration")
        if body.calibration is None:
            raise RuntimeError(f"the body calibration was refused: {body.refusal}")
        live.apply_body_calibration(body.calibration)
    finally:
        feed.instruct(RESUME)
        feed.close()


def _every_workspace(app: QtWidgets.QApplication, out_dir: Path, home: Path, folder: Path) -> list[Path]:
    """The main window in each workspace (recordings go to ``folder``; ``home`` is the scratch
    home folder) and the dialogs opened from them."""
    from mimucap.gui.capture import save_window_png
    from mimucap.gui.main_window import MainWindow
    from mimucap.session.live.live_session import open_live_session
    from mimucap.session.sources.fast_clock import fast_clock

    written: list[Path] = []
    clock = fast_clock(SPEED_UP)
    window = MainWindow("simulated:walk", session_factory=lambda spec: open_live_session(spec, clock=clock))
    window.recording_folder = lambda: folder
    window.confirm_recording = lambda items: True  # the checklist shows what is missing
    window.show()
    window.start()
    window.set_camera_preset("front")
    _wait(app, lambda: window.live.samples_received > 0, 20, "live data")
    window.session_panel.subject_id.setText("P001")
    start = time.monotonic()
    _wait(app, lambda: time.monotonic() - start > 2.0, 10, "the sensors' first seconds")
    written.append(window.save_screenshot(out_dir / "main-window-before-calibration.png"))
    _calibrate(app, window, folder)
    window.action_truth.setChecked(True)  # the simulator's truth beside the estimate
    start = time.monotonic()
    _wait(app, lambda: time.monotonic() - start > 1.0, 10, "walking")
    window.mode_bar.record_button.click()  # Record
    start = time.monotonic()
    _wait(app, lambda: time.monotonic() - start > 3.0, 10, "recording")
    window.session_panel.marker_label.setText("heel strike")  # typed, used once
    window.session_panel.request_marker()
    _wait(app, lambda: time.monotonic() - start > 6.0, 10, "recording")
    window.plots.set_joints(["knee_r", "hip_r"])
    window.add_marker("turn")
    window.live.publish_status()
    app.processEvents()
    written.append(window.save_screenshot(out_dir / "main-window.png"))
    _wait(app, lambda: time.monotonic() - start > 8.0, 10, "recording")
    window.mode_bar.record_button.click()  # Stop
    window.wait_for_saving()
    path = window.live.last_recording.session_path

    window.workspace_actions["review"].trigger()  # shows the recording just saved
    review = window.review.view
    if review is None or review.path != path:
        raise RuntimeError(f"Review does not show the recording just saved ({path})")
    _wait(app, lambda: review.ready or review.load_error, 60, "the review")
    review.seek_marker(1)
    _wait(app, lambda: review.scene_view.frames_rendered > 0, 10, "the review's 3D view")
    app.processEvents()
    written.append(window.save_screenshot(out_dir / "review.png"))
    dialog = review.open_export()
    dialog.range_markers.setChecked(True)
    app.processEvents()
    written.append(save_window_png(dialog, out_dir / "export-dialog.png"))
    written.append(dialog.save_summary_png(out_dir / "export-summary.png"))
    dialog.close()
    window.action_truth.setChecked(False)
    written += _helper("analysis_screenshots").write_analysis_screenshots(app, window, out_dir)
    written += _helper("library_screenshots").write_library_screenshots(app, window, home, out_dir)
    written += _helper("clinical_screenshots").write_clinical_test_screenshots(app, window, folder, out_dir)
    window.close()
    return written


#: The pictures the user guide shows (``resources/guide/img``), one per section of it.
GUIDE_PICTURES = ("main-window.png", "wizard-magnetometer-2-turn-about-y.png", "wizard-body-5-result.png",
                  "review.png", "export-dialog.png", "analysis-gait.png", "library-compare.png",
                  "clinical-test-4-result.png", "clinical-test-trend.png")


def copy_guide_pictures(out_dir: Path, guide_dir: Path) -> list[Path]:
    """Copy :data:`GUIDE_PICTURES` from ``out_dir`` to ``guide_dir`` (the guide's ``img`` folder)."""
    guide_dir.mkdir(parents=True, exist_ok=True)
    copied = []
    for name in GUIDE_PICTURES:
        copied.append(guide_dir / name)
        shutil.copyfile(out_dir / name, copied[-1])
    return copied


def main(argv: list[str]) -> int:
    if len(argv) not in (1, 3) or (len(argv) == 3 and argv[1] != "--guide"):
        print("usage: make_screenshots.py OUT_DIR [--guide GUIDE_IMG_DIR]", file=sys.stderr)
        return 2
    out_dir = Path(argv[0])
    for path in make_screenshots(out_dir):
        print(path)
    if len(argv) == 3:
        for path in copy_guide_pictures(out_dir, Path(argv[2])):
            print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
