"""The application's log: in the platform's log folder, and a bad user file is a warning of one
sentence, not a traceback that reads like a crash."""

from __future__ import annotations

import logging
from pathlib import Path

from mimucap.gui.background import BackgroundTask
from mimucap.gui.settings import config_dir, log_dir


def test_the_log_lives_in_the_state_folder_not_beside_the_settings(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    assert log_dir() == tmp_path / "state" / "mimucap"
    assert log_dir().is_dir()
    assert log_dir() != config_dir()


def _run(qtbot, work):
    task = BackgroundTask(work)
    with qtbot.waitSignal(task.failed, timeout=5000) as failed:
        task.start()
    task.wait()
    return failed.args[0]


def test_a_bad_user_file_is_logged_as_one_sentence_without_a_traceback(qtbot, caplog, tmp_path):
    def open_session(progress):
        raise ValueError(f"{tmp_path / 'notes.txt'}: not an HDF5 file (a MimuCap session is HDF5)")

    with caplog.at_level(logging.INFO, logger="mimucap"):
        message = _run(qtbot, open_session)
    assert "notes.txt: not an HDF5 file" in message
    records = [r for r in caplog.records if r.name.startswith("mimucap")]
    assert [r.levelno for r in records] == [logging.WARNING]
    assert records[0].exc_info is None


def test_a_missing_file_is_said_in_words(qtbot, tmp_path):
    def open_missing(progress):
        return Path(tmp_path / "gone.h5").read_bytes()

    assert _run(qtbot, open_missing) == f"{tmp_path / 'gone.h5'}: no such file"


def test_a_defect_of_ours_keeps_its_traceback(qtbot, caplog):
    def broken(progress):
        return {}["missing key"]

    with caplog.at_level(logging.INFO, logger="mimucap"):
        _run(qtbot, broken)
    assert any(r.levelno == logging.ERROR and r.exc_info for r in caplog.records)
