"""Help → User Guide: the clinician's guide shipped with the program (``resources/guide``),
shown in a plain browser window that needs no network."""

from __future__ import annotations

from pathlib import Path

from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap.resources import resource_path

#: The guide, relative to the resources folder.
GUIDE = "guide/user-guide.html"


def guide_path() -> Path:
    """Where the guide is (``FileNotFoundError`` naming where it was looked for)."""
    return resource_path(GUIDE)


class UserGuideWindow(QtWidgets.QWidget):
    """The user guide in a :class:`QTextBrowser` (links inside the guide work; outside links
    open in the system browser)."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent, QtCore.Qt.Window)
        self.setObjectName("userGuide")
        self.setWindowTitle("MimuCap User Guide")
        self.browser = QtWidgets.QTextBrowser(self)
        self.browser.setObjectName("guideBrowser")
        self.browser.setOpenExternalLinks(True)
        path = guide_path()
        self.browser.setSearchPaths([str(path.parent)])
        self.browser.setSource(QtCore.QUrl.fromLocalFile(str(path)))
        close = QtWidgets.QPushButton("Close", self)
        close.clicked.connect(self.close)
        QtWidgets.QShortcut(QtGui.QKeySequence.Close, self, self.close)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(self.browser, 1)
        row = QtWidgets.QHBoxLayout()
        row.addStretch(1)
        row.addWidget(close)
        layout.addLayout(row)
        self.resize(760, 700)

    def text(self) -> str:
        """The guide as plain text (what a reader sees)."""
        return self.browser.toPlainText()
