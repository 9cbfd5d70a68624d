"""Screenshots of the Analysis workspace (gait tab, ROM tab) and of the PDF report's first two
pages, on a simulated session processed like a real one (no truth in the file): the ``demo``
scenario with BNO055-like sensors, its body calibration from the N-pose/T-pose, and ROM
markers around the squats and the arm raises; and of the ROM wizard on the simulated suit
(its sensors' orientations through a body calibration made from its N-pose/T-pose). Called by
``make_screenshots.py``."""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

from PyQt5 import QtWidgets
from screenshots_common import wait as _wait

ROM_MARKERS = (
    (30.0, "rom:knee_flexion:left:start"), (37.0, "rom:knee_flexion:left:end"),
    (30.0, "rom:knee_flexion:right:start"), (37.0, "rom:knee_flexion:right:end"),
    (37.2, "rom:shoulder_flexion:left:start"), (44.9, "rom:shoulder_flexion:left:end"),
    (37.2, "rom:shoulder_flexion:right:start"), (44.9, "rom:shoulder_flexion:right:end"),
)


class _PipelineLive:
    """The parts of the live session the ROM wizard reads, from the simulated suit's sensor
    output: on-board orientations through a body calibration from its N-pose/T-pose."""

    def __init__(self) -> None:
        import numpy as np

        from mimucap.core import bodycal
        from mimucap.core.simulate.config import SimulationConfig
        from mimucap.core.simulate.suit import SuitSimulator
        from mimucap.session.events import EmitterGroup

        self.events = EmitterGroup("frame", "calibration")  # driven by hand: wizard.tick() per pose
        self.np, self.bodycal = np, bodycal
        self.simulator = SuitSimulator(SimulationConfig(scenario="bodycal", n_sensors=10, errors="bno055", seed=6))
        self.model = self.simulator.model
        block = self.simulator.advance(7.0)
        t = block.samples["S01"].t_s
        q = {sid: s.q_world_from_sensor[np.clip(np.searchsorted(s.t_s, t), 0, len(s.t_s) - 1)]
             for sid, s in block.samples.items()}
        mapping = {s.segment: sid for sid, s in block.samples.items()}
        self.body_calibration = bodycal.calibrate_npose_tpose(t, q, mapping, (0.5, 2.5), (4.6, 5.9))
        self.columns = {j: tuple(f"{j}_{a}_deg" for a in ("flexion", "adduction", "rotation"))
                        for j in self.model.joint_names}
        self.markers: list[str] = []
        self.advance()

    def advance(self) -> None:
        from mimucap.core import skeleton

        block = self.simulator.advance(0.04)
        q = {sid: s.q_world_from_sensor[-1] for sid, s in block.samples.items() if len(s.t_s)}
        segments = self.bodycal.segment_orientations(self.body_calibration, q, require_all=False)
        self.q_world_from_segment = self.bodycal.fill_missing_segments(
            segments, [(s.name, s.parent) for s in self.model.segments])
        self.time_s = float(block.truth.t_s[-1])
        self._angles = skeleton.joint_angles_deg(self.model, self.q_world_from_segment)

    @property
    def joint_names(self):
        return tuple(self.columns)

    def joint_columns(self, joint):
        return self.columns[joint]

    def joint_series(self, joint, window_s):
        return self.np.array([self.time_s]), self.np.array([[self._angles[c] for c in self.columns[joint]]])

    def instruct(self, instruction) -> None:
        from mimucap.session.sources.feeds import simulated_subject_follows

        simulated_subject_follows(self.simulator, instruction)

    def add_marker(self, label: str) -> float:
        self.markers.append(label)
        return self.time_s


def write_rom_wizard_screenshot(out_dir: Path) -> list[Path]:
    from mimucap.gui.capture import save_window_png
    from mimucap.gui.wizards.rom import RomWizard
    from mimucap.session.procedures.range_of_motion import RomProcedure, RomStep

    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(["mimucap-screenshots"])
    live = _PipelineLive()
    steps = (RomStep("shoulder_flexion", "right"), RomStep("knee_flexion", "left"))
    wizard = RomWizard(None, live, procedure=RomProcedure(steps, repeats=3))
    wizard.show()
    wizard.start_button.click()
    while wizard.procedure.state != "step_done":
        live.advance()
        wizard.tick()
        app.processEvents()
    wizard.next_button.click()
    wizard.start_button.click()
    captured = 0
    for _ in range(2000):
        live.advance()
        wizard.tick()
        app.processEvents()
        if len(wizard.procedure.peaks_deg) == 1:
            captured += 1
        if captured and wizard.procedure.active_angle_deg > 100.0:
            break
    path = save_window_png(wizard, out_dir / "rom-wizard.png")
    wizard.close()
    return [path]


def write_analysis_screenshots(app: QtWidgets.QApplication, window, out_dir: Path) -> list[Path]:
    """The Analysis workspace of main window ``window`` (gait and ROM tabs) on the simulated
    session opened in its Review workspace, the report's first two pages, and the ROM wizard."""
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.session.recorded.gait_validation import simulated_analysis

    written = []
    with tempfile.TemporaryDirectory() as scratch:
        config = SimulationConfig(scenario="demo", duration_s=45.0, n_sensors=10, errors="bno055", seed=3)
        _, analysis = simulated_analysis(config, scratch, ROM_MARKERS)
        review = window.open_review(analysis.review.path)
        _wait(app, lambda: review.ready, 60, "the review")
        window.show_workspace("analysis")
        view = window.analysis.view
        _wait(app, lambda: view.analysis is not None, 60, "the analysis")
        app.processEvents()
        written.append(window.save_screenshot(out_dir / "analysis-gait.png"))
        view.tabs.setCurrentWidget(view.rom_tab)
        view.marker_from.setCurrentIndex(next(i for i in range(view.marker_from.count())
                                              if "squat" in view.marker_from.itemText(i)))
        view.marker_to.setCurrentIndex(next(i for i in range(view.marker_to.count())
                                            if "arm raise" in view.marker_to.itemText(i)))
        view.compute_marker_rom()
        app.processEvents()
        written.append(window.save_screenshot(out_dir / "analysis-rom.png"))
        pdf = Path(scratch) / "report.pdf"
        view.notes.setText("Simulated subject; screenshot of the report.")
        view.write_report(pdf)
        if shutil.which("pdftoppm"):
            subprocess.run(["pdftoppm", "-r", "80", "-png", "-f", "1", "-l", "2", str(pdf),
                            str(out_dir / "report-page")], check=True)
            written += sorted(out_dir.glob("report-page-*.png"))
        window.review.close_recording()  # the file goes with the scratch folder
        window.show_workspace("capture")
    written += write_rom_wizard_screenshot(out_dir)
    return written
