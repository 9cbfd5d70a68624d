"""A workspace's own status line and its page's margins: a status bar laid out at the bottom of a page of the main
window (Review, Analysis, Library), in place of the window's, which belongs to the live capture
(what the pages say about a recording never mixes with what the live sources report)."""

from __future__ import annotations

from PyQt5 import QtWidgets

#: A page's margins (px: left, top, right, bottom): its contents clear of the window's edges;
#: the status line at the bottom lies on the window's bottom edge, as a status bar does.
PAGE_MARGINS = (6, 6, 6, 0)


def status_line(parent: QtWidgets.QWidget) -> QtWidgets.QStatusBar:
    """A status bar for ``parent``'s layout (no size grip: the window's corner has its own)."""
    bar = QtWidgets.QStatusBar(parent)
    bar.setSizeGripEnabled(False)
    return bar
