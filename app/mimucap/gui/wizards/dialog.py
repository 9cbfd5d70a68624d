"""The life cycle both calibration wizards share: a procedure stepped by its sample feed's
events, and one 3D view; closing or finishing the dialog stops following the procedure, closes
the feed and releases the view, so nothing renders or reads samples afterwards."""

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
    """Base of the calibration wizards. Subclasses set ``self.feed`` (a calibration feed,
    :mod:`mimucap.session.sources.calibration_feed`) and return their 3D view from
    :meth:`vtk_view`.

    A wizard does not poll: while a procedure runs, :meth:`follow` steps it each time the feed
    tells ``arrived`` and shows each status the procedure tells (``events.status``);
    :meth:`stop_following` ends both subscriptions.
    """

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._followed: tuple[object, Callable[[object], None]] | None = None

    def follow(self, procedure, show_status: Callable[[object], None]) -> None:
        """Step ``procedure`` on every arrival of samples and call ``show_status(status)`` after each step."""
        self.stop_following()
        self.feed.events.arrived.connect(procedure.step)
        procedure.events.status.connect(show_status)
        self._followed = (procedure, show_status)

    def stop_following(self) -> None:
        """Stop stepping the procedure followed (nothing when none is)."""
        if self._followed is None:
            return
        procedure, show_status = self._followed
        self.feed.events.arrived.disconnect(procedure.step)
        procedure.events.status.disconnect(show_status)
        self._followed = None

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
        """Hook run after the procedure is no longer followed and before the feed closes (default: nothing)."""

    def shutdown(self) -> None:
        """Stop following the procedure, let the subject carry on (the simulated subject
        resumes its scenario), close the feed and release the 3D view."""
        self.stop_following()
        self.before_shutdown()
        self.feed.instruct(instructions.RESUME)
        self.feed.close()
        self.vtk_view().shutdown()

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802 (Qt API)
        self.shutdown()
        super().closeEvent(event)

    def done(self, result: int) -> None:  # noqa: D401 (Qt API)
        self.shutdown()
        super().done(result)
