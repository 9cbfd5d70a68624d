"""Checks of a laid-out window (used by the layout tests): widgets that stick out of their
parent, and texts cut or elided although their widget could show them whole."""

from __future__ import annotations

from PyQt5 import QtCore, QtGui, QtWidgets

from mimucap.gui.elided_label import ElidedLabel

#: Widgets whose children may lie outside them by design: scroll areas show a part of their
#: contents, stacked pages and splitters' collapsed children are hidden, a table's cell widgets
#: scroll with the table.
_SCROLLING = (QtWidgets.QAbstractScrollArea,)


def _scrolled(widget: QtWidgets.QWidget) -> bool:
    """Whether ``widget`` lies inside a scroll area's viewport (it may be scrolled out of view)."""
    parent = widget.parentWidget()
    while parent is not None and not parent.isWindow():
        grand = parent.parentWidget()
        if isinstance(grand, _SCROLLING) and parent is grand.viewport():
            return True
        parent = grand
    return False


def outside_parent(window: QtWidgets.QWidget) -> list[str]:
    """Visible widgets of ``window`` whose rectangle is not inside their parent's."""
    found = []
    for widget in window.findChildren(QtWidgets.QWidget):
        parent = widget.parentWidget()
        if (parent is None or widget.isWindow() or not widget.isVisible() or not parent.isVisible()
                or _scrolled(widget) or isinstance(parent, QtWidgets.QAbstractScrollArea)):
            continue
        if not parent.rect().contains(widget.geometry()):
            found.append(f"{_name(widget)} {_rect(widget.geometry())} outside {_name(parent)} {_rect(parent.rect())}")
    return found


def off_screen(window: QtWidgets.QWidget, area: QtCore.QRect) -> list[str]:
    """Visible widgets of ``window`` (and the window) that do not lie wholly inside ``area``
    (the screen's free area, global coordinates); what a scroll area scrolls is left out."""
    found = []
    for widget in [window] + window.findChildren(QtWidgets.QWidget):
        if not widget.isVisible() or (widget is not window and (widget.isWindow() or _scrolled(widget))):
            continue
        rect = QtCore.QRect(widget.mapToGlobal(QtCore.QPoint(0, 0)), widget.size())
        if not rect.isEmpty() and not area.contains(rect):  # an empty widget draws nothing
            found.append(f"{_name(widget)} {_rect(rect)} off the screen {_rect(area)}")
    return found


def cut_texts(window: QtWidgets.QWidget) -> list[str]:
    """Visible one-line labels and buttons whose text does not fit their width, and elided
    labels elided although their text would fit."""
    found = []
    for widget in window.findChildren(QtWidgets.QWidget):
        if not widget.isVisible():
            continue
        metrics = widget.fontMetrics()
        if isinstance(widget, ElidedLabel):
            # elided by design when squeezed, never while its row has room for the whole text
            need = metrics.horizontalAdvance(widget.text())
            short = need - widget.contentsRect().width()
            parent = widget.parentWidget()
            if short > 1 and parent is not None:
                used = sum(child.width() for child in parent.findChildren(QtWidgets.QWidget, options=QtCore.Qt.FindDirectChildrenOnly)
                           if child.isVisible() and not child.isWindow())
                if parent.contentsRect().width() - used >= short:
                    found.append(f"{_name(widget)} '{widget.text()}' elided with {parent.contentsRect().width() - used} px free")
            continue
        if isinstance(widget, QtWidgets.QLabel):
            if widget.wordWrap() or widget.textFormat() == QtCore.Qt.RichText or not widget.text():
                continue
            if widget.pixmap() is not None and not widget.pixmap().isNull():
                continue
            text = widget.text().replace("&", "") if widget.buddy() is not None else widget.text()
            need = max(metrics.horizontalAdvance(line) for line in text.splitlines())
            if need > widget.contentsRect().width() + 1:
                found.append(f"{_name(widget)} '{widget.text()}' needs {need} px, has {widget.contentsRect().width()}")
        elif isinstance(widget, QtWidgets.QComboBox) and not widget.isEditable():
            option = QtWidgets.QStyleOptionComboBox()
            widget.initStyleOption(option)
            field = widget.style().subControlRect(QtWidgets.QStyle.CC_ComboBox, option,
                                                  QtWidgets.QStyle.SC_ComboBoxEditField, widget)
            need = metrics.horizontalAdvance(widget.currentText())
            if need > field.width() + 1:
                found.append(f"{_name(widget)} '{widget.currentText()}' needs {need} px, has {field.width()}")
        elif isinstance(widget, QtWidgets.QTableWidget):
            header = widget.horizontalHeader()
            last = widget.columnCount() - 1
            for column in range(widget.columnCount()):
                if header.isSectionHidden(column) or (column == last and header.stretchLastSection()):
                    continue
                for row in range(widget.rowCount()):
                    item = widget.item(row, column)
                    if item is None or not item.text():
                        continue
                    need = item.font().pointSizeF() and QtGui.QFontMetrics(item.font()).horizontalAdvance(item.text()) + 8
                    if need > widget.columnWidth(column) + 1:
                        found.append(f"cell of {_name(widget)} '{item.text()}' needs {need} px, has "
                                     f"{widget.columnWidth(column)}")
        elif isinstance(widget, QtWidgets.QHeaderView) and widget.orientation() == QtCore.Qt.Horizontal:
            model = widget.model()
            last = widget.count() - 1
            for section in range(widget.count()):
                if widget.isSectionHidden(section) or (section == last and widget.stretchLastSection()):
                    continue
                text = str(model.headerData(section, QtCore.Qt.Horizontal) or "")
                need = metrics.horizontalAdvance(text) + 8
                if need > widget.sectionSize(section) + 1:
                    found.append(f"header of {_name(widget.parentWidget())} '{text}' needs {need} px, "
                                 f"has {widget.sectionSize(section)}")
        elif isinstance(widget, (QtWidgets.QPushButton, QtWidgets.QToolButton, QtWidgets.QCheckBox,
                                 QtWidgets.QRadioButton)):
            text = widget.text().replace("&&", "\0").replace("&", "").replace("\0", "&")
            if not text:
                continue
            hint = widget.sizeHint().width()
            if hint > widget.width() + 1:
                found.append(f"{_name(widget)} '{text}' needs {hint} px, has {widget.width()}")
    return found


def _name(widget: QtWidgets.QWidget) -> str:
    return f"{type(widget).__name__}({widget.objectName() or '-'})"


def _rect(rect: QtCore.QRect) -> str:
    return f"[{rect.x()},{rect.y()} {rect.width()}x{rect.height()}]"
