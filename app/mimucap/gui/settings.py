"""Where the GUI keeps its settings: ``$XDG_CONFIG_HOME/mimucap/gui.ini`` (default ``~/.config``).

The path is worked out on every call (not cached by Qt), so tests that point
``XDG_CONFIG_HOME`` elsewhere never touch the user's real settings.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from PyQt5 import QtCore


def config_dir() -> Path:
    """The user's MimuCap configuration folder (created when needed)."""
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    path = Path(base) / "mimucap"
    path.mkdir(parents=True, exist_ok=True)
    return path


def gui_settings() -> QtCore.QSettings:
    """The GUI's settings file (INI format)."""
    return QtCore.QSettings(str(config_dir() / "gui.ini"), QtCore.QSettings.IniFormat)


def load_json(key: str, default):
    """A JSON value stored under ``key`` (``default`` when absent or unreadable)."""
    text = gui_settings().value(key, "")
    if not text:
        return default
    try:
        return json.loads(str(text))
    except ValueError:
        return default


def save_json(key: str, value) -> None:
    settings = gui_settings()
    settings.setValue(key, json.dumps(value))
    settings.sync()
