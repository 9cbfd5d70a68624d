"""Every command-line error a person can cause is one sentence naming the file and the problem,
never Python's exception text ("[Errno 2]…", "'utf-8' codec can't decode…", a traceback)."""

from __future__ import annotations

import pytest

from mimucap.cli import main

PYTHON_TEXT = ("Errno", "codec", "Traceback", "object has no attribute", "KeyError")


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    path = tmp_path_factory.mktemp("errors") / "walk.h5"
    assert main(["simulate", "--scenario", "walk", "--duration", "2", "--out", str(path)]) == 0
    return path


def _one_sentence(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err
    assert not any(text in err for text in PYTHON_TEXT), err
    return err


@pytest.mark.parametrize("calibration, said", [
    ("missing.json", "cannot read body calibration {path}: no such file"),
    ("SESSION", "{path} is an HDF5 file (a MimuCap session?), not a body calibration"),
    ("FOLDER", "cannot read body calibration {path}: it is a folder"),
    ("random.bin", "{path} is not a text file, so not a body calibration"),
])
def test_a_wrong_calibration_file_is_named_in_one_sentence(session, tmp_path, capsys, calibration, said):
    path = {"SESSION": session, "FOLDER": tmp_path}.get(calibration, tmp_path / calibration)
    if calibration == "random.bin":
        path.write_bytes(bytes(range(128, 256)) * 3)
    code = main(["angles", str(session), "--calibration", str(path), "--out", str(tmp_path / "a.csv")])
    assert code != 0
    assert said.format(path=path) in _one_sentence(capsys)


def test_a_missing_input_of_any_command_is_one_sentence(tmp_path, capsys):
    missing = tmp_path / "nowhere.h5"
    for argv in (["fuse", str(missing), "--out", str(tmp_path / "o.csv")],
                 ["magcal", "fit", str(missing)],
                 ["recover", str(missing)]):
        assert main(argv) != 0
        assert "nowhere.h5" in _one_sentence(capsys)


def test_an_os_error_without_a_sentence_of_ours_is_put_in_words(monkeypatch, tmp_path, capsys):
    """The last line of defence in ``main``: an ``OSError`` from deep inside (here a
    permission problem) is said in words with its file, not as ``[Errno 13]``."""
    import mimucap.cli.fuse as fuse

    def refuse(args):
        raise PermissionError(13, "Permission denied", str(tmp_path / "locked.h5"))

    monkeypatch.setattr(fuse, "run", refuse)
    parser_args = ["fuse", str(tmp_path / "locked.h5"), "--out", str(tmp_path / "o.csv")]
    assert main(parser_args) != 0
    assert f"{tmp_path / 'locked.h5'}: permission denied" in _one_sentence(capsys)


@pytest.mark.parametrize("fmt", ["csv", "mot", "c3d", "bvh", "sto"])
def test_export_of_angles_or_segments_needs_a_body_calibration(session, tmp_path, capsys, fmt):
    assert main(["export", str(session), "--format", fmt, "--out", str(tmp_path / f"out.{fmt}")]) == 1
    assert "--calibration CAL.json" in _one_sentence(capsys)


def test_the_sensors_own_orientations_export_without_a_body_calibration(session, tmp_path):
    assert main(["export", str(session), "--format", "sto", "--raw-sensors", "--out", str(tmp_path / "raw.sto")]) == 0
