"""The body-calibration wizard: subject and mapping, N-pose, T-pose (or a walk), result.

Pages (:attr:`BodyCalibrationWizard.page_name`):

* ``"setup"``: subject height (prefilled from the session), the method (N-pose and T-pose,
  or "no T-pose": stand still, then walk or bend the elbows, for a patient who cannot raise
  the arms), which arm(s) will do the T-pose, and the sensor mapping (segment → sensor id,
  one combo box per segment).
* ``"pose"``: N-pose, then T-pose: the picture of the pose, the instruction, a countdown
  while the averaged window fills, and the stillness meter (a bar that turns green when the
  subject holds still); movement restarts the capture with a message. Without a T-pose, the
  still N-pose, then the walk with its countdown (the movement's axes are found after it).
* ``"result"``: the skeleton in the calibrated N-pose (VTK, the main window's figure
  actors) next to the quality figures (arm raise and rotation angles, axis tilt, left/right
  agreement, stillness; without a T-pose, how well the movement defined each axis, in words)
  and the verdict with its reasons. Accept applies the calibration to
  the live pipeline (``live_session.apply_body_calibration`` when the pipeline has it) and
  emits :attr:`BodyCalibrationWizard.calibration_accepted`.
* ``"refused"``: why the capture was refused, Change settings, Close and Redo.

A sensor mapping changed on the setup page is never dropped silently: closing the wizard
without accepting a calibration asks whether to keep it (applied to the live session as its
sensor assignment) or discard it (:attr:`BodyCalibrationWizard.ask_about_assignment`);
accepting a calibration applies the mapping with it.

The logic is :class:`mimucap.session.procedures.body.BodycalProcedure`: the feed's ``arrived``
event steps it and the pages show each status it tells
(:meth:`~mimucap.gui.wizards.dialog.CalibrationDialog.follow`); nothing polls.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from PyQt5 import QtCore, QtWidgets

from mimucap.core import skeleton
from mimucap.core.clinical_names import in_clinical_words, segment_name
from mimucap.gui.assignment_dialog import remember_assignment
from mimucap.core.simulate.suit import SuitSimulator
from mimucap.gui.scene.view import SceneView
from mimucap.gui.screen_fit import fit_on_screen
from mimucap.gui.simulated_suit_clock import SimulatedSuitClock
from mimucap.gui.wizards.pictures import PictureWidget
from mimucap.gui.wizards.dialog import CalibrationDialog, button_row, large_label, push_button
from mimucap.session.procedures.body import ARMS, METHODS, BodycalProcedure, BodycalProcedureSettings
from mimucap.session.procedures import instructions
from mimucap.session.sources.calibration_feed import CalibrationFeed, SimulatedSuitFeed, feed_for_live_session
from mimucap.session.views.skeleton_figure import FigureBuilder

VERDICT_COLOURS = {"good": "#2ca02c", "acceptable": "#e08a00", "poor": "#d62728"}
ARM_LABELS = {"both": "Both arms", "right": "Right arm only", "left": "Left arm only"}
METHOD_LABELS = {"npose-tpose": "N-pose, then T-pose",
                 "functional": "No T-pose: stand still, then walk (or bend the elbows)"}
#: Page titles of each method's steps.
STEP_TITLES = {"npose-tpose": {"npose": "Step 1 of 2: N-pose", "tpose": "Step 2 of 2: T-pose"},
               "functional": {"npose": "Step 1 of 2: stand still", "movement": "Step 2 of 2: walk"}}
#: Full scale of the stillness meter (degrees turned within the meter window).
METER_FULL_SCALE_DEG = 10.0
NO_SENSOR = "(none)"


class BodyCalibrationWizard(CalibrationDialog):
    """Guided N-pose/T-pose body calibration.

    ``live_session``: the main window's live session (whose assignment the setup page shows and
    changes, and where an accepted calibration goes; ``None``: the calibration is only told);
    ``feed``: where the samples come from (default: the live session's). ``model``, ``mapping``
    (segment → sensor id prefilled on the setup page) and ``height_m`` default to the live
    session's, else the feed's. ``settings``: the procedure's settings.
    """

    calibration_accepted = QtCore.pyqtSignal(object)

    def __init__(
        self,
        parent: QtWidgets.QWidget | None,
        live_session: object | None = None,
        *,
        feed: CalibrationFeed | None = None,
        model: skeleton.SkeletonModel | None = None,
        mapping: Mapping[str, str] | None = None,
        height_m: float | None = None,
        settings: BodycalProcedureSettings = BodycalProcedureSettings(),
    ) -> None:
        super().__init__(parent)
        #: the main window's live session: the assignment is its to keep, and the calibration
        #: its to apply (a feed's own session is the wizard's alone)
        self.live_session = live_session
        if feed is None:
            if live_session is None:
                raise ValueError("the body calibration wizard needs a live session or a feed")
            feed = feed_for_live_session(live_session)
        self.feed = feed
        self.model = model if model is not None else feed.model
        if mapping is None:
            worn = (live_session if live_session is not None else feed).sensor_segments
            mapping = {segment: sid for sid, segment in worn.items() if segment}
        self.initial_mapping = dict(mapping)
        if height_m is None:
            height_m = feed.height_m
        self.settings = settings
        self.procedure: BodycalProcedure | None = None
        self.accepted_calibration = None
        #: True once the mapping of the setup page was applied or discarded (asked at most once)
        self.assignment_settled = False
        #: Asked when the wizard closes with a changed mapping: returns "keep", "discard" or
        #: "cancel" (stay open). Tests and scripts may replace it.
        self.ask_about_assignment = self._ask_about_assignment
        self.setWindowTitle("Body calibration")
        fit_on_screen(self, 1180, 760, parent)

        self.pages = QtWidgets.QStackedWidget()
        self.setup_page = self._build_setup(height_m)
        self.pose_page = self._build_pose()
        self.result_page = self._build_result()
        self.refused_page = self._build_refused()
        for page in (self.setup_page, self.pose_page, self.result_page, self.refused_page):
            self.pages.addWidget(page)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(self.pages)
        self.set_page_defaults(self.pages, {self.setup_page: self.start_button,
                                            self.result_page: self.accept_button})

    @classmethod
    def for_simulator(
        cls, simulator: SuitSimulator, parent: QtWidgets.QWidget | None = None, step_s: float = 0.1,
        feed: SimulatedSuitFeed | None = None, tick_ms: int = 40, **kwargs,
    ) -> BodyCalibrationWizard:
        """A wizard on a simulated suit (its sensors' labels prefill the mapping), ``step_s`` simulated
        seconds every ``tick_ms`` ms (:class:`~mimucap.gui.simulated_suit_clock.SimulatedSuitClock`);
        pass ``feed`` to reuse one (e.g. with magnetometer calibrations)."""
        feed = feed if feed is not None else SimulatedSuitFeed(simulator, step_s=step_s)
        wizard = cls(parent, None, feed=feed, model=simulator.model, **kwargs)
        wizard.clock = SimulatedSuitClock(feed, tick_ms, wizard)
        return wizard

    # -- pages -------------------------------------------------------------------------------
    def _build_setup(self, height_m: float) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        intro = QtWidgets.QLabel(
            "<h2>Body calibration</h2><p>The subject stands upright with the arms hanging (N-pose), "
            "then raises the chosen arm(s) sideways to shoulder height (T-pose). Each pose is held "
            f"still for {self.settings.hold_s:g} s; the wizard captures it by itself.</p><p>A patient who "
            "cannot raise the arms: choose <i>No T-pose</i>. The subject stands still, then walks (or, "
            f"seated, bends both elbows a few times) for {self.settings.movement_s:g} s; the knees' and "
            "elbows' axes come from the movement.</p>")
        intro.setWordWrap(True)
        layout.addWidget(intro)
        form = QtWidgets.QFormLayout()
        self.height_spin = QtWidgets.QDoubleSpinBox()
        self.height_spin.setRange(0.5, 2.5)
        self.height_spin.setDecimals(2)
        self.height_spin.setSingleStep(0.01)
        self.height_spin.setSuffix(" m")
        self.height_spin.setValue(height_m)
        form.addRow("Subject height", self.height_spin)
        self.method_combo = QtWidgets.QComboBox()
        for method in METHODS:
            self.method_combo.addItem(METHOD_LABELS[method], method)
        form.addRow("Method", self.method_combo)
        self.arms_combo = QtWidgets.QComboBox()
        for arms in ARMS:
            self.arms_combo.addItem(ARM_LABELS[arms], arms)
        form.addRow("T-pose with", self.arms_combo)
        self.method_combo.currentIndexChanged.connect(
            lambda: self.arms_combo.setEnabled(self.method_combo.currentData() == "npose-tpose"))
        layout.addLayout(form)
        layout.addWidget(QtWidgets.QLabel("<b>Sensor on each segment</b>"))
        self.mapping_table = QtWidgets.QTableWidget(len(self.model.segment_names), 2)
        self.mapping_table.setHorizontalHeaderLabels(["Segment", "Sensor"])
        self.mapping_table.verticalHeader().setVisible(False)
        self.mapping_table.horizontalHeader().setStretchLastSection(True)
        self.mapping_combos: dict[str, QtWidgets.QComboBox] = {}
        for row, segment in enumerate(self.model.segment_names):
            self.mapping_table.setItem(row, 0, QtWidgets.QTableWidgetItem(segment_name(segment)))
            combo = QtWidgets.QComboBox()
            combo.addItems([NO_SENSOR, *self.feed.sensor_ids])
            combo.setCurrentText(self.initial_mapping.get(segment, NO_SENSOR))
            self.mapping_table.setCellWidget(row, 1, combo)
            self.mapping_combos[segment] = combo
        self.mapping_table.resizeColumnToContents(0)  # whole segment names ("Right upper arm")
        layout.addWidget(self.mapping_table, 1)
        self.setup_error = QtWidgets.QLabel("")
        self.setup_error.setWordWrap(True)
        self.setup_error.setStyleSheet("color: #d62728")
        layout.addWidget(self.setup_error)
        self.start_button = push_button("Start", self.start)
        layout.addLayout(button_row(None, push_button("Close", self.reject), self.start_button))
        return page

    def _build_pose(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        outer = QtWidgets.QHBoxLayout(page)
        self.pose_picture = PictureWidget()
        self.pose_picture.setMinimumSize(420, 420)
        outer.addWidget(self.pose_picture, 3)
        side = QtWidgets.QVBoxLayout()
        self.pose_title = QtWidgets.QLabel("<h2>Step 1 of 2: N-pose</h2>")
        side.addWidget(self.pose_title)
        self.pose_instruction = large_label()
        side.addWidget(self.pose_instruction)
        self.countdown = large_label(4.0, bold=True, wrap=False)
        self.countdown.setAlignment(QtCore.Qt.AlignCenter)
        side.addWidget(self.countdown)
        side.addWidget(QtWidgets.QLabel("<b>Stillness</b>"))
        self.meter = QtWidgets.QProgressBar()
        self.meter.setRange(0, 100)
        self.meter.setTextVisible(True)
        side.addWidget(self.meter)
        self.meter_label = QtWidgets.QLabel("")
        side.addWidget(self.meter_label)
        self.movement_message = QtWidgets.QLabel("")
        self.movement_message.setWordWrap(True)
        self.movement_message.setStyleSheet("color: #d62728; font-weight: bold")
        side.addWidget(self.movement_message)
        side.addStretch(1)
        side.addLayout(button_row(push_button("Cancel", self.back_to_setup), None))
        outer.addLayout(side, 2)
        return page

    def _build_result(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        outer = QtWidgets.QHBoxLayout(page)
        self.scene = SceneView(target_fps=20.0)
        self.scene.setMinimumSize(420, 520)
        outer.addWidget(self.scene, 3)
        side = QtWidgets.QVBoxLayout()
        self.verdict_label = QtWidgets.QLabel("")
        self.verdict_label.setWordWrap(True)
        side.addWidget(self.verdict_label)
        self.figures_table = QtWidgets.QTableWidget(0, 2)
        self.figures_table.setHorizontalHeaderLabels(["Quality figure", "Value"])
        self.figures_table.verticalHeader().setVisible(False)
        self.figures_table.horizontalHeader().setStretchLastSection(True)
        self.figures_table.setEditTriggers(QtWidgets.QAbstractItemView.NoEditTriggers)
        side.addWidget(self.figures_table, 1)
        self.problems_label = QtWidgets.QLabel("")
        self.problems_label.setWordWrap(True)
        side.addWidget(self.problems_label)
        self.accept_button = push_button("Accept", self.accept_result)
        side.addLayout(button_row(push_button("Redo", self.redo), None, push_button("Close", self.reject),
                                  self.accept_button))
        outer.addLayout(side, 2)
        return page

    def _build_refused(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        layout.addWidget(QtWidgets.QLabel("<h2 style='color:#d62728'>Calibration refused</h2>"))
        self.refusal_label = large_label()
        layout.addWidget(self.refusal_label)
        layout.addStretch(1)
        layout.addLayout(button_row(push_button("Change settings", self.back_to_setup), None,
                                    push_button("Close", self.reject), push_button("Redo", self.redo)))
        return page

    # -- state -------------------------------------------------------------------------------
    @property
    def page_name(self) -> str:
        return ("setup", "pose", "result", "refused")[self.pages.currentIndex()]

    def mapping(self) -> dict[str, str]:
        """Segment → sensor id as set on the setup page."""
        return {seg: combo.currentText() for seg, combo in self.mapping_combos.items()
                if combo.currentText() != NO_SENSOR}

    def set_arms(self, arms: str) -> None:
        self.arms_combo.setCurrentIndex(ARMS.index(arms))

    def set_method(self, method: str) -> None:
        """``"npose-tpose"`` or ``"functional"`` (no T-pose)."""
        self.method_combo.setCurrentIndex(METHODS.index(method))

    # -- actions -----------------------------------------------------------------------------
    def start(self) -> None:
        """Check the setup and begin with the N-pose page."""
        try:
            self.procedure = BodycalProcedure(self.feed, self.mapping(), arms=self.arms_combo.currentData(),
                                              height_m=self.height_spin.value(), settings=self.settings,
                                              method=self.method_combo.currentData())
        except ValueError as error:
            self.setup_error.setText(in_clinical_words(str(error)))
            return
        self.setup_error.setText("")
        self.procedure.start()
        self.pages.setCurrentWidget(self.pose_page)
        self._show_status()
        self.follow(self.procedure, self._status_told)

    def redo(self) -> None:
        """Start the poses again with the same settings."""
        if self.procedure is None:
            return self.start()
        self.procedure.redo()
        self.pages.setCurrentWidget(self.pose_page)
        self._show_status()
        self.follow(self.procedure, self._status_told)

    def back_to_setup(self) -> None:
        self.stop_following()
        self.feed.instruct(instructions.npose())
        self.pages.setCurrentWidget(self.setup_page)

    def accept_result(self) -> None:
        """Apply the calibration to the live pipeline and close."""
        if self.procedure is None or self.procedure.calibration is None:
            return
        calibration = self.procedure.calibration
        if self.live_session is not None:
            self.live_session.apply_body_calibration(calibration)
        self.accepted_calibration = calibration
        self.assignment_settled = True  # the calibration carries the mapping
        self.calibration_accepted.emit(calibration)
        self.accept()

    # -- the mapping made here: kept or discarded, never dropped silently --------------------
    def assignment_changed(self) -> bool:
        """Whether the setup page's mapping differs from the live session's assignment."""
        return self.live_session is not None and self.mapping() != self.initial_mapping

    def _ask_about_assignment(self) -> str:
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Question, "Sensor assignment",
                                    "You changed which sensor is on which segment. Keep this assignment?",
                                    parent=self)
        box.setInformativeText("Keep: the live view and the next recording use it. Discard: the "
                               "assignment stays as it was before the wizard.")
        keep = box.addButton("Keep", QtWidgets.QMessageBox.AcceptRole)
        discard = box.addButton("Discard", QtWidgets.QMessageBox.DestructiveRole)
        box.addButton(QtWidgets.QMessageBox.Cancel)
        box.setDefaultButton(keep)
        box.exec_()
        return {keep: "keep", discard: "discard"}.get(box.clickedButton(), "cancel")

    def settle_assignment(self) -> bool:
        """Ask what to do with a changed mapping and do it; False if the user chose to stay."""
        if self.assignment_settled or not self.assignment_changed():
            return True
        answer = self.ask_about_assignment()
        if answer == "cancel":
            return False
        if answer == "keep":
            self.keep_assignment()
        self.assignment_settled = True
        return True

    def keep_assignment(self) -> None:
        """Apply the setup page's mapping to the live session as its sensor assignment."""
        live = self.live_session
        for segment, sensor_id in self.initial_mapping.items():
            if self.mapping().get(segment) != sensor_id:
                live.assign_sensor(sensor_id, None)
        for segment, sensor_id in self.mapping().items():
            live.assign_sensor(sensor_id, segment)
        remember_assignment(live.sensor_segments)
        self.assignment_settled = True

    def discard_assignment(self) -> None:
        """Drop the setup page's mapping without asking (the live session is going away)."""
        self.assignment_settled = True

    def reject(self) -> None:
        if self.settle_assignment():
            super().reject()

    def closeEvent(self, event) -> None:  # noqa: N802 (Qt API)
        if not self.settle_assignment():
            event.ignore()
            return
        super().closeEvent(event)

    def _status_told(self, _status) -> None:
        """The procedure took new samples: show where it stands."""
        self._show_status()

    # -- showing -----------------------------------------------------------------------------
    def _show_status(self) -> None:
        procedure = self.procedure
        status = procedure.status()
        if status.phase == "result":
            self.stop_following()
            self._show_result()
            return
        if status.phase == "refused":
            self.stop_following()
            reason = procedure.refusal or ""
            reason = in_clinical_words(reason)
            self.refusal_label.setText(reason[:1].upper() + reason[1:])
            self.pages.setCurrentWidget(self.refused_page)
            return
        if status.pose is None:
            return
        self.pose_title.setText(f"<h2>{STEP_TITLES[procedure.method][status.pose]}</h2>")
        self.pose_picture.setVisible(status.pose != "movement")  # there is no picture of walking
        if status.pose == "movement":
            self.pose_instruction.setText(procedure.instruction(status.pose))
            self.countdown.setText(f"{status.countdown_s:.0f} s")
            self.movement_message.setText("")
            self.meter.setFormat("moving: keep going")
            self.meter.setValue(0)
            self.meter_label.setText("")
            return
        self.pose_picture.show_pose(status.pose, procedure.arms)
        movement = status.message.startswith("Movement")
        self.pose_instruction.setText(procedure.instruction(status.pose))
        self.movement_message.setText(status.message if movement or status.settling_sensor else "")
        self.movement_message.setStyleSheet(f"color: {'#d62728' if movement else '#b06000'}; font-weight: bold")
        if status.capturing:
            self.countdown.setText(f"{status.countdown_s:.1f} s")
        elif status.pose == "tpose" and not status.still:
            self.countdown.setText("raise")
        elif status.settling_sensor:
            self.countdown.setText("settling")
        else:
            self.countdown.setText("hold still")
        if np.isfinite(status.meter_deg):
            motion = min(status.meter_deg / METER_FULL_SCALE_DEG, 1.0)
            self.meter.setValue(int(round(100 * (1.0 - motion))))
            colour = "#2ca02c" if status.still else ("#e08a00" if status.meter_deg < 3 * procedure.settings.still_limit_deg
                                                      else "#d62728")
            self.meter.setFormat("still" if status.still else "moving")
            self.meter_label.setText(f"largest turn in the last {procedure.settings.meter_window_s:g} s: "
                                     f"{status.meter_deg:.1f}° (still means below {procedure.settings.still_limit_deg:g}°)")
        else:
            self.meter.setValue(0)
            colour = "#888888"
            self.meter.setFormat("waiting for sensors")
        self.meter.setStyleSheet(f"QProgressBar::chunk {{ background: {colour}; }}")
        self.meter.setProperty("still", bool(status.still))

    def _show_result(self) -> None:
        procedure = self.procedure
        calibration = procedure.calibration
        quality = calibration.quality
        colour = VERDICT_COLOURS.get(quality.verdict, "#000000")
        pose = "standing still" if procedure.method == "functional" else "the calibrated N-pose"
        self.verdict_label.setText(
            f"<h2>Result: <span style='color:{colour}'>{quality.verdict}</span></h2>"
            f"<p>The figure shows the subject {pose}: it should stand upright with "
            "the arms hanging and face you.</p>")
        rows = procedure.quality_figures()
        self.figures_table.setRowCount(len(rows))
        for row, (label, value) in enumerate(rows):
            self.figures_table.setItem(row, 0, QtWidgets.QTableWidgetItem(label))
            self.figures_table.setItem(row, 1, QtWidgets.QTableWidgetItem(value))
        # the labels whole; the values (an axis' verdict is a sentence) wrap in the rest
        self.figures_table.resizeColumnToContents(0)
        self.figures_table.resizeRowsToContents()
        problems = quality.problems
        self.problems_label.setText(
            "<p><b>Remarks:</b></p><ul>" + "".join(f"<li>{p}</li>" for p in problems) + "</ul>"
            if problems else "<p>No remarks: every figure is within the good range.</p>")
        self.pages.setCurrentWidget(self.result_page)
        self._show_skeleton()

    def _show_skeleton(self) -> None:
        """The calibrated N-pose as the main window's figure (body display mode: facing the
        camera); segments without a sensor follow their parent."""
        segments = self.procedure.npose_segment_orientations(self.model)
        height = self.procedure.height_m
        poses = skeleton.forward_kinematics(self.model, segments, height)
        builder = FigureBuilder(self.model, height)
        geometry = builder.build(poses, mode="body")
        self.scene.set_figure(builder)
        self.scene.show_frame("calibrated", geometry)
        self.scene.set_tints({s: "ok" for s in self.procedure.mapping})
        self.scene.start()
        self.scene.render_pending()

    def vtk_view(self):
        return self.scene
