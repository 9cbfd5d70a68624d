"""Locate the data files shipped under ``resources/`` (icons).

In a source checkout (editable install) they live in ``<repo>/resources``; in a built wheel
they are packed as ``mimucap/_resources``. Callers ask for a relative path and get an
absolute :class:`pathlib.Path`; a missing file raises ``FileNotFoundError`` naming it.
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent
_CANDIDATES = (_PACKAGE_DIR / "_resources", _PACKAGE_DIR.parent.parent / "resources")


def resources_root() -> Path:
    """Return the folder holding MimuCap's resources."""
    for candidate in _CANDIDATES:
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(
        "MimuCap resources not found (looked in " + ", ".join(map(str, _CANDIDATES)) + ")"
    )


def resource_path(relative: str) -> Path:
    """Absolute path of ``relative`` (e.g. ``"icons/mimucap.svg"``) inside the resources."""
    path = resources_root() / relative
    if not path.exists():
        raise FileNotFoundError(f"MimuCap resource missing: {relative} (looked in {path})")
    return path
