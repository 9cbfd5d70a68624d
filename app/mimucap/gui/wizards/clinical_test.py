"""Assess → Clinical Test: a standard clinical test run guided in the window, recorded, and its
result from the sensors beside the published reference.

Three pages: the test with what to prepare and say and its settings (walkway, chair seat; the
subject's age, sex and weight, which the references depend on); the run (the countdown, the
start signal, the time, the clinician's own start and stop); the result. The run is
:class:`mimucap.session.procedures.clinical_test.ClinicalTestProcedure`, fed with every new pose
of the live session (its ``frame`` event); the recording goes through the main window's own
(:meth:`MainWindow.start_recording`, the checklist included) and the result is computed from the
saved session file by :func:`mimucap.session.recorded.clinical_tests.run_clinical_test`, the path the
``protocol`` command takes, in a background thread. The result is kept in the library
(:meth:`mimucap.io.library.Library.store_result`, name ``clinical_test:<test>``) for the trend
of the subject's visits.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

from PyQt5 import QtCore, QtWidgets

from mimucap.gui.background_task import BackgroundTask
from mimucap.gui.wizards.dialog import button_row, large_label, push_button
from mimucap.gui.screen_fit import fit_on_screen
from mimucap.gui.session_panel import display_path
from mimucap.io.session import SEXES
from mimucap.session.procedures import instructions
from mimucap.session.procedures.clinical_test import GUIDES, ClinicalTestProcedure
from mimucap.session.recorded.clinical_test_results import result_rows, start_text, store_in_library

log = logging.getLogger(__name__)


class ClinicalTestWizard(QtWidgets.QDialog):
    """Guided clinical test on ``live_session``; ``parent`` is the main window (it records, and
    says when a recording is saved: ``recording_saved``)."""

    #: the result is shown (its :class:`~mimucap.session.recorded.clinical_tests.ClinicalTestResult`)
    result_ready = QtCore.pyqtSignal(object)

    def __init__(self, parent, live_session) -> None:
        super().__init__(parent)
        self.setObjectName("clinicalTestWizard")
        self.setWindowTitle("Clinical Test")
        self.main_window = parent
        self.live = live_session
        self.procedure: ClinicalTestProcedure | None = None
        self._last_pose_t = -math.inf  # the newest pose the procedure has seen (session s)
        self.result = None
        self.session_path: Path | None = None
        self._markers_sent = 0
        self._task: BackgroundTask | None = None
        self.pages = QtWidgets.QStackedWidget(self)
        self.pages.addWidget(self._choose_page())
        self.pages.addWidget(self._run_page())
        self.pages.addWidget(self._result_page())
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(self.pages)
        fit_on_screen(self, 720, 560, parent)
        live_session.events.frame.connect(self._pose_arrived)
        live_session.events.calibration.connect(self._refresh_choice)
        parent.recording_saved.connect(self._recording_saved)
        self._test_chosen()

    # -- pages --------------------------------------------------------------------------------
    def _choose_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        self.test_combo = QtWidgets.QComboBox(page)
        self.test_combo.setObjectName("clinicalTestChoice")
        for test, guide in GUIDES.items():
            self.test_combo.addItem(guide.name, test)
        self.test_combo.currentIndexChanged.connect(self._test_chosen)
        self.setup_text = QtWidgets.QLabel(page)
        self.setup_text.setWordWrap(True)
        self.say_text = QtWidgets.QLabel(page)
        self.say_text.setWordWrap(True)
        self.walkway = QtWidgets.QDoubleSpinBox(page)
        self.walkway.setRange(1.0, 100.0)
        self.walkway.setDecimals(1)
        self.walkway.setSuffix(" m")
        self.chair = QtWidgets.QDoubleSpinBox(page)
        self.chair.setRange(30.0, 70.0)
        self.chair.setDecimals(0)
        self.chair.setSuffix(" cm")
        self.age = QtWidgets.QSpinBox(page)
        self.age.setRange(0, 110)
        self.age.setSpecialValueText("not given")
        self.age.setSuffix(" years")
        self.sex = QtWidgets.QComboBox(page)
        self.sex.addItem("not given", "")
        for sex in SEXES:
            self.sex.addItem(sex, sex)
        self.weight = QtWidgets.QSpinBox(page)
        self.weight.setRange(0, 250)
        self.weight.setSpecialValueText("not given")
        self.weight.setSuffix(" kg")
        form = self._settings_form = QtWidgets.QFormLayout()
        form.addRow("Test", self.test_combo)
        form.addRow("Prepare", self.setup_text)
        form.addRow("Say", self.say_text)
        form.addRow("Walkway", self.walkway)
        form.addRow("Chair seat height", self.chair)
        form.addRow("Age", self.age)
        form.addRow("Sex", self.sex)
        form.addRow("Weight", self.weight)
        self.choice_status = QtWidgets.QLabel(page)
        self.choice_status.setWordWrap(True)
        self.ready_button = push_button("Get Ready", self.get_ready, "the subject takes the starting position")
        self.ready_button.setObjectName("clinicalTestReady")
        layout = QtWidgets.QVBoxLayout(page)
        layout.addLayout(form)
        layout.addWidget(self.choice_status)
        layout.addStretch(1)
        layout.addLayout(button_row(None, self.ready_button, push_button("Close", self.close)))
        return page

    def _run_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        self.run_title = large_label(1.4, bold=True)
        self.run_instruction = large_label(1.15)
        self.clock = QtWidgets.QLabel("")
        self.clock.setObjectName("clinicalTestClock")
        self.clock.setAlignment(QtCore.Qt.AlignCenter)
        font = self.clock.font()
        font.setPointSizeF(font.pointSizeF() * 6)
        font.setBold(True)
        self.clock.setFont(font)
        self.run_note = QtWidgets.QLabel("")
        self.run_note.setWordWrap(True)
        self.countdown_button = push_button("Start Countdown", self.start_countdown,
                                            "recording starts, then 3-2-1 and the start signal")
        self.mark_start_button = push_button("Mark Start", self.mark_start,
                                             "the test started now (instead of where the sensors show it)")
        self.stop_button = push_button("Stop Test", self.stop_test, "the test ended now")
        self.cancel_button = push_button("Cancel", self.cancel)
        layout = QtWidgets.QVBoxLayout(page)
        layout.addWidget(self.run_title)
        layout.addWidget(self.run_instruction)
        layout.addWidget(self.clock, 1)
        layout.addWidget(self.run_note)
        layout.addLayout(button_row(self.countdown_button, self.mark_start_button, self.stop_button, None,
                                    self.cancel_button))
        return page

    def _result_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        self.result_title = large_label(1.4, bold=True)
        self.result_status = QtWidgets.QLabel("")
        self.result_status.setWordWrap(True)
        self.result_table = QtWidgets.QTableWidget(0, 3, page)
        self.result_table.setObjectName("clinicalTestResults")
        self.result_table.setHorizontalHeaderLabels(["Result", "Value", "Reference"])
        self.result_table.verticalHeader().setVisible(False)
        self.result_table.setEditTriggers(QtWidgets.QAbstractItemView.NoEditTriggers)
        self.result_table.horizontalHeader().setSectionResizeMode(0, QtWidgets.QHeaderView.ResizeToContents)
        self.result_table.horizontalHeader().setSectionResizeMode(1, QtWidgets.QHeaderView.ResizeToContents)
        self.result_table.horizontalHeader().setSectionResizeMode(2, QtWidgets.QHeaderView.Stretch)
        self.result_notes = QtWidgets.QLabel("")
        self.result_notes.setWordWrap(True)
        self.report_button = push_button("Save Report…", self.save_report)
        self.review_button = push_button("Review", self.open_review)
        again = push_button("Run Again", self.run_again)
        layout = QtWidgets.QVBoxLayout(page)
        layout.addWidget(self.result_title)
        layout.addWidget(self.result_status)
        layout.addWidget(self.result_table, 1)
        layout.addWidget(self.result_notes)
        layout.addLayout(button_row(self.report_button, self.review_button, None, again, push_button("Close", self.close)))
        return page

    # -- choosing -----------------------------------------------------------------------------
    @property
    def test(self) -> str:
        return str(self.test_combo.currentData())

    def choose(self, test: str) -> None:
        self.test_combo.setCurrentIndex(self.test_combo.findData(test))

    def _test_chosen(self, *_args) -> None:
        guide = GUIDES[self.test]
        self.setup_text.setText(guide.setup)
        self.say_text.setText(guide.say)
        defaults = ClinicalTestProcedure(self.test)
        self.walkway.setValue(defaults.walkway_m)
        self.chair.setValue(defaults.chair_height_cm)
        form = self._settings_form
        for widget, shown in ((self.walkway, guide.walkway), (self.chair, guide.chair)):
            widget.setVisible(shown)
            form.labelForField(widget).setVisible(shown)
        self._refresh_choice()

    def _refresh_choice(self, *_args) -> None:
        calibrated = self.live.body_calibration is not None
        recording = self.live.recording
        if not calibrated:
            self.choice_status.setText("Calibrate the body first (Calibrate → Body…): the test's phases and "
                                       "distances come from the segments.")
        elif recording:
            self.choice_status.setText("A recording is running: stop it first; the test records a session of its own.")
        else:
            self.choice_status.setText("The test is recorded as a session in the library, with its settings.")
        self.ready_button.setEnabled(calibrated and not recording and self.procedure is None)

    def subject_details(self) -> dict:
        """Age, sex and weight given here, for the subject record (the references need them)."""
        details: dict = {}
        if self.age.value() > 0:
            details["age_years"] = float(self.age.value())
        if self.sex.currentData():
            details["sex"] = str(self.sex.currentData())
        if self.weight.value() > 0:
            details["weight_kg"] = float(self.weight.value())
        return details

    def get_ready(self) -> None:
        """The subject takes the starting position (the simulated subject sits down or stands at the line)."""
        try:
            self.procedure = ClinicalTestProcedure(self.test, self.walkway.value(), self.chair.value())
        except ValueError as error:
            self.choice_status.setText(str(error))
            return
        self._markers_sent = 0
        self.live.instruct(self.procedure.instruction())
        self.pages.setCurrentIndex(1)
        self._refresh_run()

    # -- the run ------------------------------------------------------------------------------
    def start_countdown(self) -> None:
        procedure = self.procedure
        if procedure is None or procedure.state != "ready":
            return
        if not self.main_window.start_recording({"clinical_test": procedure.metadata()}, self.subject_details()):
            self.run_note.setText("Not recording: the test did not start.")
            return
        procedure.start_countdown(self.live.time_s)
        self._last_pose_t = self.live.time_s
        self._refresh_run()

    def _pose_arrived(self, _frame_id, _geometry) -> None:
        procedure = self.procedure
        if procedure is None or procedure.state in ("ready", "done"):
            return
        was = procedure.state
        self._follow_poses(procedure)
        if was == "countdown" and procedure.state == "running":
            self.live.instruct(procedure.instruction())
        self._send_markers()
        if procedure.state == "done":
            self._finish()
        self._refresh_run()

    def _follow_poses(self, procedure: ClinicalTestProcedure) -> None:
        """Step the procedure over every pose since the last frame, not only the newest: a
        frame drawn late (a busy machine) must not hide the walk that starts or ends a test."""
        live = self.live
        if live.body_calibration is None:
            procedure.update(live.time_s, None)
            return
        found = live.poses_after(self._last_pose_t)
        if found is None:  # no new pose: the countdown and a timed test still run on the clock
            procedure.update(live.time_s, None)
            return
        t_pose, q_segments = found
        self._last_pose_t = float(t_pose[-1])
        for index, t_s in enumerate(t_pose):
            state = procedure.state
            procedure.update(float(t_s), {name: q[index] for name, q in q_segments.items()})
            if procedure.state != state and procedure.state == "done":
                break

    def _send_markers(self) -> None:
        for _t, label in self.procedure.markers[self._markers_sent:]:
            if self.live.recording:
                self.live.add_marker(label)
        self._markers_sent = len(self.procedure.markers)

    def mark_start(self) -> None:
        if self.procedure is not None and self.procedure.state == "running":
            self.procedure.mark_start(self.live.time_s)
            self._send_markers()
            self._refresh_run()

    def stop_test(self) -> None:
        procedure = self.procedure
        if procedure is None or procedure.state not in ("countdown", "running"):
            return
        started = procedure.state == "running"
        procedure.stop(self.live.time_s)
        self._send_markers()
        if started:
            self._finish()
        else:
            self.cancel()

    def cancel(self) -> None:
        """Back to the choice; a recording already started is stopped and kept (it is named in
        the library like any other)."""
        self.procedure = None
        if self.live.recording:
            self.main_window.stop_recording()
        self.live.instruct(instructions.RESUME)
        self.pages.setCurrentIndex(0)
        self._refresh_choice()

    def _finish(self) -> None:
        self.live.instruct(instructions.RESUME)
        self.result_title.setText(self.procedure.guide.name)
        self.result_status.setText("Saving the session…")
        self.result_table.setRowCount(0)
        self.result_notes.setText("")
        self.report_button.setEnabled(False)
        self.review_button.setEnabled(False)
        self.pages.setCurrentIndex(2)
        self.main_window.stop_recording()

    def _refresh_run(self) -> None:
        procedure = self.procedure
        if procedure is None:
            return
        guide = procedure.guide
        t = self.live.time_s
        self.run_title.setText(guide.name)
        state = procedure.state
        if state == "ready":
            self.run_instruction.setText(f"{procedure.instruction().text}. Then say: {guide.say}")
            self.clock.setText("Ready")
        elif state == "countdown":
            self.run_instruction.setText("Recording. The start signal comes at zero: say “Go!”.")
            self.clock.setText(f"{math.ceil(procedure.countdown_left_s(t)):.0f}")
        elif state == "running":
            remaining = procedure.remaining_s(t)
            seconds = procedure.elapsed_s(t) if remaining is None else remaining
            minutes, rest = divmod(int(seconds), 60)
            self.clock.setText(f"{minutes}:{rest:02d}")
            self.run_instruction.setText("Go! " + ("Time left." if remaining is not None else
                                                   "The recording ends when the subject is "
                                                   + ("seated again." if guide.test == "tug" else "standing still again.")))
        manual = [label for _t, label in procedure.markers if label in ("test start", "test stop")]
        self.run_note.setText("Marked by you: " + ", ".join(manual) if manual else
                              "The start is found from the sensors; Mark Start overrides it.")
        self.countdown_button.setEnabled(state == "ready")
        self.mark_start_button.setEnabled(state == "running")
        self.stop_button.setEnabled(state in ("countdown", "running"))

    # -- the result ---------------------------------------------------------------------------
    def _recording_saved(self, recording) -> None:
        procedure = self.procedure
        if procedure is None or procedure.state != "done" or recording.session_path is None:
            return
        self.session_path = Path(recording.session_path)
        self.result_status.setText(f"Computing the result from {self.session_path.name}…")
        from mimucap.session.recorded.clinical_tests import run_clinical_test

        test, path = procedure.test, self.session_path
        self._task = BackgroundTask(lambda progress: run_clinical_test(path, test, progress=progress), self)
        self._task.succeeded.connect(self._show_result)
        self._task.failed.connect(self._result_failed)
        self._task.start()

    def _show_result(self, result) -> None:
        self.result = result
        self.result_status.setText(f"Timed from {start_text(result.started_by)}; {self.session_path.name}, "
                                   f"{result.result.replace('_', ' ')}.")
        rows = result_rows(result)
        self.result_table.setRowCount(len(rows))
        for row, cells in enumerate(rows):
            for column, text in enumerate(cells):
                item = QtWidgets.QTableWidgetItem(text)
                if column == 1:
                    item.setTextAlignment(int(QtCore.Qt.AlignRight | QtCore.Qt.AlignVCenter))
                self.result_table.setItem(row, column, item)
        self.result_table.resizeRowsToContents()
        notes = []
        if result.reference is None:
            notes.append(f"No reference: {result.reference_note}.")
        else:
            notes.append(f"Reference: {result.reference['group']}, {result.reference['statistic']} "
                         f"({result.reference['source']}).")
        library = self.main_window.library_folder()
        stored = store_in_library(self.session_path, result, library)
        if stored:
            notes.append(stored.replace(str(library), display_path(library)))  # the home folder as ~, as elsewhere
        self.result_notes.setText(" ".join(notes))
        self.report_button.setEnabled(True)
        self.review_button.setEnabled(True)
        self.result_ready.emit(result)

    def _result_failed(self, message: str) -> None:
        self.result_status.setText(f"No result: {message}")
        self.review_button.setEnabled(self.session_path is not None)

    def save_report(self) -> None:
        if self.result is None or self.session_path is None:
            return
        suggested = str(self.session_path.with_name(f"{self.session_path.stem}_{self.result.test}_report.pdf"))
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save Report", suggested, "PDF (*.pdf)")
        if path:
            self.write_report(path)

    def write_report(self, path: str | Path) -> Path:
        """The test's report page (with the subject's earlier visits from the library) as a PDF."""
        from mimucap.gui.pdf_report import write_clinical_test_report
        from mimucap.session.recorded.clinical_test_results import earlier_results

        earlier = earlier_results(self.session_path, self.result.test, self.main_window.library_folder())
        written = write_clinical_test_report(path, self.result, earlier)
        self.result_notes.setText(self.result_notes.text() + f" Report saved to {written}.")
        return written

    def open_review(self) -> None:
        if self.session_path is not None:
            self.main_window.open_review(self.session_path)

    def run_again(self) -> None:
        self.procedure = None
        self.result = None
        self.pages.setCurrentIndex(0)
        self._refresh_choice()

    def closeEvent(self, event) -> None:  # noqa: N802 (Qt API)
        if self.procedure is not None and self.procedure.state in ("countdown", "running"):
            self.procedure.stop(self.live.time_s)
            self._send_markers()
            self.main_window.stop_recording()
        self.live.events.frame.disconnect(self._pose_arrived)
        self.live.events.calibration.disconnect(self._refresh_choice)
        self.main_window.recording_saved.disconnect(self._recording_saved)
        self.live.instruct(instructions.RESUME)
        if self._task is not None:
            self._task.wait()
        super().closeEvent(event)
