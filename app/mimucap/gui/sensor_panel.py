"""The sensor panel: one row per sensor (id, segment, rate, samples lost, packets refused, delay,
battery, radio signal, magnetometer calibration, the orientation filter's notes), its headings in
words with the technical detail on hover (:data:`COLUMN_TOOLTIPS`), a stale sensor flagged in red,
a sensor whose orientation is doubtful in orange with the reasons in its State column; a
magnetometer calibration that is not good (its standing: another device's, a local field that
no longer fits, too old; or a stored one not used) named in the State column, the device each
sensor is in the tooltip of its id.
Orientation-only sensors (on-board fusion, e.g. SlimeVR trackers) read "on-board" under
magnetometer calibration. Shows :class:`~mimucap.session.live.sensor_rows.SensorRow` values as they are,
from the live session's ``status`` event (:meth:`SensorPanel.set_session`); computes nothing.

The "Refused" column counts the packets of a sensor that the source received and refused
(stale sequence number, value out of range, bad checksum…); its tooltip lists them by reason,
so that a sensor shown STALE while its packets still arrive explains itself.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap.acquisition.rejections import Rejection
from mimucap.core.clinical_names import segment_name
from mimucap.session.live.sensor_rows import SensorRow
from mimucap.session.views.calibration_age import describe_age, quality_word

COLUMNS = ("Sensor", "Segment", "Rate (Hz)", "Lost", "Refused", "Delay (ms)", "Battery (%)",
           "Radio (dBm)", "Magnetometer", "Filter notes", "State")
#: The technical detail behind each column's heading, on hover.
COLUMN_TOOLTIPS = {
    "Sensor": "The sensor's id; hover over an id for the device it is.",
    "Segment": "The body segment the sensor is worn on (Session → Assign Sensors…).",
    "Rate (Hz)": "Samples received per second.",
    "Lost": "Samples lost on the way (gaps in the sensor's packet numbers): radio range or interference.",
    "Refused": "Packets that arrived but were refused (damaged, repeated, out of range); hover over a count "
               "for the reasons.",
    "Delay (ms)": "How late the samples arrive: the 95th percentile of the time from the sensor's clock to the "
                  "program's, in milliseconds.",
    "Battery (%)": "The sensor's battery charge, as the sensor reports it.",
    "Radio (dBm)": "The radio signal strength the sensor reports (RSSI, dBm): nearer 0 is stronger; below about "
                   "−80 dBm samples start to get lost.",
    "Magnetometer": "The magnetometer calibration applied to the sensor: its quality and age.",
    "Filter notes": "What the orientation filter notes about the sensor now: still (at rest), magnetic field "
                    "disturbed (the heading relies on the gyroscope), fast movement (the tilt relies on the "
                    "gyroscope), starting, magnetometer offset corrected.",
    "State": "Whether the sensor's orientation can be trusted now, and if not, why.",
}
#: What each refusal reason means to the person looking at the panel.
REJECTION_TEXT = {
    Rejection.TOO_SHORT: "packet too short",
    Rejection.OVERSIZED: "packet or line too long",
    Rejection.BAD_MAGIC: "not a MimuCap packet",
    Rejection.UNSUPPORTED_VERSION: "protocol version not supported (update the sensor's firmware)",
    Rejection.UNKNOWN_TYPE: "unknown message type",
    Rejection.UNKNOWN_FLAGS: "unknown payload flags",
    Rejection.LENGTH_MISMATCH: "payload length does not match its flags",
    Rejection.BAD_CHECKSUM: "checksum wrong (damaged in transit)",
    Rejection.MALFORMED_LINE: "malformed text line",
    Rejection.BAD_FIELD: "a field is not a number",
    Rejection.NON_FINITE: "a value is NaN or infinite",
    Rejection.OUT_OF_RANGE: "a value outside the sensor's physical range",
    Rejection.UNKNOWN_SENSOR: "a sensor id this source does not expect",
    Rejection.UNKNOWN_ADDRESS: "a sender this source does not accept",
    Rejection.UNPAIRED_DEVICE: "a device not paired with this suit (or not identified yet)",
    Rejection.STALE_SEQUENCE: "stale: a repeated or older packet number (a sensor restarted, or packets arrive twice)",
    Rejection.UNEXPECTED_MESSAGE: "a message not expected here",
    Rejection.QUEUE_OVERFLOW: "the program could not keep up; the sample was discarded",
    Rejection.UNDECODABLE: "the packet could not be decoded",
}
REFUSED_COLUMN = COLUMNS.index("Refused")
STALE_BRUSH = QtGui.QBrush(QtGui.QColor(255, 205, 205))
WARN_BRUSH = QtGui.QBrush(QtGui.QColor(255, 236, 200))


def _number(value: float, digits: int = 0) -> str:
    return "–" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def rejections_tooltip(counts: dict[str, int]) -> str:
    """The packets refused, one reason a line, most frequent first ("" when none)."""
    lines = []
    for reason, count in sorted(counts.items(), key=lambda item: (-item[1], item[0])):
        try:
            text = REJECTION_TEXT[Rejection(reason)]
        except ValueError:
            text = reason.replace("_", " ")
        lines.append(f"{count} × {text}")
    return "Packets refused:\n" + "\n".join(lines) if lines else "No packet of this sensor was refused."


def device_tooltip(row: SensorRow) -> str:
    """Which device the sensor is (its calibrations are kept for it), or why that is not known."""
    if row.device is None or not row.device.settled:
        return "Device: not told yet by the source."
    if row.device.known:
        return f"Device: {row.device.describe()} (its magnetometer calibration is kept for this device)."
    return f"Device not known: {row.device.missing}. A calibration made for it cannot be checked against the device."


def _age(seconds: float) -> str:
    """`` (3 hours ago)`` after the calibration state ("" when the date is unknown)."""
    if not math.isfinite(seconds):
        return ""
    return f" ({describe_age(seconds / 86400.0)})"


class SensorPanel(QtWidgets.QTableWidget):
    """Table of sensors; :meth:`show_rows` replaces its contents, called by the ``status`` event
    of the session it follows (:meth:`set_session`).

    Only cells whose text or colour changed are touched, and the columns are fitted to their
    contents only when the set of sensors changes: with "resize to contents" each ``setText``
    makes Qt measure every cell of the table again, which would cost a whole frame per status
    update with many sensors.
    """

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(0, len(COLUMNS), parent)
        self.setObjectName("sensorPanel")
        self.setHorizontalHeaderLabels(COLUMNS)
        for column, name in enumerate(COLUMNS):
            self.horizontalHeaderItem(column).setToolTip(COLUMN_TOOLTIPS[name])
        self.verticalHeader().setVisible(False)
        self.setEditTriggers(QtWidgets.QAbstractItemView.NoEditTriggers)
        self.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectRows)
        self.setSelectionMode(QtWidgets.QAbstractItemView.SingleSelection)
        self.horizontalHeader().setSectionResizeMode(QtWidgets.QHeaderView.Interactive)
        self.horizontalHeader().setStretchLastSection(True)
        # One line of text a row (the style's default is half as tall again): more sensors in view.
        self.verticalHeader().setDefaultSectionSize(self.fontMetrics().height() + 8)
        self._shown_ids: tuple[str, ...] = ()
        self._session = None

    def set_session(self, session) -> None:
        """Show the sensors of ``session`` (its ``status`` events; ``None``: none, emptied); the
        previous session is let go (unsubscribed)."""
        if self._session is not None:
            self._session.events.status.disconnect(self.show_rows)
        self._session = session
        if session is None:
            self.setRowCount(0)
            return
        session.events.status.connect(self.show_rows)

    def show_rows(self, rows: Sequence[SensorRow]) -> None:
        ids = tuple(row.sensor_id for row in rows)
        refit = ids != self._shown_ids
        if self.rowCount() != len(rows):
            self.setRowCount(len(rows))
        for r, row in enumerate(rows):
            refused = sum(row.rejections.values())
            if row.stale and refused:
                state = "STALE: packets arrive but are refused (see Refused)"
            elif row.stale:
                state = "STALE: no data"
            # A calibration that does not fit is the cause to act on; the doubt it brings follows.
            elif row.state == "mag_uncalibrated":
                state = "magnetometer not calibrated" + (f": {row.mag_cal_note}" if row.mag_cal_note else "")
            elif row.mag_field_warning:
                state = row.mag_field_warning
            elif row.mag_standing is not None and not row.mag_standing.good:
                state = f"magnetometer calibration {row.mag_standing.summary()}"
            elif row.doubt:
                state = f"orientation doubtful: {row.doubt}"
            else:
                state = "ok"
            values = (
                row.sensor_id, segment_name(row.segment) if row.segment else "(not assigned)",
                _number(row.rate_hz, 1), str(row.drops), str(refused), _number(row.latency_ms, 1),
                _number(row.battery_pct), _number(row.signal_dbm),
                row.mag_cal + (f", {quality_word(row.mag_cal_verdict)}" if row.mag_cal_verdict else "") + _age(row.mag_cal_age_s),
                ", ".join(row.flags) or "–", state,
            )
            doubtful = row.mag_standing is not None and not row.mag_standing.good
            brush = (STALE_BRUSH if row.stale else WARN_BRUSH if row.state != "ok" or doubtful or row.doubt
                     else QtGui.QBrush())
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
            refused_item = self.item(r, REFUSED_COLUMN)
            tooltip = rejections_tooltip(dict(row.rejections))
            if refused_item.toolTip() != tooltip:
                refused_item.setToolTip(tooltip)
            sensor_item = self.item(r, 0)
            device = device_tooltip(row)
            if sensor_item.toolTip() != device:
                sensor_item.setToolTip(device)
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
