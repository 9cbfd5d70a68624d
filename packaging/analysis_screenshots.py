"""Screenshots of the Analysis window (gait tab, ROM tab) and of the PDF report's first two
pages, on a simulated session processed like a real one (no truth in the file): the ``demo``
scenario with BNO055-like sensors, its body calibration from the N-pose/T-pose, and ROM
markers around the squats and the arm raises. Called by ``make_screenshots.py``."""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from PyQt5 import QtCore, QtWidgets

ROM_MARKERS = (
    (30.0, "rom:knee_flexion:left:start"), (37.0, "rom:knee_flexion:left:end"),
    (30.0, "rom:knee_flexion:right:start"), (37.0, "rom:knee_flexion:right:end"),
    (37.2, "rom:shoulder_flexion:left:start"), (44.9, "rom:shoulder_flexion:left:end"),
    (37.2, "rom:shoulder_flexion:right:start"), (44.9, "rom:shoulder_flexion:right:end"),
)


def _wait(app, condition, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise RuntimeError(f"timed out waiting for {what}")
        app.processEvents(QtCore.QEventLoop.AllEvents, 20)


def write_analysis_screenshots(out_dir: Path) -> list[Path]:
    from mimucap.core.simulate import SimulationConfig
    from mimucap.gui.capture import save_window_png
    from mimucap.gui.review_window import ReviewWindow
    from mimucap.session.analysis_evaluation import simulated_analysis

    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(["mimucap-screenshots"])
    written = []
    with tempfile.TemporaryDirectory() as scratch:
        config = SimulationConfig(scenario="demo", duration_s=45.0, n_sensors=10, errors="bno055", seed=3)
        _, analysis = simulated_analysis(config, scratch, ROM_MARKERS)
        review = ReviewWindow(analysis.review.path)
        review.show()
        review.load()
        _wait(app, lambda: review.player is not None, 60, "the review")
        window = review.open_analysis()
        _wait(app, lambda: window.analysis is not None, 60, "the analysis")
        window.resize(1400, 860)
        app.processEvents()
        written.append(save_window_png(window, out_dir / "analysis-gait.png"))
        window.tabs.setCurrentWidget(window.rom_tab)
        window.marker_from.setCurrentIndex(next(i for i in range(window.marker_from.count())
                                                if "activity:squat" in window.marker_from.itemText(i)))
        window.marker_to.setCurrentIndex(next(i for i in range(window.marker_to.count())
                                              if "activity:arm_raise" in window.marker_to.itemText(i)))
        window.compute_marker_rom()
        app.processEvents()
        written.append(save_window_png(window, out_dir / "analysis-rom.png"))
        pdf = Path(scratch) / "report.pdf"
        window.notes.setText("Simulated subject; screenshot of the report.")
        window.write_report(pdf)
        if shutil.which("pdftoppm"):
            subprocess.run(["pdftoppm", "-r", "80", "-png", "-f", "1", "-l", "2", str(pdf),
                            str(out_dir / "report-page")], check=True)
            written += sorted(out_dir.glob("report-page-*.png"))
        window.close()
        review.close()
    return written
