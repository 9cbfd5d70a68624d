"""The life cycle both calibration wizards share: a tick timer driving a procedure from a
sample feed, and one 3D view; closing or finishing the dialog stops the timer, closes the
feed and releases the view, so nothing renders or reads samples afterwards."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from PyQt5 import QtGui, QtWidgets

from mimucap.session.procedures import instructions


def push_button(text: str, slot: Callable[[], object], tooltip: str = "") -> QtWidgets.QPushButton:
    """A push button calling ``slot`` when clicked (which button Enter presses is the dialog's
    choice: :meth:`CalibrationDialog.set_page_defaults`)."""
    widget = QtWidgets.QPushButton(text)
    widget.clicked.connect(slot)
    if tooltip:
        widget.setToolTip(tooltip)
    return widget


def large_label(scale: float = 1.3, bold: bool = False, wrap: bool = True) -> QtWidgets.QLabel:
    """An empty label in the dialog font scaled by ``scale`` (instructions, countdowns)."""
    label = QtWidgets.QLabel("")
    label.setWordWrap(wrap)
    font = label.font()
    font.setPointSizeF(font.pointSizeF() * scale)
    font.setBold(bold)
    label.setFont(font)
    return label


def button_row(*items: QtWidgets.QWidget | None) -> QtWidgets.QHBoxLayout:
    """A row of ``items`` left to right; ``None`` is the stretch that pushes the rest right."""
    row = QtWidgets.QHBoxLayout()
    for item in items:
        if item is None:
            row.addStretch(1)
        else:
            row.addWidget(item)
    return row


class CalibrationDialog(QtWidgets.QDialog):
    """Base of the wizards. Subclasses set ``self.timer`` (QTimer), ``self.feed`` (a
    calibration feed, optionally with ``close()``) and return their 3D view from :meth:`vtk_view`."""

    def set_page_defaults(self, pages: QtWidgets.QStackedWidget,
                          defaults: Mapping[QtWidgets.QWidget, QtWidgets.QPushButton]) -> None:
        """Make Enter press the main button of the page shown (``defaults``: page → button; a page
        not in it has none, and Enter does nothing there). Without this, Qt makes the first
        button after the focused widget the default one when the dialog opens: Enter in the
        sensor list pressed *Close*. Call it once the pages are in the dialog."""

        def follow(_index: int) -> None:
            for button in self.findChildren(QtWidgets.QPushButton):
                button.setDefault(False)
            button = defaults.get(pages.currentWidget())
            if button is not None:
                button.setDefault(True)

        pages.currentChanged.connect(follow)
        follow(pages.currentIndex())

    def vtk_view(self):
        """The wizard's VTK view (anything with ``shutdown()``)."""
        raise NotImplementedError

    def before_shutdown(self) -> None:
        """Hook run after the timer stops and before the feed closes (default: nothing)."""

    def shutdown(self) -> None:
        """Stop the timer, let the subject carry on (the simulated subject resumes its
        scenario), close the feed and release the 3D view."""
        self.timer.stop()
        self.before_shutdown()
        self.feed.instruct(instructions.RESUME)
        close = getattr(self.feed, "close", None)
        if callable(close):
            close()
        self.vtk_view().shutdown()

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802 (Qt API)
        self.shutdown()
        super().closeEvent(event)

    def done(self, result: int) -> None:  # noqa: D401 (Qt API)
        self.shutdown()
        super().done(result)
