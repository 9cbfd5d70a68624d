"""Which folder is the library: one setting shared by the desktop application and the command line.

The choice is kept in ``$XDG_CONFIG_HOME/mimucap/library.json`` (default ``~/.config``), a small
JSON file both read without Qt, so ``mimucap library …`` and ``mimucap record --library``
find the folder the application uses. The order of precedence:

1. the ``MIMUCAP_LIBRARY`` environment variable (scripts, tests);
2. the folder remembered by :func:`remember_library_folder` (the application's File → Library Folder…);
3. the default given by the caller (the application passes the user's documents folder as Qt
   knows it), else :func:`plain_default_folder`.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

#: Environment variable naming the library folder (overrides the remembered one).
LIBRARY_ENV = "MIMUCAP_LIBRARY"
#: Name of the library folder made inside the documents folder by default.
DEFAULT_FOLDER_NAME = "MimuCap Library"


def settings_file() -> Path:
    """``$XDG_CONFIG_HOME/mimucap/library.json`` (worked out on every call)."""
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "mimucap" / "library.json"


def plain_default_folder() -> Path:
    """``~/Documents/MimuCap Library`` (or ``~/MimuCap Library`` without a Documents folder)."""
    documents = Path.home() / "Documents"
    return (documents if documents.is_dir() else Path.home()) / DEFAULT_FOLDER_NAME


def remembered_library_folder() -> Path | None:
    """The folder last chosen, or None (no choice yet, or an unreadable settings file)."""
    try:
        value = json.loads(settings_file().read_text(encoding="utf-8")).get("folder")
    except (OSError, ValueError, AttributeError):
        return None
    return Path(value) if isinstance(value, str) and value else None


def configured_library_folder(default: str | os.PathLike[str] | None = None) -> Path:
    """The library folder in the order of the module doc (not created here)."""
    override = os.environ.get(LIBRARY_ENV)
    if override:
        return Path(override).expanduser()
    remembered = remembered_library_folder()
    if remembered is not None:
        return remembered
    return Path(default) if default is not None else plain_default_folder()


def remember_library_folder(folder: str | os.PathLike[str]) -> None:
    """Keep ``folder`` as the library folder (written beside and renamed: never half-written)."""
    path = settings_file()
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.part")
    temporary.write_text(json.dumps({"folder": str(Path(folder).expanduser())}, indent=1), encoding="utf-8")
    os.replace(temporary, path)


__all__ = ["LIBRARY_ENV", "DEFAULT_FOLDER_NAME", "settings_file", "plain_default_folder",
           "remembered_library_folder", "configured_library_folder", "remember_library_folder"]
