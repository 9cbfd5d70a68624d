"""Library → Trend: one subject's results of a clinical test across visits, as a chart with the
published reference, a table, and a printable PDF (:func:`mimucap.gui.pdf_report.write_trend_report`).

The results are those the library keeps (:mod:`mimucap.session.recorded.clinical_test_results`): every
guided test in the window, and ``mimucap protocol`` run on a session of the library.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyqtgraph as pg
from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap.gui.pdf_report import write_trend_report
from mimucap.gui.screen_fit import fit_on_screen
from mimucap.io.library import Library
from mimucap.session.recorded.clinical_test_results import (
    MAIN_RESULT, QUANTITIES, RESULT_PREFIX, Visit, format_quantity, subject_trend,
)
from mimucap.session.views.calibration_age import local_time_text
from mimucap.session.recorded.clinical_tests import RESULT_KEYS, TEST_NAMES


class TrendDialog(QtWidgets.QDialog):
    """The trend of ``subject_id``'s clinical test results in ``library``."""

    def __init__(self, library: Library, subject_id: str, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("trendDialog")
        self.setWindowTitle(f"Trend of {subject_id}")
        self.library = library
        self.subject_id = subject_id
        self.visits: list[Visit] = []
        self.test_combo = QtWidgets.QComboBox(self)
        self.test_combo.setObjectName("trendTest")
        self.key_combo = QtWidgets.QComboBox(self)
        self.key_combo.setObjectName("trendResult")
        self.key_combo.setSizeAdjustPolicy(QtWidgets.QComboBox.AdjustToContents)
        counts = {test: len(subject_trend(library, subject_id, test)) for test in TEST_NAMES}
        for test, name in TEST_NAMES.items():
            self.test_combo.addItem(f"{name} ({counts[test]} visit{'s' if counts[test] != 1 else ''})", test)
        self.test_combo.setCurrentIndex(max(range(len(TEST_NAMES)), key=lambda k: counts[list(TEST_NAMES)[k]]))
        self.plot = pg.PlotWidget(self, background="w")
        self.plot.setObjectName("trendPlot")
        self.plot.showGrid(y=True, alpha=0.3)
        self.plot.setMenuEnabled(False)
        self.plot.hideButtons()
        self.table = QtWidgets.QTableWidget(0, 3, self)
        self.table.setObjectName("trendTable")
        self.table.setHorizontalHeaderLabels(["Recorded", "Session", "Result"])
        self.table.verticalHeader().setVisible(False)
        self.table.setEditTriggers(QtWidgets.QAbstractItemView.NoEditTriggers)
        header = self.table.horizontalHeader()
        header.setSectionResizeMode(0, QtWidgets.QHeaderView.ResizeToContents)
        header.setSectionResizeMode(1, QtWidgets.QHeaderView.Stretch)
        header.setSectionResizeMode(2, QtWidgets.QHeaderView.ResizeToContents)
        self.note = QtWidgets.QLabel(self)
        self.note.setWordWrap(True)
        self.pdf_button = QtWidgets.QPushButton("Save PDF…", self)
        self.pdf_button.clicked.connect(self._ask_pdf)
        close = QtWidgets.QPushButton("Close", self)
        close.clicked.connect(self.close)
        choices = QtWidgets.QHBoxLayout()
        for text, widget in (("Test", self.test_combo), ("Result", self.key_combo)):
            label = QtWidgets.QLabel(text, self)
            label.setBuddy(widget)
            choices.addWidget(label)
            choices.addWidget(widget)
        choices.addStretch(1)
        buttons = QtWidgets.QHBoxLayout()
        buttons.addStretch(1)
        buttons.addWidget(self.pdf_button)
        buttons.addWidget(close)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addLayout(choices)
        layout.addWidget(self.plot, 3)
        layout.addWidget(self.note)
        layout.addWidget(self.table, 2)
        layout.addLayout(buttons)
        QtWidgets.QShortcut(QtGui.QKeySequence.Close, self, activated=self.close)
        fit_on_screen(self, 760, 640, parent)
        self.test_combo.currentIndexChanged.connect(self._test_chosen)
        self.key_combo.currentIndexChanged.connect(self._draw)
        self._test_chosen()

    @property
    def test(self) -> str:
        return str(self.test_combo.currentData())

    @property
    def key(self) -> str:
        return str(self.key_combo.currentData() or MAIN_RESULT[self.test])

    def _test_chosen(self, *_args) -> None:
        self.visits = subject_trend(self.library, self.subject_id, self.test)
        self.key_combo.blockSignals(True)
        self.key_combo.clear()
        for key in RESULT_KEYS[self.test]:
            name, unit, _digits = QUANTITIES[key]
            self.key_combo.addItem(f"{name} ({unit})" if unit else name, key)
        self.key_combo.blockSignals(False)
        self._draw()

    def reference(self) -> dict | None:
        """The reference stored with the latest visit (the subject's age at that visit)."""
        if not self.visits:
            return None
        stored = self.library.result(self.visits[-1].session, RESULT_PREFIX + self.test) or {}
        return stored.get("reference")

    def _draw(self, *_args) -> None:
        key = self.key
        name, unit, _digits = QUANTITIES[key]
        self.plot.clear()
        self.plot.setLabel("left", name, units=None if not unit else unit)
        values = np.array([np.nan if v.values.get(key) is None else float(v.values[key]) for v in self.visits])
        x = np.arange(len(self.visits), dtype=float)
        reference = self.reference()
        if reference is not None and reference.get("key") == key:
            low, high = ((reference.get("ci95_low"), reference.get("ci95_high")) if "ci95_low" in reference
                         else (reference.get("p25"), reference.get("p75")))
            if low is not None and high is not None and len(x):
                band = pg.LinearRegionItem((float(low), float(high)), orientation="horizontal", movable=False,
                                           brush=pg.mkBrush(120, 190, 120, 60), pen=pg.mkPen(None))
                self.plot.addItem(band)
            for level in (reference.get("mean"), reference.get("predicted"), reference.get("lower_limit")):
                if level is not None:
                    self.plot.addItem(pg.InfiniteLine(float(level), angle=0, pen=pg.mkPen((60, 140, 60), width=1,
                                                                                           style=QtCore.Qt.DashLine)))
        if len(x):
            self.plot.plot(x, values, pen=pg.mkPen((30, 100, 200), width=2), symbol="o", symbolSize=9,
                           symbolBrush=(30, 100, 200), connect="finite")
        axis = self.plot.getAxis("bottom")
        axis.setTicks([[(k, local_time_text(v.recorded_utc).split(",")[0]) for k, v in enumerate(self.visits)]])
        self.plot.setXRange(-0.5, max(len(x) - 0.5, 0.5), padding=0.02)
        self.table.setRowCount(len(self.visits))
        for row, visit in enumerate(reversed(self.visits)):
            for column, text in enumerate((local_time_text(visit.recorded_utc), visit.session,
                                           format_quantity(key, visit.values.get(key)))):
                item = QtWidgets.QTableWidgetItem(text)
                if column == 2:
                    item.setTextAlignment(int(QtCore.Qt.AlignRight | QtCore.Qt.AlignVCenter))
                self.table.setItem(row, column, item)
        finite = values[np.isfinite(values)] if len(values) else values
        if not self.visits:
            self.note.setText(f"No {TEST_NAMES[self.test]} of {self.subject_id} in the library yet: run one from "
                              "Assess → Clinical Test, or `mimucap protocol` on a session of the library.")
        elif reference is None:
            self.note.setText("No reference for this subject (age or sex not recorded, or none published).")
        else:
            change = "" if len(finite) < 2 else (f" Change since the first visit: "
                                                 f"{format_quantity(key, finite[-1] - finite[0])}.")
            self.note.setText(f"Reference: {reference.get('group', '')}, {reference.get('statistic', '')} "
                              f"({reference.get('source', '')}).{change}")
        self.pdf_button.setEnabled(bool(self.visits))

    def _ask_pdf(self) -> None:
        suggested = str(self.library.root / f"{self.subject_id}_{self.test}_trend.pdf")
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save Trend", suggested, "PDF (*.pdf)")
        if path:
            self.save_pdf(path if path.lower().endswith(".pdf") else path + ".pdf")

    def save_pdf(self, path: str | Path) -> Path:
        return write_trend_report(path, self.subject_id, self.test, self.key, self.visits, self.reference())
