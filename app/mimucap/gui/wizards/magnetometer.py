"""The magnetometer-calibration wizard: choose sensors and protocol, turn, check, accept.

Pages (a ``QStackedWidget``; :attr:`MagnetometerWizard.page_name` says which is shown):

* ``"setup"``: the sensors to calibrate together (checked in a list, with each one's previous
  calibration and its age) and the protocol: one turn about each axis (default), figure-8
  or free.
* ``"recording"``: the picture of the axis to turn about now (or of the protocol), the
  instruction, a progress bar per axis, and on the right the live views
  (:mod:`mimucap.gui.wizards.ellipsoid_view`) of one chosen sensor: raw point cloud with the
  fitted ellipsoid, corrected samples on the field sphere, |field| before/after. The page
  advances to the next axis by itself and to the result when all are done.
* ``"result"``: per sensor the verdict, offset, soft-iron matrix, residual, coverage, the
  previous calibration and its age, and the advice in plain words; Accept stores the
  acceptable calibrations per sensor id, Redo starts again.

All logic lives in :class:`mimucap.session.procedures.magnetometer.MagcalProcedure`: the feed's
``arrived`` event steps it and the page shows each status it tells
(:meth:`~mimucap.gui.wizards.dialog.CalibrationDialog.follow`); nothing polls. The live views are
refreshed at most every ``view_interval_ms`` (a refit of the preview is the expensive part).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from html import escape

import numpy as np
from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap.core.magcal.guidance import AXIS_NAMES
from mimucap.core.simulate.suit import SuitSimulator
from mimucap.core.wording import plural
from mimucap.io.calibration_store import CalibrationFileError, CalibrationStore
from mimucap.session.procedures import instructions
from mimucap.session.sources.calibration_feed import CalibrationFeed, SimulatedSuitFeed, feed_for_live_session
from mimucap.session.procedures.magnetometer import (
    PROTOCOLS,
    MagcalProcedure,
    MagcalProcedureSettings,
    SensorOutcome,
)
from mimucap.session.views.calibration_age import age_days_since, describe_age, utc_now
from mimucap.gui.wizards.ellipsoid_view import EllipsoidView, FieldMagnitudePlot
from mimucap.session.views.magcal_display import magcal_display
from mimucap.gui.wizards.pictures import AXIS_COLOURS, PictureWidget
from mimucap.core.clinical_names import sensor_name
from mimucap.gui.screen_fit import fit_on_screen
from mimucap.gui.simulated_suit_clock import SimulatedSuitClock
from mimucap.gui.wizards.dialog import CalibrationDialog, button_row, large_label, push_button

PROTOCOL_LABELS = {
    "single_axis": "One turn about each sensor axis (recommended)",
    "figure8": "Figure-8 in the air",
    "free": "Free turning in every direction",
}
VERDICT_COLOURS = {"good": "#2ca02c", "warn": "#e08a00", "fail": "#d62728"}
#: At most this many samples are drawn in the live views (evenly thinned).
VIEW_MAX_POINTS = 4000
VERDICT_WORDS = {"good": "Good", "warn": "Usable, with a warning", "fail": "Failed — redo"}


def _matrix_text(m: np.ndarray) -> str:
    return "\n".join("  ".join(f"{v:+.3f}" for v in row) for row in np.asarray(m))


class MagnetometerWizard(CalibrationDialog):
    """Guided magnetometer calibration.

    ``live_session``: the main window's live session (read through
    :func:`feed_for_live_session`; accepted calibrations are also applied to it with
    ``apply_mag_calibration``); or give ``feed`` directly (with ``live_session`` None, accepted
    calibrations are only stored and told). ``store``: where calibrations are kept (default: the
    user's). ``preselected``: sensor ids checked at the start (default: all).
    """

    calibrations_accepted = QtCore.pyqtSignal(list)

    def __init__(
        self,
        parent: QtWidgets.QWidget | None,
        live_session: object | None = None,
        *,
        feed: CalibrationFeed | None = None,
        store: CalibrationStore | None = None,
        view_interval_ms: int = 300,
        preselected: Sequence[str] | None = None,
        now: Callable = utc_now,
    ) -> None:
        super().__init__(parent)
        if feed is None:
            if live_session is None:
                raise ValueError("the magnetometer wizard needs a live session or a feed")
            feed = feed_for_live_session(live_session)
        self.live_session = live_session
        self.feed = feed
        self.store = store if store is not None else CalibrationStore()
        self._now = now
        self.procedure: MagcalProcedure | None = None
        self.view_interval_ms = int(view_interval_ms)
        self._last_view = -1e9
        self.setWindowTitle("Magnetometer calibration")
        fit_on_screen(self, 1280, 760, parent)

        self.pages = QtWidgets.QStackedWidget()
        self.setup_page = self._build_setup(preselected)
        self.recording_page = self._build_recording()
        self.result_page = self._build_result()
        for page in (self.setup_page, self.recording_page, self.result_page):
            self.pages.addWidget(page)

        self.view = EllipsoidView()
        self.plot = FieldMagnitudePlot()
        self.view_sensor = QtWidgets.QComboBox()
        self.view_sensor.currentIndexChanged.connect(lambda _: self._refresh_views(force=True))
        right = QtWidgets.QWidget()
        right_layout = QtWidgets.QVBoxLayout(right)
        row = QtWidgets.QHBoxLayout()
        row.addWidget(QtWidgets.QLabel("Sensor shown:"))
        row.addWidget(self.view_sensor, 1)
        right_layout.addLayout(row)
        right_layout.addWidget(self.view, 3)
        right_layout.addWidget(self.plot, 1)
        self.views_panel = right
        self.views_panel.setVisible(False)

        layout = QtWidgets.QHBoxLayout(self)
        layout.addWidget(self.pages, 1)
        layout.addWidget(self.views_panel, 1)
        self.set_page_defaults(self.pages, {self.setup_page: self.start_button,
                                            self.result_page: self.accept_button})
        self._update_previous()

    @classmethod
    def for_simulator(
        cls, simulator: SuitSimulator, parent: QtWidgets.QWidget | None = None, step_s: float = 0.2,
        tick_ms: int = 40, **kwargs
    ) -> MagnetometerWizard:
        """A wizard on a simulated suit of its own, advancing ``step_s`` simulated seconds every
        ``tick_ms`` ms (:class:`~mimucap.gui.simulated_suit_clock.SimulatedSuitClock`); accepted
        calibrations are applied to the suit's session too."""
        feed = SimulatedSuitFeed(simulator, step_s=step_s)
        wizard = cls(parent, feed.live_session, feed=feed, **kwargs)
        wizard.clock = SimulatedSuitClock(feed, tick_ms, wizard)
        return wizard

    # -- pages -------------------------------------------------------------------------------
    def _build_setup(self, preselected: Sequence[str] | None) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        title = QtWidgets.QLabel("<h2>Magnetometer calibration</h2>"
                                 "<p>Take the sensors off, hold the ones you tick together firmly in "
                                 "one bundle, away from metal, and turn them as the next page shows. "
                                 "Each sensor gets its own calibration.</p>")
        title.setWordWrap(True)
        layout.addWidget(title)
        # orientation-only sensors (on-board fusion, no magnetometer readings) calibrate themselves
        self.self_calibrating = tuple(self.feed.orientation_only_sensors())
        self.self_calibrating_note = QtWidgets.QLabel(
            f"<p><b>{plural(len(self.self_calibrating), 'sensor')} calibrate{'s' if len(self.self_calibrating) == 1 else ''} themselves</b> "
            f"({', '.join(self.self_calibrating)}): they fuse their own orientation on board and send no "
            "magnetometer readings, so no turns are asked for them here. Follow their maker's "
            "calibration (for SlimeVR trackers: the SlimeVR firmware's own procedure).</p>")
        self.self_calibrating_note.setObjectName("selfCalibratingNote")
        self.self_calibrating_note.setWordWrap(True)
        self.self_calibrating_note.setVisible(bool(self.self_calibrating))
        layout.addWidget(self.self_calibrating_note)
        layout.addWidget(QtWidgets.QLabel("<b>Sensors to calibrate together</b>"))
        self.sensor_list = QtWidgets.QListWidget()
        to_calibrate = [s for s in self.feed.sensor_ids if s not in self.self_calibrating]
        chosen = set(to_calibrate if preselected is None else preselected) - set(self.self_calibrating)
        for sensor_id in to_calibrate:
            item = QtWidgets.QListWidgetItem(sensor_id)
            item.setFlags(item.flags() | QtCore.Qt.ItemIsUserCheckable)
            item.setCheckState(QtCore.Qt.Checked if sensor_id in chosen else QtCore.Qt.Unchecked)
            item.setData(QtCore.Qt.UserRole, sensor_id)
            self.sensor_list.addItem(item)
        self.sensor_list.itemChanged.connect(lambda _: self._update_previous())
        layout.addWidget(self.sensor_list, 1)
        layout.addWidget(QtWidgets.QLabel("<b>Protocol</b>"))
        self.protocol_buttons: dict[str, QtWidgets.QRadioButton] = {}
        for protocol in PROTOCOLS:
            button = QtWidgets.QRadioButton(PROTOCOL_LABELS[protocol])
            button.setChecked(protocol == "single_axis")
            self.protocol_buttons[protocol] = button
            layout.addWidget(button)
        self.setup_error = QtWidgets.QLabel("")
        self.setup_error.setStyleSheet("color: #d62728")
        layout.addWidget(self.setup_error)
        self.start_button = push_button("Start", self.start)
        self.start_button.setEnabled(bool(to_calibrate))   # every sensor calibrates itself: nothing to do
        layout.addLayout(button_row(None, push_button("Close", self.reject), self.start_button))
        return page

    def _build_recording(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        self.recording_title = QtWidgets.QLabel("<h2>Turn the sensors</h2>")
        layout.addWidget(self.recording_title)
        self.picture = PictureWidget()
        layout.addWidget(self.picture, 3)
        self.instruction = large_label(bold=True)
        layout.addWidget(self.instruction)
        self.axis_bars: dict[str, QtWidgets.QProgressBar] = {}
        grid = QtWidgets.QGridLayout()
        for row, axis in enumerate(AXIS_NAMES):
            label = QtWidgets.QLabel(f"about {axis}")
            bar = QtWidgets.QProgressBar()
            bar.setRange(0, 100)
            bar.setFormat(f"{axis}: %p%")
            colour = AXIS_COLOURS[axis].name()
            bar.setStyleSheet(f"QProgressBar::chunk {{ background: {colour}; }}")
            bar.setAlignment(QtCore.Qt.AlignCenter)
            grid.addWidget(label, row, 0)
            grid.addWidget(bar, row, 1)
            self.axis_bars[axis] = bar
        self.axis_widget = QtWidgets.QWidget()
        self.axis_widget.setLayout(grid)
        layout.addWidget(self.axis_widget)
        self.recording_info = QtWidgets.QLabel("")
        layout.addWidget(self.recording_info)
        self.finish_button = push_button("Compute now", self.finish_now,
                                         tooltip="Stop recording and compute with what was recorded")
        layout.addLayout(button_row(push_button("Cancel", self.redo), None, self.finish_button))
        return page

    def _build_result(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        self.result_title = QtWidgets.QLabel("<h2>Result</h2>")
        self.result_title.setWordWrap(True)
        layout.addWidget(self.result_title)
        # The offset is in the details below and under the 3D view: the table keeps what tells
        # the calibrations apart, every column in view on a laptop's screen.
        self.result_table = QtWidgets.QTableWidget(0, 5)
        self.result_table.setHorizontalHeaderLabels(["Sensor", "Verdict", "Residual", "Coverage x/y/z", "Previous"])
        self.result_table.verticalHeader().setVisible(False)
        self.result_table.setEditTriggers(QtWidgets.QAbstractItemView.NoEditTriggers)
        self.result_table.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectRows)
        self.result_table.itemSelectionChanged.connect(self._show_selected_result)
        self.result_table.horizontalHeader().setStretchLastSection(True)
        layout.addWidget(self.result_table, 2)
        self.result_details = QtWidgets.QTextBrowser()
        layout.addWidget(self.result_details, 2)
        self.redo_button = push_button("Redo", self.redo)
        self.accept_button = push_button("Accept", self.accept_results)
        layout.addLayout(button_row(self.redo_button, None, push_button("Close", self.reject), self.accept_button))
        return page

    # -- state -------------------------------------------------------------------------------
    @property
    def page_name(self) -> str:
        return ("setup", "recording", "result")[self.pages.currentIndex()]

    def selected_sensors(self) -> list[str]:
        items = (self.sensor_list.item(i) for i in range(self.sensor_list.count()))
        return [item.data(QtCore.Qt.UserRole) for item in items if item.checkState() == QtCore.Qt.Checked]

    def set_selected_sensors(self, sensor_ids: Sequence[str]) -> None:
        wanted = set(sensor_ids)
        for i in range(self.sensor_list.count()):
            item = self.sensor_list.item(i)
            item.setCheckState(QtCore.Qt.Checked if item.data(QtCore.Qt.UserRole) in wanted else QtCore.Qt.Unchecked)

    def protocol(self) -> str:
        return next(p for p, b in self.protocol_buttons.items() if b.isChecked())

    def set_protocol(self, protocol: str) -> None:
        self.protocol_buttons[protocol].setChecked(True)

    def sensor_label(self, sensor_id: str) -> str:
        """The sensor by the segment it is worn on, when the live session says: "Pelvis sensor (S01)"."""
        segment = self.feed.sensor_segments.get(sensor_id)
        return sensor_name(segment, sensor_id) if segment else sensor_id

    def _update_previous(self) -> None:
        now = self._now()
        for i in range(self.sensor_list.count()):
            item = self.sensor_list.item(i)
            sensor_id = item.data(QtCore.Qt.UserRole)
            try:
                found = self.store.lookup(sensor_id, self.feed.device(sensor_id))
                old = found.calibration
                if old is not None:
                    text = (f"{self.sensor_label(sensor_id)} — calibrated {describe_age(age_days_since(old.created_utc, now))} "
                            f"({old.quality.get('verdict', 'unknown')})")
                elif found.note:
                    text = f"{self.sensor_label(sensor_id)} — never calibrated on this device"
                else:
                    text = f"{self.sensor_label(sensor_id)} — never calibrated"
            except (OSError, CalibrationFileError):
                text = f"{self.sensor_label(sensor_id)} — stored calibration unreadable: calibrate again"
            self.sensor_list.blockSignals(True)
            item.setText(text)
            self.sensor_list.blockSignals(False)

    # -- actions -----------------------------------------------------------------------------
    def start(self) -> None:
        """Start recording the checked sensors with the chosen protocol."""
        try:
            procedure = MagcalProcedure(self.feed, self.selected_sensors(),
                                        MagcalProcedureSettings(protocol=self.protocol()),
                                        store=self.store, now=self._now)
        except ValueError as error:
            self.setup_error.setText(str(error))
            return
        self.setup_error.setText("")
        self.procedure = procedure
        self.view_sensor.blockSignals(True)
        self.view_sensor.clear()
        for sensor_id in procedure.sensor_ids:
            self.view_sensor.addItem(self.sensor_label(sensor_id), sensor_id)
        self.view_sensor.blockSignals(False)
        self.view.reset()
        self.axis_widget.setVisible(procedure.protocol == "single_axis")
        if procedure.protocol != "single_axis":
            self.picture.show_protocol("figure8" if procedure.protocol == "figure8" else "free")
            title = "Figure-8 in the air" if procedure.protocol == "figure8" else "Turn in every direction"
            self.recording_title.setText(f"<h2>{title}</h2>")
        procedure.start()
        self.pages.setCurrentWidget(self.recording_page)
        self.views_panel.setVisible(True)
        self.view.start()
        self._show_status()
        self.follow(procedure, self._status_told)

    def _status_told(self, _status) -> None:
        """The procedure took new samples: show where it stands (the result once it is done)."""
        self._show_status()
        if self.procedure.phase == "result":
            self._show_result()
        else:
            self._refresh_views()

    def finish_now(self) -> None:
        """Stop and compute with what was recorded."""
        if self.procedure is not None and self.procedure.phase == "recording":
            self.procedure.finish_now()
            self._show_result()

    def redo(self) -> None:
        """Back to the setup page; the recording is discarded."""
        self.stop_following()
        if self.procedure is not None:
            if self.procedure.phase == "recording":
                self.feed.instruct(instructions.put_sensors_back())
            self.procedure.redo()
        self.views_panel.setVisible(False)
        self._update_previous()
        self.pages.setCurrentWidget(self.setup_page)

    def accept_results(self) -> list[str]:
        """Store every acceptable calibration; returns the sensor ids stored."""
        if self.procedure is None or self.procedure.phase != "result":
            return []
        stored = self.procedure.accept()
        calibrations = [self.procedure.outcomes[s].result.calibration for s in stored]
        if self.live_session is not None:
            for calibration in calibrations:
                self.live_session.apply_mag_calibration(calibration, save=False)  # the procedure has stored it
        self.calibrations_accepted.emit(calibrations)
        failed = [s for s in self.procedure.sensor_ids if s not in stored]
        text = f"Stored: {', '.join(stored) or 'none'}."
        if failed:
            text += f" Not stored (failed): {', '.join(failed)} — redo them."
        self.result_title.setText(f"<h2>Result</h2><p>{text}</p>")
        self.accept_button.setEnabled(False)
        self._update_previous()
        if not failed:  # nothing left to redo: the wizard's work is done
            self.accept()
        return stored

    # -- showing -----------------------------------------------------------------------------
    def _show_status(self) -> None:
        status = self.procedure.status()
        self.instruction.setText(status.message)
        if self.procedure.protocol == "single_axis":
            guides = [self.procedure.guidance(s) for s in self.procedure.sensor_ids]
            swept = {a: min(g.axis(a).swept_deg for g in guides) for a in AXIS_NAMES}
            self.picture.show_axis(status.axis_to_turn, swept, self.procedure.settings.guidance.full_turn_deg)
            for axis, bar in self.axis_bars.items():
                bar.setValue(int(round(100 * status.axis_progress.get(axis, 0.0))))
            title = f"Turn about {status.axis_to_turn}" if status.axis_to_turn else "All axes done"
            self.recording_title.setText(f"<h2>{title}</h2>")
        # One short line whatever the number of sensors; each sensor's count in the tooltip.
        counts = list(status.samples.values())
        if not counts:
            samples = "no samples yet"
        elif min(counts) == max(counts):
            samples = f"{counts[0]} samples per sensor"
        else:
            samples = f"{min(counts)} to {max(counts)} samples per sensor"
        self.recording_info.setText(f"{status.elapsed_s:.0f} s recorded, {samples}")
        self.recording_info.setToolTip("\n".join(f"{self.sensor_label(s)}: {c} samples" for s, c in status.samples.items()))

    def _refresh_views(self, force: bool = False) -> None:
        if self.procedure is None:
            return
        now = time.monotonic() * 1000.0
        if not force and now - self._last_view < self.view_interval_ms:
            return
        self._last_view = now
        sensor_id = self.view_sensor.currentData()
        if sensor_id not in self.procedure.sensor_ids:
            return
        t, mag, _ = self.procedure.samples(sensor_id)
        if t.shape[0] == 0:
            return
        display = magcal_display(mag, t, self.procedure.preview_fit(sensor_id), max_points=VIEW_MAX_POINTS)
        self.view.set_data(display)
        self.plot.set_data(display)

    def _show_result(self) -> None:
        self.stop_following()
        procedure = self.procedure
        outcomes = [procedure.outcomes[s] for s in procedure.sensor_ids]
        failed = [o.sensor_id for o in outcomes if o.verdict == "fail"]
        if failed:
            head = f"Calibration failed for {', '.join(self.sensor_label(s) for s in failed)}: see the advice below and redo"
        else:
            head = "All sensors calibrated: check the views and accept"
        self.result_title.setText(f"<h2>Result</h2><p>{head}</p>")
        self.result_table.setRowCount(len(outcomes))
        for row, outcome in enumerate(outcomes):
            self._fill_row(row, outcome)
        self.result_table.resizeColumnsToContents()
        self.accept_button.setEnabled(any(o.acceptable for o in outcomes))
        self.pages.setCurrentWidget(self.result_page)
        self.result_table.selectRow(0)
        self._show_selected_result()

    def _fill_row(self, row: int, outcome: SensorOutcome) -> None:
        cells = [self.sensor_label(outcome.sensor_id), VERDICT_WORDS[outcome.verdict]]
        if outcome.result is not None:
            q = outcome.result.quality
            cells += [f"{q.rms_residual_uT:.2f} µT", "/".join(f"{c * 100:.0f}" for c in q.axis_coverage) + " %"]
        else:
            cells += ["—", "—"]
        previous = outcome.previous
        # the age only: the previous offset is in the details below and in the tooltip
        cells.append("none" if previous is None else describe_age(previous.age_days))
        tooltip = "" if previous is None else f"previous offset {', '.join(f'{v:.1f}' for v in previous.offset_uT)} µT"
        for col, text in enumerate(cells):
            item = QtWidgets.QTableWidgetItem(text)
            if col == len(cells) - 1 and tooltip:
                item.setToolTip(tooltip)
            if col == 1:
                item.setForeground(QtGui.QColor(VERDICT_COLOURS[outcome.verdict]))
                font = item.font()
                font.setBold(True)
                item.setFont(font)
            self.result_table.setItem(row, col, item)

    def _show_selected_result(self) -> None:
        if self.procedure is None or self.procedure.phase != "result":
            return
        rows = self.result_table.selectionModel().selectedRows()
        row = rows[0].row() if rows else 0
        sensor_id = self.procedure.sensor_ids[row]
        outcome = self.procedure.outcomes[sensor_id]
        html = [f"<h3>{self.sensor_label(sensor_id)}: <span style='color:{VERDICT_COLOURS[outcome.verdict]}'>"
                f"{VERDICT_WORDS[outcome.verdict]}</span></h3>"]
        if outcome.advice:
            html.append("<p><b>What to do:</b></p><ul>" + "".join(f"<li>{a}</li>" for a in outcome.advice) + "</ul>")
        if outcome.result is not None:
            q = outcome.result.quality
            cal = outcome.result.calibration
            html.append(
                f"<p>Offset (hard iron): {', '.join(f'{v:.2f}' for v in cal.offset_uT)} µT<br>"
                f"Field after correction: {cal.field_uT:.1f} µT; residual {q.rms_residual_uT:.2f} µT "
                f"({q.rms_residual_pct:.1f} %)<br>Coverage x/y/z: "
                f"{' / '.join(f'{c * 100:.0f}%' for c in q.axis_coverage)} (condition {q.condition:.1f})</p>"
                f"<p>Soft-iron correction:</p><pre>{_matrix_text(cal.soft_iron)}</pre>"
                f"<p>Gyroscope, from the same turns: {escape(outcome.result.gyro.summary())}</p>")
        if outcome.previous is not None:
            p = outcome.previous
            html.append(f"<p><b>Previous calibration</b> ({p.created_utc}, {describe_age(p.age_days)}, {p.verdict}): "
                        f"offset {', '.join(f'{v:.2f}' for v in p.offset_uT)} µT, field {p.field_uT:.1f} µT</p>")
        else:
            html.append("<p>No previous calibration of this sensor.</p>")
        self.result_details.setHtml("".join(html))
        if self.view_sensor.currentData() != sensor_id:
            self.view_sensor.setCurrentIndex(self.view_sensor.findData(sensor_id))  # refreshes the views
        else:
            self._refresh_views(force=True)

    def vtk_view(self):
        return self.view

    def before_shutdown(self) -> None:
        """Sensors still being turned are put back on."""
        if self.procedure is not None and self.procedure.phase == "recording":
            self.feed.instruct(instructions.put_sensors_back())
