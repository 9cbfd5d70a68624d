"""A one-line label that gives up width before the window does: when it has less room than its
text needs, it shows the start of the text and "…", and its tooltip shows the whole of it.

Used in status bars, whose permanent labels (source, pose, rates) would otherwise hold the
window at the width of their longest text."""

from __future__ import annotations

from PyQt5 import QtCore, QtGui, QtWidgets

#: Narrowest the label becomes (px): a few characters and the ellipsis.
MIN_WIDTH_PX = 60


class ElidedLabel(QtWidgets.QLabel):
    """A :class:`QtWidgets.QLabel` of plain text, elided at the right when squeezed
    (:meth:`text` is always the whole text)."""

    def __init__(self, text: str = "", parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(text, parent)
        self.setSizePolicy(QtWidgets.QSizePolicy.Preferred, QtWidgets.QSizePolicy.Preferred)

    def setText(self, text: str) -> None:  # noqa: N802 (Qt API)
        super().setText(text)
        self.setToolTip(text)

    def minimumSizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt API)
        hint = super().minimumSizeHint()
        return QtCore.QSize(min(hint.width(), MIN_WIDTH_PX), hint.height())

    def paintEvent(self, event: QtGui.QPaintEvent) -> None:  # noqa: N802 (Qt API)
        painter = QtGui.QPainter(self)
        area = self.contentsRect()
        shown = self.fontMetrics().elidedText(self.text(), QtCore.Qt.ElideRight, area.width())
        painter.setPen(self.palette().color(QtGui.QPalette.WindowText))
        painter.drawText(area, int(self.alignment()), shown)
        painter.end()
