"""Where the GUI keeps its settings (``$XDG_CONFIG_HOME/mimucap/gui.ini``, default ``~/.config``)
and its log (the platform's log folder, see :func:`log_dir`).

The path is worked out on every call (not cached by Qt), so tests that point
``XDG_CONFIG_HOME`` elsewhere never touch the user's real settings.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

from PyQt5 import QtCore


def config_dir() -> Path:
    """The user's MimuCap configuration folder (created when needed)."""
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    path = Path(base) / "mimucap"
    path.mkdir(parents=True, exist_ok=True)
    return path


def log_dir() -> Path:
    """The folder of MimuCap's log (created when needed): ``$XDG_STATE_HOME/mimucap`` (default
    ``~/.local/state/mimucap``) on Linux, ``~/Library/Logs/MimuCap`` on macOS,
    ``%LOCALAPPDATA%\\MimuCap\\Logs`` on Windows. A log is state, not configuration: it does not
    belong beside the settings a user might copy to another machine."""
    if sys.platform == "darwin":
        path = Path.home() / "Library" / "Logs" / "MimuCap"
    elif os.name == "nt":
        base = os.environ.get("LOCALAPPDATA") or str(Path.home() / "AppData" / "Local")
        path = Path(base) / "MimuCap" / "Logs"
    else:
        base = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
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
