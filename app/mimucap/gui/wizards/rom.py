"""The guided range-of-motion wizard: one movement after the other, the active joint angle in
large digits, each repetition's peak captured, repeats averaged, and the results table.

The logic is :class:`mimucap.session.procedures.range_of_motion.RomProcedure`, fed with every new pose of
the live session (its ``frame`` event: the newest joint angles and segment orientations; it
needs a body calibration, and follows the ``calibration`` event). Each step's start and end are also set as markers on the live session
(``rom:<movement>:<side>:start`` / ``:end``), so a recording running meanwhile holds them and
its analysis finds the same movements. Each movement is an instruction to the live session
(:mod:`mimucap.session.procedures.instructions`): the person reads it, the simulated subject does it.
"""

from __future__ import annotations

import math

import numpy as np
from PyQt5 import QtCore, QtWidgets

from mimucap.core.analysis import rom as rom_core
from mimucap.gui.wizards.dialog import button_row, large_label, push_button
from mimucap.gui.screen_fit import fit_on_screen
from mimucap.session.procedures import instructions
from mimucap.session.procedures.range_of_motion import RomProcedure


class RomWizard(QtWidgets.QDialog):
    """Guided ROM protocol on ``live_session`` (the main window's live pipeline)."""

    def __init__(self, parent: QtWidgets.QWidget | None, live_session, repeats: int = 3,
                 procedure: RomProcedure | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("romWizard")
        self.setWindowTitle("Range of Motion")
        fit_on_screen(self, 760, 620, parent)
        self.live = live_session
        self.procedure = procedure or RomProcedure(repeats=repeats)
        self._markers_sent = 0
        self._subject_resting = True
        self.step_label = large_label(1.6, bold=True)
        self.instruction = large_label(1.2)
        self.angle = QtWidgets.QLabel("–")
        self.angle.setObjectName("romAngle")
        self.angle.setAlignment(QtCore.Qt.AlignCenter)
        font = self.angle.font()
        font.setPointSizeF(font.pointSizeF() * 6)
        font.setBold(True)
        self.angle.setFont(font)
        self.peaks = large_label(1.2)
        self.progress = QtWidgets.QLabel("")
        self.results = QtWidgets.QTableWidget(0, 5, self)
        self.results.setHorizontalHeaderLabels(["Movement", "Active ROM (°)", "Peaks (°)", "Reference (°)", "% of ref."])
        self.results.horizontalHeader().setStretchLastSection(True)
        self.start_button = push_button("Start", self.start_step)
        self.done_button = push_button("Finish step", self.finish_step, "end the step with the repetitions so far")
        self.skip_button = push_button("Skip", self.skip_step)
        self.next_button = push_button("Next", self.next_step)
        self.close_button = push_button("Close", self.close)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(self.step_label)
        layout.addWidget(self.instruction)
        layout.addWidget(self.angle, 1)
        layout.addWidget(self.peaks)
        layout.addWidget(self.progress)
        layout.addLayout(button_row(self.start_button, self.done_button, self.skip_button, self.next_button, None,
                                    self.close_button))
        layout.addWidget(self.results, 1)
        live_session.events.frame.connect(self._pose_arrived)
        live_session.events.calibration.connect(self.refresh)
        self.refresh()

    def _pose_arrived(self, _frame_id, _geometry) -> None:
        self.tick()

    # -- the live pose ------------------------------------------------------------------------
    def _pose(self) -> tuple[float, dict, dict] | None:
        """Newest (t_s, angles column → (1,), segments → (1, 4)), or None before any pose."""
        segments = self.live.q_world_from_segment
        t = self.live.time_s
        if segments is None or not math.isfinite(t):
            return None
        angles = {}
        for joint in self.live.joint_names:
            _, values = self.live.joint_series(joint, 0.05)
            if len(values):
                for k, column in enumerate(self.live.joint_columns(joint)):
                    angles[column] = np.array([values[-1, k]])
        return t, angles, {s: np.asarray(q, dtype=float)[None, :] for s, q in segments.items()}

    def tick(self) -> None:
        """Feed the newest pose to the procedure and show its state (on every new pose)."""
        if self.live.body_calibration is None:
            self.refresh()
            return
        pose = self._pose()
        if pose is not None and self.procedure.step is not None:
            t, angles, segments = pose
            try:
                self.procedure.update(np.array([t]), angles, segments)
            except ValueError as error:  # the model lacks the joint: say so and let it be skipped
                self.instruction.setText(str(error))
        self._send_markers()
        self.refresh()

    def _send_markers(self) -> None:
        for _, label in self.procedure.markers[self._markers_sent:]:
            self.live.add_marker(label)
        self._markers_sent = len(self.procedure.markers)
        if self.procedure.state == "step_done" and not self._subject_resting:
            self._rest()

    def _rest(self) -> None:
        """The simulated subject stands still again (once per step)."""
        self._subject_resting = True
        self.live.instruct(instructions.npose())

    # -- buttons ------------------------------------------------------------------------------
    def start_step(self) -> None:
        if self.live.body_calibration is None:
            return
        step = self.procedure.step
        self.live.instruct(instructions.move_joint(step.key, step.side, step.instruction))
        self._subject_resting = False
        self.procedure.start_step(self.live.time_s)
        self._send_markers()
        self.refresh()

    def finish_step(self) -> None:
        try:
            self.procedure.finish_step_now(self.live.time_s)
        except ValueError as error:
            self.instruction.setText(str(error))
            return
        self._send_markers()
        self.refresh()

    def skip_step(self) -> None:
        self.procedure.skip_step()
        self._markers_sent = min(self._markers_sent, len(self.procedure.markers))
        if not self._subject_resting:
            self._rest()
        self.refresh()

    def next_step(self) -> None:
        self.procedure.next_step()
        self.refresh()

    # -- display ------------------------------------------------------------------------------
    def refresh(self) -> None:
        p = self.procedure
        calibrated = self.live.body_calibration is not None
        step = p.step
        self.progress.setText(f"Step {min(p.index + 1, len(p.steps))} of {len(p.steps)}")
        if not calibrated:
            self.step_label.setText("Body calibration needed")
            self.instruction.setText("Calibrate the body first (Calibrate > Body…): joint angles need it.")
        elif step is None:
            self.step_label.setText("Done")
            self.instruction.setText(p.instruction)
        else:
            self.step_label.setText(step.title)
            self.instruction.setText(p.instruction)
        value = p.active_angle_deg
        self.angle.setText("–" if not math.isfinite(value) else f"{value:.0f}°")
        peaks = ", ".join(f"{v:.0f}°" for v in p.peaks_deg)
        current = p.current_peak_deg
        self.peaks.setText(f"Peaks: {peaks or 'none yet'}" + (f"   (this repetition so far: {current:.0f}°)"
                                                               if p.state == "measuring" and math.isfinite(current) else ""))
        self.start_button.setEnabled(calibrated and p.state == "ready")
        self.done_button.setEnabled(p.state == "measuring")
        self.skip_button.setEnabled(p.state in ("ready", "measuring"))
        self.next_button.setEnabled(p.state == "step_done")
        if self.results.rowCount() != len(p.results):
            self.results.setRowCount(len(p.results))
            for row, ((key, side), r) in enumerate(p.results.items()):
                m = rom_core.movement(key)
                cells = [f"{m.label} ({side})", f"{r.active_rom_deg:.1f}", " ".join(f"{v:.0f}" for v in r.peaks_deg),
                         f"{r.reference_deg:.0f}", f"{r.percent_of_reference:.0f}"]
                for column, text in enumerate(cells):
                    self.results.setItem(row, column, QtWidgets.QTableWidgetItem(text))
            self.results.resizeColumnsToContents()

    def closeEvent(self, event) -> None:  # noqa: N802 (Qt API)
        self.live.events.frame.disconnect(self._pose_arrived)
        self.live.events.calibration.disconnect(self.refresh)
        self.live.instruct(instructions.RESUME)
        super().closeEvent(event)
