"""A workspace page's layout and its own status line: a status bar laid out at the bottom of a
page of the main window (Review, Analysis, Library), in place of the window's, which belongs to
the live capture (what the pages say about a recording never mixes with what the live sources
report)."""

from __future__ import annotations

from PyQt5 import QtWidgets

#: A page's margins (px: left, top, right, bottom): its contents clear of the window's edges;
#: the status line at the bottom lies on the window's bottom edge, as a status bar does.
PAGE_MARGINS = (6, 6, 6, 0)


def page_layout(page: QtWidgets.QWidget) -> QtWidgets.QVBoxLayout:
    """``page``'s vertical layout, with the page margins."""
    layout = QtWidgets.QVBoxLayout(page)
    layout.setContentsMargins(*PAGE_MARGINS)
    return layout


def status_line(parent: QtWidgets.QWidget, layout: QtWidgets.QBoxLayout | None = None) -> QtWidgets.QStatusBar:
    """A status bar for ``parent`` (no size grip: the window's corner has its own), added at
    the end of ``layout`` when given."""
    bar = QtWidgets.QStatusBar(parent)
    bar.setSizeGripEnabled(False)
    if layout is not None:
        layout.addWidget(bar)
    return bar


def progress_bar(bar: QtWidgets.QStatusBar) -> QtWidgets.QProgressBar:
    """A progress bar (0-100 %) at the right of status line ``bar``."""
    progress = QtWidgets.QProgressBar(bar)
    progress.setRange(0, 100)
    progress.setMaximumWidth(200)
    bar.addPermanentWidget(progress)
    return progress
