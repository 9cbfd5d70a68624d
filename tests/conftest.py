"""Shared test helpers: where the real recordings live, and a per-test user data directory."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]


def shared_data_dir() -> Path:
    """``<repo>/../shared/data``: real recordings with their own licences (never copied in)."""
    path = (REPO_ROOT / ".." / "shared" / "data").resolve()
    if not path.is_dir():
        raise FileNotFoundError(f"shared data not found at {path}: the tests need ../shared beside the repository")
    return path


@pytest.fixture
def shared_data() -> Path:
    return shared_data_dir()


@pytest.fixture(autouse=True)
def _isolated_user_dirs(tmp_path_factory, monkeypatch):
    """Keep calibrations and settings written by tests out of the real user's folders."""
    base = tmp_path_factory.mktemp("user")
    monkeypatch.setenv("MIMUCAP_DATA_DIR", str(base / "data"))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(base / "config"))
    monkeypatch.setenv("XDG_DATA_HOME", str(base / "share"))
