"""Menu helpers of the main window (and the dialogs' keys)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from PyQt5 import QtGui, QtWidgets


def choice_actions(menu: QtWidgets.QMenu, names: Sequence[str], label: Callable[[str], str],
                   chosen: Callable[[str], None], checked: str,
                   numbered_shortcuts: str = "") -> dict[str, QtWidgets.QAction]:
    """One checkable action per name in ``menu``, mutually exclusive, ``checked`` ticked;
    triggering one calls ``chosen(name)``. With ``numbered_shortcuts`` (a modifier, e.g. "Alt")
    the i-th is that modifier + i."""
    group = QtWidgets.QActionGroup(menu)
    actions: dict[str, QtWidgets.QAction] = {}
    for index, name in enumerate(names, start=1):
        action = menu.addAction(label(name))
        action.setCheckable(True)
        if numbered_shortcuts:
            action.setShortcut(QtGui.QKeySequence(f"{numbered_shortcuts}+{index}"))
        action.triggered.connect(lambda _checked, n=name: chosen(n))
        group.addAction(action)
        actions[name] = action
    actions[checked].setChecked(True)
    return actions


def truth_action(menu: QtWidgets.QMenu, toggled: Callable[[bool], None]) -> QtWidgets.QAction:
    """View → Show Simulator Truth: the simulated subject's true pose as a ghost figure and
    dashed curves beside the estimate (off until asked: a second figure doubles the drawing
    without a GPU; ``toggled(on)`` when changed)."""
    action = menu.addAction("Show Simulator &Truth")
    action.setCheckable(True)
    action.setChecked(False)
    action.setToolTip("The simulated subject's true pose as a pale figure and dashed curves beside the "
                      "estimate (the simulated suit only): an accuracy check")
    action.toggled.connect(toggled)
    return action


def closes_with_keys(window: QtWidgets.QWidget) -> None:
    """``window`` (a dialog that stays open beside the main window: the comparison) closes
    with Esc and with the platform's Close keys (Ctrl+W, ⌘W)."""
    for keys in (QtGui.QKeySequence(QtGui.QKeySequence.Close), QtGui.QKeySequence("Esc")):
        QtWidgets.QShortcut(keys, window, activated=window.close)
