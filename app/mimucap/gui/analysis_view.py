"""The analysis of a reviewed session (the page of the main window's Analysis workspace): a
Gait tab, a ROM tab, a Doubtful data tab, and the report.

* **Gait**: what was found (strides analysed and refused, bouts, turns, which sensors gave
  events and lengths), the parameter table (per side and both: mean ± SD, CV, symmetry), the
  stride list with the reason of every refused stride, and one joint angle over the gait cycle
  (chosen in a list: left and right mean ± SD, the stance/swing boundaries, a normative band
  once a band file is loaded).
* **ROM**: the ROM protocol's results (active ROM, peaks, left/right difference, reference
  value), and the ROM of every movement between any two markers.
* **Report…** writes the PDF report (:mod:`mimucap.gui.pdf_report`); **Save tables…** writes every
  analysis table as CSV.

Without a body calibration the gait tab shows the temporal parameters alone, and the curves,
the ROM tab and the report are disabled, each saying why
(:data:`mimucap.session.recorded.analysis.NEEDS_BODY_CALIBRATION`).

The analysis runs off the GUI thread (:func:`mimucap.session.recorded.analysis.analyse_review`); this
view only shows it.
"""

from __future__ import annotations

import math
from pathlib import Path

import pyqtgraph as pg
from PyQt5 import QtCore, QtWidgets

from mimucap.core.wording import plural
from mimucap.core.analysis import rom as rom_core
from mimucap.core.analysis.gait_cycle import CYCLE_PERCENT, NormativeBand
from mimucap.gui.background_task import BackgroundTask
from mimucap.gui.pdf_report import write_report
from mimucap.gui.status_line import page_layout, progress_bar, status_line
from mimucap.io.normative_bands import read_normative_bands
from mimucap.session.recorded.analysis import (
    DOUBT_HEADER,
    GAIT_PARAMETER_HEADER,
    ROM_HEADER,
    CurveGroup,
    SessionAnalysis,
    analyse_review,
    curve_groups,
    format_value,
    gait_parameter_rows,
    rom_between,
    rom_rows,
    write_analysis_csv,
)
from mimucap.session.recorded.review import ReviewData

SIDE_PENS = {"left": (30, 100, 200), "right": (200, 50, 40)}


def _fill_table(table: QtWidgets.QTableWidget, header: list[str], rows: list[list[str]],
                text_columns: tuple[int, ...] = (0,)) -> None:
    """``rows`` in ``table`` under ``header``: read-only, figures right-aligned, the
    ``text_columns`` left-aligned."""
    table.clear()
    table.setColumnCount(len(header))
    table.setHorizontalHeaderLabels(header)
    table.setRowCount(len(rows))
    for r, row in enumerate(rows):
        for c, cell in enumerate(row):
            item = QtWidgets.QTableWidgetItem(str(cell))
            item.setFlags(item.flags() & ~QtCore.Qt.ItemIsEditable)
            if c not in text_columns:
                item.setTextAlignment(int(QtCore.Qt.AlignRight | QtCore.Qt.AlignVCenter))
            table.setItem(r, c, item)
    table.resizeColumnsToContents()
    table.horizontalHeader().setStretchLastSection(True)


class AnalysisView(QtWidgets.QWidget):
    """Analysis of ``data`` (a loaded review); call :meth:`run` once shown; :attr:`analysed`
    is emitted when the results are shown."""

    analysed = QtCore.pyqtSignal()

    def __init__(self, parent: QtWidgets.QWidget | None, data: ReviewData) -> None:
        super().__init__(parent)
        self.setObjectName("analysisView")
        self.data = data
        self.analysis: SessionAnalysis | None = None
        self.bands: dict[tuple[str, str], NormativeBand] = {}
        self._task: BackgroundTask | None = None

        self.tabs = QtWidgets.QTabWidget(self)
        self.gait_tab = QtWidgets.QWidget(self)
        self.rom_tab = QtWidgets.QWidget(self)
        self.doubt_tab = QtWidgets.QWidget(self)
        self.tabs.addTab(self.gait_tab, "Gait")
        self.tabs.addTab(self.rom_tab, "ROM")
        self.tabs.addTab(self.doubt_tab, "Doubtful data")
        self.doubt_label = QtWidgets.QLabel("Analysing…", self.doubt_tab)
        self.doubt_label.setWordWrap(True)
        self.doubt_table = QtWidgets.QTableWidget(self.doubt_tab)
        self.doubt_table.setObjectName("doubtTable")
        doubt_layout = QtWidgets.QVBoxLayout(self.doubt_tab)
        doubt_layout.addWidget(self.doubt_label)
        doubt_layout.addWidget(self.doubt_table, 1)

        # -- gait tab ------------------------------------------------------------------------
        self.gait_summary = QtWidgets.QLabel("Analysing…", self.gait_tab)
        self.gait_summary.setWordWrap(True)
        self.limits_label = QtWidgets.QLabel(self)
        self.limits_label.setObjectName("analysisLimits")
        self.limits_label.setWordWrap(True)
        self.limits_label.setStyleSheet("color: #b00020; font-weight: bold")
        self.limits_label.hide()
        self.parameters_table = QtWidgets.QTableWidget(self.gait_tab)
        self.parameters_table.setObjectName("parametersTable")
        self.strides_table = QtWidgets.QTableWidget(self.gait_tab)
        self.strides_table.setObjectName("stridesTable")
        # Its last column (why a stride was refused) is as wide as the longest reason: its title
        # at the column's start stays in view while the table is scrolled to the left.
        self.strides_table.horizontalHeader().setDefaultAlignment(QtCore.Qt.AlignLeft | QtCore.Qt.AlignVCenter)
        self.curve_choice = QtWidgets.QComboBox(self.gait_tab)
        self.curve_choice.setObjectName("curveChoice")
        self.curve_choice.currentIndexChanged.connect(self._show_curve)
        self.band_button = QtWidgets.QPushButton("Normative band…", self.gait_tab)
        self.band_button.clicked.connect(self.ask_bands)
        self.band_label = QtWidgets.QLabel("No normative band loaded.", self.gait_tab)
        self.curve_plot = pg.PlotWidget(self.gait_tab, background="w")
        self.curve_plot.setObjectName("cyclePlot")
        self.curve_plot.setLabel("bottom", "gait cycle", units="%")
        self.curve_plot.setLabel("left", "angle", units="°")
        self.curve_plot.showGrid(x=True, y=True, alpha=0.2)
        self.curve_plot.addLegend(offset=(10, 10))
        curve_bar = QtWidgets.QHBoxLayout()
        curve_bar.addWidget(QtWidgets.QLabel("Joint angle:"))
        curve_bar.addWidget(self.curve_choice, 1)
        curve_bar.addWidget(self.band_button)
        left = QtWidgets.QVBoxLayout()
        left.addWidget(self.gait_summary)
        left.addWidget(self.parameters_table, 3)
        left.addWidget(QtWidgets.QLabel("Strides (refused ones say why):"))
        left.addWidget(self.strides_table, 2)
        right = QtWidgets.QVBoxLayout()
        right.addLayout(curve_bar)
        right.addWidget(self.curve_plot, 1)
        right.addWidget(self.band_label)
        gait_layout = QtWidgets.QHBoxLayout(self.gait_tab)
        gait_layout.addLayout(left, 3)
        gait_layout.addLayout(right, 2)

        # -- ROM tab -------------------------------------------------------------------------
        self.rom_label = QtWidgets.QLabel("ROM protocol:", self.rom_tab)
        self.rom_table = QtWidgets.QTableWidget(self.rom_tab)
        self.rom_table.setObjectName("romTable")
        self.marker_from = QtWidgets.QComboBox(self.rom_tab)
        self.marker_to = QtWidgets.QComboBox(self.rom_tab)
        for index, marker in enumerate(data.markers):
            text = f"{marker.t_s:.2f} s  {rom_core.marker_words(marker.label)}"
            self.marker_from.addItem(text, marker.t_s)
            self.marker_to.addItem(text, marker.t_s)
        if len(data.markers) > 1:
            self.marker_to.setCurrentIndex(1)
        self.marker_button = QtWidgets.QPushButton("ROM between these markers", self.rom_tab)
        self.marker_button.setEnabled(len(data.markers) >= 2)
        self.marker_button.clicked.connect(self.compute_marker_rom)
        self.marker_table = QtWidgets.QTableWidget(self.rom_tab)
        self.marker_table.setObjectName("markerRomTable")
        self.marker_message = QtWidgets.QLabel("" if len(data.markers) >= 2 else "The recording has fewer than two markers.",
                                               self.rom_tab)
        marker_bar = QtWidgets.QHBoxLayout()
        marker_bar.addWidget(QtWidgets.QLabel("From"))
        marker_bar.addWidget(self.marker_from, 1)
        marker_bar.addWidget(QtWidgets.QLabel("to"))
        marker_bar.addWidget(self.marker_to, 1)
        marker_bar.addWidget(self.marker_button)
        rom_layout = QtWidgets.QVBoxLayout(self.rom_tab)
        rom_layout.addWidget(self.rom_label)
        rom_layout.addWidget(self.rom_table, 1)
        rom_layout.addWidget(QtWidgets.QLabel("Any recording: the ROM of every movement between two markers"))
        rom_layout.addLayout(marker_bar)
        rom_layout.addWidget(self.marker_message)
        rom_layout.addWidget(self.marker_table, 1)

        # -- buttons -------------------------------------------------------------------------
        self.report_button = QtWidgets.QPushButton("Report…", self)
        self.report_button.setObjectName("reportButton")
        self.report_button.clicked.connect(self.ask_report)
        self.csv_button = QtWidgets.QPushButton("Save tables…", self)
        self.csv_button.clicked.connect(self.ask_csv)
        self.notes = QtWidgets.QLineEdit(self)
        self.notes.setPlaceholderText("Notes for the report")
        for button in (self.report_button, self.csv_button):
            button.setEnabled(False)
        bottom = QtWidgets.QHBoxLayout()
        bottom.addWidget(self.notes, 1)
        bottom.addWidget(self.csv_button)
        bottom.addWidget(self.report_button)
        layout = page_layout(self)
        layout.addWidget(self.limits_label)
        layout.addWidget(self.tabs, 1)
        layout.addLayout(bottom)
        self._status = status_line(self, layout)
        self.progress = progress_bar(self._status)

    def statusBar(self) -> QtWidgets.QStatusBar:  # noqa: N802 (as QMainWindow's)
        """The analysis' status line (progress, files written)."""
        return self._status

    # -- analysis ------------------------------------------------------------------------------
    def run(self) -> None:
        """Analyse in the background; :attr:`analysed` is emitted when shown."""
        self.statusBar().showMessage("Analysing…")
        self._task = BackgroundTask(lambda progress: analyse_review(self.data, progress), self)
        self._task.progress.connect(lambda f: self.progress.setValue(int(round(100 * f))))
        self._task.succeeded.connect(self.show_analysis)
        self._task.failed.connect(lambda message: self.statusBar().showMessage(f"Analysis failed: {message}"))
        self._task.start()

    def show_analysis(self, analysis: SessionAnalysis) -> None:
        self.analysis = analysis
        self.progress.hide()
        gait = analysis.gait
        if gait is None or not gait.analysed:
            self.gait_summary.setText(f"No gait analysis: {analysis.gait_problem or 'no straight-walking stride'}.")
        else:
            refused = len(gait.strides) - len(gait.analysed)
            sources = "; ".join(f"{side}: {text}" for side, text in gait.sources.items())
            turns = ", ".join(f"{t.angle_deg:+.0f}° at {t.start_s:.1f} s" for t in gait.turns) or "none"
            self.gait_summary.setText(
                f"<b>{len(gait.analysed)}</b> straight strides analysed, {refused} refused; "
                f"{plural(len(gait.bouts), 'walking bout')}; turns: {turns}.<br><small>{sources}</small>")
            _fill_table(self.parameters_table, list(GAIT_PARAMETER_HEADER),
                        [row.cells() for row in gait_parameter_rows(gait)])
            _fill_table(self.strides_table, ["Foot", "IC (s)", "FC (s)", "Next IC (s)", "Time (s)", "Length (m)",
                                             "Heading (°)", "Refused because"],
                        [[s.side, format_value(s.ic_s), format_value(s.fc_s), format_value(s.next_ic_s),
                          format_value(s.stride_time_s), format_value(s.stride_length_m),
                          format_value(s.heading_change_deg, 0), s.refused_because or "analysed"]
                         for s in gait.strides], text_columns=(0, 7))
        self.curve_choice.blockSignals(True)
        self.curve_choice.clear()
        for group in curve_groups([analysis]):
            self.curve_choice.addItem(group.label, group)
        self.curve_choice.blockSignals(False)
        knee = next((k for k in range(self.curve_choice.count())
                     if (self.curve_choice.itemData(k).joint, self.curve_choice.itemData(k).axis) == ("knee", "flexion")), 0)
        self.curve_choice.setCurrentIndex(knee)
        self._show_curve()
        if analysis.rom:
            self.rom_label.setText("ROM protocol results (reference: healthy adults, "
                                   f"{rom_core.REFERENCE_SOURCE}; shoulder: humeral elevation in the movement's plane):")
            _fill_table(self.rom_table, list(ROM_HEADER), [row.cells() for row in rom_rows(analysis.rom)])
        else:
            self.rom_label.setText("ROM protocol: this recording has no ROM protocol markers.")
        if len(self.data.markers) >= 2 and analysis.calibrated:
            self.compute_marker_rom()
        if analysis.doubt:
            self.doubt_label.setText("The joint angles below may be wrong where marked (the orientation of a sensor "
                                     "they use, or the body calibration, is doubtful); the results include them.")
        else:
            self.doubt_label.setText("Every joint angle passed the checks: none is marked doubtful.")
        _fill_table(self.doubt_table, list(DOUBT_HEADER), [row.cells() for row in analysis.doubt])
        for button in (self.report_button, self.csv_button):
            button.setEnabled(True)
        self._show_limits(analysis)
        self.statusBar().showMessage("Analysis done.", 5000)
        self.analysed.emit()

    def _show_limits(self, analysis: SessionAnalysis) -> None:
        """Disable what the analysis cannot give (without a body calibration), saying why."""
        reason = analysis.limits
        self.limits_label.setText(f"Temporal gait parameters only: {reason}. Calibrate the body (or give the "
                                  "session a body calibration) for the rest." if reason else "")
        self.limits_label.setVisible(bool(reason))
        for widget in (self.curve_choice, self.band_button, self.curve_plot, self.report_button, self.marker_button):
            if reason:
                widget.setEnabled(False)
            widget.setToolTip(reason)
        self.tabs.setTabEnabled(self.tabs.indexOf(self.rom_tab), not reason)
        self.tabs.setTabToolTip(self.tabs.indexOf(self.rom_tab), reason)
        if reason:
            self.rom_label.setText(f"ROM: {reason}.")

    def _show_curve(self) -> None:
        self.curve_plot.clear()
        group: CurveGroup | None = self.curve_choice.currentData()
        if self.analysis is None or group is None:
            return
        band = self.bands.get((group.joint, group.axis))
        if band is not None:
            low, high = band.on_cycle()
            lower = pg.PlotDataItem(CYCLE_PERCENT, low, pen=pg.mkPen((150, 150, 150)))
            upper = pg.PlotDataItem(CYCLE_PERCENT, high, pen=pg.mkPen((150, 150, 150)))
            self.curve_plot.addItem(lower)
            self.curve_plot.addItem(upper)
            self.curve_plot.addItem(pg.FillBetweenItem(lower, upper, brush=pg.mkBrush(150, 150, 150, 70)))
        for curve in group.curves[0].values():
            colour = SIDE_PENS[curve.side]
            upper = pg.PlotDataItem(CYCLE_PERCENT, curve.mean_deg + curve.sd_deg, pen=pg.mkPen(colour + (60,)))
            lower = pg.PlotDataItem(CYCLE_PERCENT, curve.mean_deg - curve.sd_deg, pen=pg.mkPen(colour + (60,)))
            self.curve_plot.addItem(upper)
            self.curve_plot.addItem(lower)
            self.curve_plot.addItem(pg.FillBetweenItem(lower, upper, brush=pg.mkBrush(colour + (45,))))
            self.curve_plot.plot(CYCLE_PERCENT, curve.mean_deg, pen=pg.mkPen(colour, width=2),
                                 name=f"{curve.side} (n = {curve.n_strides})")
            if math.isfinite(curve.stance_percent):
                self.curve_plot.addItem(pg.InfiniteLine(curve.stance_percent, angle=90,
                                                        pen=pg.mkPen(colour, width=1, style=QtCore.Qt.DashLine)))
        self.curve_plot.setXRange(0, 100, padding=0.01)

    def compute_marker_rom(self) -> None:
        start, end = self.marker_from.currentData(), self.marker_to.currentData()
        if start is None or end is None:
            return
        start, end = min(start, end), max(start, end)
        try:
            results = rom_between(self.data, start, end)
        except ValueError as error:
            self.marker_message.setText(str(error))
            self.marker_table.clear()
            return
        found = {k: r for k, r in results.items() if r.repetitions}
        self.marker_message.setText(f"{start:.2f}–{end:.2f} s: {plural(len(found), 'movement')} with at least one repetition "
                                    f"of 10° or more.")
        _fill_table(self.marker_table, list(ROM_HEADER), [row.cells() for row in rom_rows(found)])

    # -- files ---------------------------------------------------------------------------------
    def load_bands(self, path: str | Path) -> None:
        self.bands = read_normative_bands(path)
        sources = "; ".join(sorted({b.source for b in self.bands.values()}))
        self.band_label.setText(f"Normative band: {Path(path).name} ({sources})")
        self._show_curve()

    def ask_bands(self) -> None:
        path, _ = QtWidgets.QFileDialog.getOpenFileName(self, "Normative band file", str(self.data.path.parent),
                                                        "Normative bands (*.csv)")
        if path:
            try:
                self.load_bands(path)
            except (OSError, ValueError) as error:
                QtWidgets.QMessageBox.warning(self, "Normative band", str(error))

    def write_report(self, path: str | Path) -> Path:
        return write_report(path, self.analysis, self.bands, self.notes.text())

    def ask_report(self) -> None:
        default = str(self.data.path.with_suffix(".report.pdf"))
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save report", default, "PDF (*.pdf)")
        if path:
            try:
                written = self.write_report(path if path.lower().endswith(".pdf") else path + ".pdf")
                self.statusBar().showMessage(f"Report written: {written}", 8000)
            except (OSError, ValueError) as error:
                QtWidgets.QMessageBox.warning(self, "Report", str(error))

    def ask_csv(self) -> None:
        folder = QtWidgets.QFileDialog.getExistingDirectory(self, "Folder for the analysis tables", str(self.data.path.parent))
        if folder:
            try:
                written = write_analysis_csv(folder, self.analysis)
                self.statusBar().showMessage(f"{len(written)} tables written to {folder}", 8000)
            except OSError as error:
                QtWidgets.QMessageBox.warning(self, "Save tables", str(error))

    def shutdown(self, wait_ms: int = 0) -> None:
        """Let the analysis go: a result still being computed is no longer shown (given
        ``wait_ms`` to finish: the program closing)."""
        if self._task is not None:
            self._task.let_go(wait_ms)
