"""GUI tests need a display: run them under Xvfb (``make test`` does)."""

from __future__ import annotations

import os

import pytest

from mimucap.gui.app import has_display

GUI_ENV = {"QT_API": "pyqt5"}


def pytest_collection_modifyitems(config, items):
    for item in items:
        if "tests/gui" in str(item.fspath).replace(os.sep, "/"):
            item.add_marker(pytest.mark.gui)


@pytest.fixture(autouse=True)
def _need_display():
    if not has_display():
        raise RuntimeError("the GUI tests need a display: run them under xvfb-run -a (make test does)")
