"""A command never destroys its own input or an existing file: an output naming the input,
a recording onto an existing session, an emulator link onto a plain file are refused."""

from __future__ import annotations

import pytest

from mimucap.acquisition.emulate_serial import SerialEmulator
from mimucap.cli import main


def _session(tmp_path):
    path = tmp_path / "walk.h5"
    assert main(["simulate", "--scenario", "walk", "--duration", "2", "--out", str(path)]) == 0
    return path


def test_fuse_and_bodycal_refuse_to_write_over_their_input(tmp_path, capsys):
    session = _session(tmp_path)
    before = session.read_bytes()
    assert main(["fuse", str(session), "--out", str(session)]) != 0
    assert main(["fuse", str(session), "--out", str(tmp_path / "." / "walk.h5")]) != 0  # same file, other name
    assert main(["bodycal", str(session), "--mapping", "S01=pelvis", "--npose", "0:1", "--out", str(session)]) != 0
    assert "would overwrite the input" in capsys.readouterr().err
    assert session.read_bytes() == before


def test_a_recording_never_replaces_an_existing_file(tmp_path, capsys):
    session = _session(tmp_path)
    before = session.read_bytes()
    assert main(["record", "--source", "simulated:walk", "--duration", "0.5", "--out", str(session)]) != 0
    assert "exists" in capsys.readouterr().err and session.read_bytes() == before


def test_the_serial_emulator_link_never_replaces_a_file(tmp_path):
    precious = tmp_path / "notes.txt"
    precious.write_text("keep me")
    with pytest.raises(ValueError, match="not a symbolic link"):
        SerialEmulator(settings=None, motion=None, link=precious)
    assert precious.read_text() == "keep me"
