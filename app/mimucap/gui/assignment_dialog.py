"""Sensor → segment assignment: one combo box per sensor; the choice is remembered."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from PyQt5 import QtCore, QtWidgets

from mimucap.core.clinical_names import segment_name
from mimucap.gui.settings import load_json, save_json

NOT_WORN = "(not worn)"
SETTINGS_KEY = "assignment/sensor_segments"


def remembered_assignment() -> dict[str, str]:
    """Sensor id → segment as saved last time (empty the first time)."""
    value = load_json(SETTINGS_KEY, {})
    return {str(k): str(v) for k, v in value.items()} if isinstance(value, dict) else {}


def remember_assignment(assignment: Mapping[str, str]) -> None:
    save_json(SETTINGS_KEY, dict(assignment))


class SegmentCombo(QtWidgets.QComboBox):
    """A combo box that takes the mouse wheel only once the user has clicked into it: scrolling
    the table over it scrolls the table instead of changing the sensor's segment."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setFocusPolicy(QtCore.Qt.StrongFocus)

    def wheelEvent(self, event) -> None:  # noqa: N802 (Qt API)
        if self.hasFocus():
            super().wheelEvent(event)
        else:
            event.ignore()  # goes on to the table, which scrolls


class AssignmentDialog(QtWidgets.QDialog):
    """Edit which segment each sensor is worn on; :meth:`assignment` gives the result."""

    def __init__(self, parent: QtWidgets.QWidget | None, sensor_ids: Sequence[str], segments: Sequence[str],
                 current: Mapping[str, str]) -> None:
        super().__init__(parent)
        self.setWindowTitle("Assign Sensors to Segments")
        self.setObjectName("assignmentDialog")
        self.table = QtWidgets.QTableWidget(len(sensor_ids), 2, self)
        self.table.setHorizontalHeaderLabels(["Sensor", "Segment"])
        self.table.verticalHeader().setVisible(False)
        self.table.horizontalHeader().setStretchLastSection(True)
        self.combos: dict[str, QtWidgets.QComboBox] = {}
        for row, sid in enumerate(sensor_ids):
            item = QtWidgets.QTableWidgetItem(sid)
            self.table.setItem(row, 0, item)
            combo = SegmentCombo(self.table)
            combo.addItem(NOT_WORN, None)
            for segment in segments:  # shown by its clinical name, kept by its machine name
                combo.addItem(segment_name(segment), segment)
            combo.setCurrentIndex(max(combo.findData(current.get(sid)), 0))
            self.table.setCellWidget(row, 1, combo)
            self.combos[sid] = combo
        self.error_label = QtWidgets.QLabel(self)
        self.error_label.setStyleSheet("color: #b00020")
        buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.Ok | QtWidgets.QDialogButtonBox.Cancel, self)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(QtWidgets.QLabel("Each segment carries at most one sensor.", self))
        layout.addWidget(self.table)
        layout.addWidget(self.error_label)
        layout.addWidget(buttons)
        self.resize(420, 460)

    def set_segment(self, sensor_id: str, segment: str | None) -> None:
        """Choose ``segment`` (machine name; ``None``: not worn) for ``sensor_id``."""
        combo = self.combos[sensor_id]
        index = 0 if segment is None else combo.findData(segment)
        if index < 0:
            raise ValueError(f"sensor {sensor_id}: unknown segment {segment!r}")
        combo.setCurrentIndex(index)

    def assignment(self) -> dict[str, str]:
        """Sensor id → segment (machine names) of the sensors worn."""
        return {sid: c.currentData() for sid, c in self.combos.items() if c.currentData() is not None}

    def accept(self) -> None:
        chosen = self.assignment()
        taken: dict[str, str] = {}
        for sid, segment in chosen.items():
            if segment in taken:
                self.error_label.setText(f"{segment_name(segment)} is given to both {taken[segment]} and {sid}")
                return
            taken[segment] = sid
        remember_assignment(chosen)
        super().accept()
