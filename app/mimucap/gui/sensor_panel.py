"""The sensor panel: one row per sensor (id, segment, rate, drops, latency, battery, magnetometer
calibration, fusion flags), a stale sensor flagged in red. Shows
:class:`~mimucap.session.live.SensorRow` values as they are; computes nothing."""

from __future__ import annotations

import math
from collections.abc import Sequence

from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap.session.live import SensorRow

COLUMNS = ("Sensor", "Segment", "Rate (Hz)", "Drops", "Latency p95 (ms)", "Battery (%)", "Mag. calibration",
           "Fusion flags", "State")
STALE_BRUSH = QtGui.QBrush(QtGui.QColor(255, 205, 205))
WARN_BRUSH = QtGui.QBrush(QtGui.QColor(255, 236, 200))


def _number(value: float, digits: int = 0) -> str:
    return "–" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def _age(seconds: float) -> str:
    if not math.isfinite(seconds):
        return ""
    if seconds < 3600:
        return f" ({seconds / 60:.0f} min ago)"
    if seconds < 86400 * 2:
        return f" ({seconds / 3600:.0f} h ago)"
    return f" ({seconds / 86400:.0f} days ago)"


class SensorPanel(QtWidgets.QTableWidget):
    """Table of sensors; :meth:`show_rows` replaces its contents.

    Only cells whose text or colour changed are touched, and the columns are fitted to their
    contents only when the set of sensors changes: with "resize to contents" on every change
    each ``setText`` re-measured the whole table (0.6 ms a cell, 25 ms a refresh with 17
    sensors; ``bench/bench_gui.py``).
    """

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(0, len(COLUMNS), parent)
        self.setObjectName("sensorPanel")
        self.setHorizontalHeaderLabels(COLUMNS)
        self.verticalHeader().setVisible(False)
        self.setEditTriggers(QtWidgets.QAbstractItemView.NoEditTriggers)
        self.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectRows)
        self.setSelectionMode(QtWidgets.QAbstractItemView.SingleSelection)
        self.horizontalHeader().setSectionResizeMode(QtWidgets.QHeaderView.Interactive)
        self.horizontalHeader().setStretchLastSection(True)
        self._shown_ids: tuple[str, ...] = ()

    def show_rows(self, rows: Sequence[SensorRow]) -> None:
        ids = tuple(row.sensor_id for row in rows)
        refit = ids != self._shown_ids
        if self.rowCount() != len(rows):
            self.setRowCount(len(rows))
        for r, row in enumerate(rows):
            if row.stale:
                state = "STALE: no data"
            elif row.state == "mag_uncalibrated":
                state = "magnetometer not calibrated"
            elif row.mag_field_warning:
                state = row.mag_field_warning
            else:
                state = "ok"
            values = (
                row.sensor_id, row.segment or "(not assigned)", _number(row.rate_hz, 1), str(row.drops),
                _number(row.latency_ms, 1), _number(row.battery_pct), row.mag_cal + (f" ({row.mag_cal_verdict})" if row.mag_cal_verdict else "") + _age(row.mag_cal_age_s),
                ", ".join(row.flags) or "–", state,
            )
            brush = STALE_BRUSH if row.stale else WARN_BRUSH if row.state != "ok" or row.mag_field_warning else QtGui.QBrush()
            for c, text in enumerate(values):
                item = self.item(r, c)
                if item is None:
                    item = QtWidgets.QTableWidgetItem()
                    self.setItem(r, c, item)
                if item.text() != text:
                    item.setText(text)
                    refit = refit or self._too_narrow(c, text)
                if item.background() != brush:
                    item.setBackground(brush)
        if refit:
            self._shown_ids = ids
            self.resizeColumnsToContents()

    def _too_narrow(self, column: int, text: str) -> bool:
        """Whether ``text`` no longer fits in ``column`` (the last column stretches)."""
        return column < len(COLUMNS) - 1 and self.fontMetrics().horizontalAdvance(text) + 12 > self.columnWidth(column)

    def row_of(self, sensor_id: str) -> int:
        for r in range(self.rowCount()):
            item = self.item(r, 0)
            if item is not None and item.text() == sensor_id:
                return r
        return -1

    def cell_text(self, sensor_id: str, column: str) -> str:
        """The text shown for ``sensor_id`` in ``column`` (one of :data:`COLUMNS`)."""
        r = self.row_of(sensor_id)
        if r < 0:
            raise KeyError(sensor_id)
        return self.item(r, COLUMNS.index(column)).text()

    def sizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt API)
        return QtCore.QSize(900, 180)
