"""The export dialog: joint angles (CSV, OpenSim .mot, with our or OpenSim's coordinate names),
the motion as C3D, BVH and an OpenSense orientation table, sensor data, and the summary table per
joint (min, max, range of motion) saved as CSV and as a PNG chart for a report.

The files are written off the GUI thread (:class:`~mimucap.gui.background_task.BackgroundTask`)
with a progress bar; the work itself is :func:`mimucap.session.recorded.export.run_export`. Every file,
the summary CSV and the chart's caption say what the result holds
(:attr:`~mimucap.session.recorded.review.ReviewData.provenance`); without a body calibration the dialog
says so above the summary.
"""

from __future__ import annotations

import html
import logging
import os
import textwrap
from pathlib import Path

import numpy as np
import pyqtgraph as pg
import pyqtgraph.exporters  # noqa: F401  (registers ImageExporter)
from PyQt5 import QtCore, QtWidgets

from mimucap.core.analysis.rom import marker_words
from mimucap.core.clinical_names import angle_label, angle_sign_text
from mimucap.core.wording import fixed
from mimucap.gui.background_task import BackgroundTask
from mimucap.gui.screen_fit import fit_on_screen
from mimucap.gui.session_panel import display_path
from mimucap.io.angles_export import write_summary_csv
from mimucap.session.recorded.export import (
    ExportRequest, ExportResult, angles_in_range, doubt_in_range, export_folder, marker_range, recording_start_s,
    run_export, summary_table,
)
from mimucap.session.recorded.provenance import WITHOUT_BODY_CALIBRATION
from mimucap.session.recorded.review import ReviewData

log = logging.getLogger(__name__)
#: Characters per line of the summary chart's caption.
CAPTION_WRAP_CHARS = 150


class ExportDialog(QtWidgets.QDialog):
    """Export a reviewed session (``data``); ``cursor_s`` preselects nothing but is shown."""

    def __init__(self, parent: QtWidgets.QWidget | None, data: ReviewData) -> None:
        super().__init__(parent)
        self.setWindowTitle("Export")
        self.setObjectName("exportDialog")
        self.data = data
        self.result: ExportResult | None = None
        self._chart: tuple | None = None  # drawn off screen for the summary PNG
        #: the provenance lines of the last summary chart's caption (before wrapping)
        self._caption_lines: list[str] = []
        self._task: BackgroundTask | None = None
        self._range_valid = False  # the chosen range holds poses (set by update_summary)

        range_box = QtWidgets.QGroupBox("Range", self)
        self.start_s = recording_start_s(data)  # never before the recording's start
        self.range_all = QtWidgets.QRadioButton(f"Whole recording ({self.start_s:.2f}–{data.end_s:.2f} s)", range_box)
        self.range_time = QtWidgets.QRadioButton("From", range_box)
        self.range_markers = QtWidgets.QRadioButton("Between markers", range_box)
        self.range_all.setChecked(True)
        self.t_from = QtWidgets.QDoubleSpinBox(range_box)
        self.t_to = QtWidgets.QDoubleSpinBox(range_box)
        for spin, value in ((self.t_from, self.start_s), (self.t_to, data.end_s)):
            spin.setRange(self.start_s, data.end_s)
            spin.setDecimals(2)
            spin.setSuffix(" s")
            spin.setValue(value)
        self.marker_a = QtWidgets.QComboBox(range_box)
        self.marker_b = QtWidgets.QComboBox(range_box)
        for combo in (self.marker_a, self.marker_b):
            for marker in data.markers:
                combo.addItem(f"{marker_words(marker.label)} ({marker.t_s:.2f} s)")
                combo.setItemData(combo.count() - 1, marker_words(marker.label), QtCore.Qt.ToolTipRole)
        if len(data.markers) >= 2:
            self.marker_b.setCurrentIndex(1)
        else:
            self.range_markers.setEnabled(False)
        grid = QtWidgets.QGridLayout(range_box)
        grid.addWidget(self.range_all, 0, 0, 1, 4)
        grid.addWidget(self.range_time, 1, 0)
        grid.addWidget(self.t_from, 1, 1)
        grid.addWidget(QtWidgets.QLabel("to"), 1, 2)
        grid.addWidget(self.t_to, 1, 3)
        grid.addWidget(self.range_markers, 2, 0)
        grid.addWidget(self.marker_a, 2, 1)
        grid.addWidget(QtWidgets.QLabel("and"), 2, 2)
        grid.addWidget(self.marker_b, 2, 3)

        files_box = QtWidgets.QGroupBox("Files", self)
        self.want_csv = QtWidgets.QCheckBox("Joint angles, CSV", files_box)
        self.want_mot = QtWidgets.QCheckBox("Joint angles, OpenSim .mot", files_box)
        self.want_summary = QtWidgets.QCheckBox("Summary per joint, CSV", files_box)
        self.want_sensors = QtWidgets.QCheckBox("Sensor data and orientations, one CSV per sensor", files_box)
        self.want_opensim_mot = QtWidgets.QCheckBox("Joint angles as OpenSim coordinates, .mot (OpenSim)", files_box)
        self.want_c3d = QtWidgets.QCheckBox("Angles, orientations, joint centres and events, C3D (Visual3D, Mokka)", files_box)
        self.want_bvh = QtWidgets.QCheckBox("Skeleton animation, BVH (Blender)", files_box)
        self.want_sto = QtWidgets.QCheckBox("Segment orientations, OpenSense .sto (OpenSim IMU kinematics)", files_box)
        self._file_boxes = (self.want_csv, self.want_mot, self.want_opensim_mot, self.want_summary, self.want_sensors,
                            self.want_c3d, self.want_bvh, self.want_sto)
        #: the files that hold joint angles or segments: meaningless without a body calibration
        self._needs_body_calibration = (self.want_csv, self.want_mot, self.want_opensim_mot, self.want_summary,
                                        self.want_c3d, self.want_bvh, self.want_sto)
        if data.body_calibration is None:
            for box in self._needs_body_calibration:
                box.setEnabled(False)
                box.setToolTip(f"Needs a body calibration: {WITHOUT_BODY_CALIBRATION}")
            self.want_sensors.setChecked(True)
        else:
            for box in (self.want_csv, self.want_mot, self.want_summary):
                box.setChecked(True)
        # the home folder written "~" (expanded again by export_base_path); the files are named
        # <session>_joint_angles.csv... inside the session's own export folder
        self.base_path = QtWidgets.QLineEdit(display_path(export_folder(data.path) / data.path.stem), files_box)
        self.base_path.setObjectName("exportBasePath")
        browse = QtWidgets.QPushButton("Browse…", files_box)
        browse.clicked.connect(self._browse)
        layout = QtWidgets.QVBoxLayout(files_box)
        for box in self._file_boxes:
            layout.addWidget(box)
        row = QtWidgets.QHBoxLayout()
        row.addWidget(QtWidgets.QLabel("Save as"))
        row.addWidget(self.base_path, 1)
        row.addWidget(browse)
        layout.addLayout(row)

        self.progress = QtWidgets.QProgressBar(self)
        self.progress.setRange(0, 100)
        self.progress.setValue(0)
        self.message = QtWidgets.QLabel(self)
        self.message.setWordWrap(True)
        self.calibration_note = QtWidgets.QLabel(self)
        self.calibration_note.setObjectName("exportCalibrationNote")
        self.calibration_note.setWordWrap(True)
        self.calibration_note.setStyleSheet("color: #b00020")
        if data.body_calibration is None:
            self.calibration_note.setText(f"Body calibration: {WITHOUT_BODY_CALIBRATION}. Only the sensor data "
                                          f"can be exported; calibrate the body (or give the session a body "
                                          f"calibration) for joint angles and segments.")
        self.calibration_note.setVisible(data.body_calibration is None)
        self.summary = QtWidgets.QTableWidget(0, 4, self)
        self.summary.setObjectName("summaryTable")
        self.summary.setHorizontalHeaderLabels(["Joint angle", "Min (°)", "Max (°)", "Range of motion (°)"])
        self.summary.verticalHeader().setVisible(False)
        self.summary.setVisible(data.body_calibration is not None)  # a range of motion needs one
        self.summary.setEditTriggers(QtWidgets.QAbstractItemView.NoEditTriggers)
        header = self.summary.horizontalHeader()
        header.setSectionResizeMode(0, QtWidgets.QHeaderView.Stretch)
        for column in (1, 2, 3):  # the headers are read whole ("Range of motion (°)")
            header.setSectionResizeMode(column, QtWidgets.QHeaderView.ResizeToContents)

        self.export_button = QtWidgets.QPushButton("Export", self)
        self.export_button.setObjectName("exportButton")
        self.export_button.setDefault(True)
        self.export_button.clicked.connect(self.start_export)
        self.summary_csv_button = QtWidgets.QPushButton("Save Summary CSV…", self)
        self.summary_csv_button.clicked.connect(self._ask_summary_csv)
        self.summary_png_button = QtWidgets.QPushButton("Save Summary PNG…", self)
        self.summary_png_button.clicked.connect(self._ask_summary_png)
        close = QtWidgets.QPushButton("Close", self)
        close.clicked.connect(self.accept)
        buttons = QtWidgets.QHBoxLayout()
        buttons.addWidget(self.summary_csv_button)
        buttons.addWidget(self.summary_png_button)
        buttons.addStretch(1)
        buttons.addWidget(self.export_button)
        buttons.addWidget(close)

        main = QtWidgets.QVBoxLayout(self)
        main.addWidget(range_box)
        main.addWidget(files_box)
        main.addWidget(self.progress)
        main.addWidget(self.message)
        main.addWidget(self.calibration_note)
        main.addWidget(self.summary, 1)
        main.addLayout(buttons)
        fit_on_screen(self, 620, 720, parent)
        for widget in (self.range_all, self.range_time, self.range_markers):
            widget.toggled.connect(self.update_summary)
        # Editing a range's fields chooses that range (edits are never silently ignored).
        for widget in (self.t_from, self.t_to):
            widget.valueChanged.connect(lambda _value: self.range_time.setChecked(True))
            widget.valueChanged.connect(self.update_summary)
        for widget in (self.marker_a, self.marker_b):
            widget.activated.connect(lambda _index: self.range_markers.setChecked(True))
            widget.currentIndexChanged.connect(self.update_summary)
        for box in self._file_boxes:
            box.toggled.connect(self._update_buttons)
        self.update_summary()

    def set_data(self, data: ReviewData) -> None:
        """Another result of the same session (as seen live / reprocessed): the summary follows,
        the user's choices (range, files, where) stay."""
        self.data = data
        self.update_summary()

    # -- range and summary -------------------------------------------------------------------
    def time_range(self) -> tuple[float, float]:
        """The chosen range (s); ``ValueError`` when it is empty."""
        if self.range_markers.isChecked():
            return marker_range(self.data.markers, self.marker_a.currentIndex(), self.marker_b.currentIndex())
        if self.range_time.isChecked():
            a, b = self.t_from.value(), self.t_to.value()
            if b <= a:
                raise ValueError(f"the range ends ({b:.2f} s) before it starts ({a:.2f} s)")
            return a, b
        return self.start_s, self.data.end_s

    def summary_rows(self):
        a, b = self.time_range()
        _t, angles = angles_in_range(self.data, a, b)
        return summary_table(angles, doubt_in_range(self.data, a, b))

    def update_summary(self) -> None:
        try:
            rows = self.summary_rows()
        except ValueError as error:
            self.message.setText(str(error))
            self.summary.setRowCount(0)
            self._range_valid = False
            self._update_buttons()
            return
        self._range_valid = True
        self._update_buttons()
        self.message.setText("")
        self.summary.setRowCount(len(rows))
        for r, row in enumerate(rows):
            values = (angle_label(row.column), fixed(row.minimum_deg, 1), fixed(row.maximum_deg, 1),
                      fixed(row.rom_deg, 1))
            for c, text in enumerate(values):
                item = QtWidgets.QTableWidgetItem(text)
                if c:
                    item.setTextAlignment(QtCore.Qt.AlignRight | QtCore.Qt.AlignVCenter)
                else:  # the file's column name and the sign, for whoever reads the files
                    sign = angle_sign_text(row.column)
                    item.setToolTip(f"{row.column} in the files" + (f"; {sign}" if sign else ""))
                self.summary.setItem(r, c, item)

    def _update_buttons(self) -> None:
        """Export needs a valid range, a file ticked and no export running; the summary
        files a valid range."""
        wanted = any(box.isChecked() and box.isEnabled() for box in self._file_boxes)
        self.export_button.setEnabled(self._range_valid and wanted and not self.busy)
        calibrated = self.data.body_calibration is not None
        self.summary_csv_button.setEnabled(self._range_valid and calibrated)
        self.summary_png_button.setEnabled(self._range_valid and calibrated)

    # -- export ------------------------------------------------------------------------------
    def _suggested(self, name: str) -> str:
        """A file ``<session>_<name>`` in the export folder (absolute), for a file dialog; the
        home folder when the "Save as" text cannot give one."""
        try:
            return str(self.export_folder() / f"{self.export_base_path().name}_{name}")
        except (ValueError, OSError):
            return str(Path.home() / f"{self.data.path.stem}_{name}")

    def _browse(self) -> None:
        try:
            start = str(self.export_folder() / self.export_base_path().name)
        except (ValueError, OSError):
            start = str(Path.home() / self.data.path.stem)
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Export As", start, "All files (*)")
        if path:
            self.base_path.setText(str(Path(path).with_suffix("")))

    def export_base_path(self) -> Path:
        """Where the files go: the "Save as" text; a folder (an existing one, or a text ending
        in a separator) gets the default name inside it. ``ValueError`` when empty."""
        text = self.base_path.text().strip()
        if not text:
            raise ValueError("choose where to save the files (Save as)")
        path = Path(text).expanduser()
        if text.endswith(("/", os.sep)) or path.is_dir():
            path = path / self.data.path.stem
        return path

    def export_folder(self) -> Path:
        """The folder the files go to, created when needed: every file dialog of the export
        starts there (a dialog given a folder that does not exist opens in the program's working
        folder instead)."""
        folder = self.export_base_path().parent
        folder.mkdir(parents=True, exist_ok=True)
        return folder

    def request(self) -> ExportRequest:
        a, b = self.time_range()
        return ExportRequest(
            base_path=self.export_base_path(), t_from_s=a, t_to_s=b,
            angles_csv=self.want_csv.isChecked(), angles_mot=self.want_mot.isChecked(),
            sensors_csv=self.want_sensors.isChecked(), summary_csv=self.want_summary.isChecked(),
            opensim_mot=self.want_opensim_mot.isChecked(), c3d=self.want_c3d.isChecked(), bvh=self.want_bvh.isChecked(),
            opensense_sto=self.want_sto.isChecked())

    def start_export(self) -> None:
        """Write the files in the background; :attr:`result` holds what was written."""
        try:
            request = self.request()
        except ValueError as error:
            self.message.setText(str(error))
            return
        self.export_button.setEnabled(False)
        self.progress.setValue(0)
        self.message.setText("Exporting…")
        self._task = BackgroundTask(lambda progress: run_export(self.data, request, progress), self)
        self._task.progress.connect(lambda fraction: self.progress.setValue(int(round(100 * fraction))))
        self._task.succeeded.connect(self._exported)
        self._task.failed.connect(self._export_failed)
        self._task.start()

    def _exported(self, result: ExportResult) -> None:
        self.result = result
        self._update_buttons()
        self.progress.setValue(100)
        names = ", ".join(p.name for p in result.files)
        self.message.setText(f"Exported {result.rows} rows to {result.files[0].parent}: {names}")

    def _export_failed(self, message: str) -> None:
        log.warning("export failed: %s", message)
        self._update_buttons()
        self.message.setText(f"Export failed: {message}. Check the folder exists and is writable, then export again.")

    @property
    def busy(self) -> bool:
        return self._task is not None and self._task.isRunning()

    # -- summary files -----------------------------------------------------------------------
    def _ask_summary_csv(self) -> None:
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save Summary", self._suggested("joint_angle_summary.csv"),
                                                        "CSV (*.csv)")
        if path:
            self._save_or_say(self.save_summary_csv, path)

    def _save_or_say(self, save, path: str) -> None:
        """Run ``save(path)``; a failure is said in the dialog (and logged), never swallowed."""
        try:
            save(path)
        except (ValueError, OSError) as error:
            log.warning("summary not saved to %s: %s", path, error)
            self.message.setText(f"Summary not saved: {error}. Choose a writable folder and save again.")

    def save_summary_csv(self, path: str | Path) -> Path:
        a, b = self.time_range()
        written = write_summary_csv(path, self.summary_rows(), a, b, notes=self.data.provenance.lines())
        self.message.setText(f"Summary saved to {written}")
        return written

    def _ask_summary_png(self) -> None:
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save Summary Chart",
                                                        self._suggested("joint_angle_summary.png"), "PNG (*.png)")
        if path:
            self._save_or_say(self.save_summary_png, path)

    def _summary_chart(self) -> tuple[pg.GraphicsLayoutWidget, pg.PlotItem, pg.LabelItem]:
        """The off-screen chart of the summary PNG (the plot, and its caption below it): a child
        of the dialog, made once and deleted with it (a throwaway top-level plot was deleted at
        an arbitrary later moment, by Qt's deferred delete or Python's garbage collector, while
        its items could still be painted)."""
        if self._chart is None:
            chart = pg.GraphicsLayoutWidget(self)
            chart.setBackground("w")
            chart.setWindowFlags(QtCore.Qt.Window)  # its own size, not laid out in the dialog
            chart.setAttribute(QtCore.Qt.WA_DontShowOnScreen, True)
            plot = chart.addPlot(row=0, col=0)
            left = plot.getAxis("left")
            left.setWidth(260)
            plot.setLabel("bottom", "joint angle, min to max (°)")
            plot.showGrid(x=True, alpha=0.3)
            plot.invertY(True)
            caption = chart.addLabel(row=1, col=0, justify="left", color="#333333", size="8pt")
            self._chart = (chart, plot, caption)
        return self._chart

    def save_summary_png(self, path: str | Path, width: int = 1200) -> Path:
        """A bar chart of each column's range (min to max, degrees), written with pyqtgraph, with
        a caption saying what the result holds."""
        rows = self.summary_rows()
        lines = self.data.provenance.lines()
        # a long line (the headings' sources of a full suit) is wrapped rather than widening
        # the chart, which the exporter would then scale down to the width asked
        drawn = [part for line in lines for part in (textwrap.wrap(line, CAPTION_WRAP_CHARS) or [""])]
        height = 90 + 24 * len(rows) + 18 * len(drawn)
        chart, plot, caption = self._summary_chart()
        plot.clear()
        chart.resize(width, height)
        y = np.arange(len(rows))
        lows = np.array([r.minimum_deg for r in rows])
        highs = np.array([r.maximum_deg for r in rows])
        plot.addItem(pg.BarGraphItem(x0=lows, x1=highs, y=y, height=0.6, brush="#4f81bd", pen=None))
        ends = pg.ScatterPlotItem(np.concatenate([lows, highs]), np.concatenate([y, y]), symbol="s", size=6,
                                  brush="#1f3f66", pen=None)
        plot.addItem(ends)  # a joint that did not move still shows as a mark
        plot.getAxis("left").setTicks([[(i, angle_label(r.column)) for i, r in zip(y, rows)]])
        a, b = self.time_range()
        plot.setTitle(f"{self.data.path.name}: {a:.2f}–{b:.2f} s")
        plot.setYRange(-0.8, len(rows) - 0.2, padding=0)
        caption.setText("<br>".join(html.escape(line) for line in drawn))
        self._caption_lines = lines
        chart.show()
        QtWidgets.QApplication.processEvents()
        exporter = pg.exporters.ImageExporter(chart.ci)
        exporter.parameters()["width"] = width
        exporter.export(str(path))
        chart.hide()
        if not Path(path).exists():
            raise OSError(f"could not write {path}")
        self.message.setText(f"Summary chart saved to {path}")
        return Path(path)

    @property
    def summary_caption(self) -> str:
        """The caption of the last summary chart (plain text lines)."""
        return "\n".join(self._caption_lines)
