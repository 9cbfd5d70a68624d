"""``mimucap library`` and ``mimucap record --subject`` as a user runs them."""

from __future__ import annotations

import csv
import subprocess
import sys

import pytest

from mimucap.cli import main
from mimucap.io.library import Library
from mimucap.io.library_settings import LIBRARY_ENV
from mimucap.io.session import read_metadata

from tests.library_sessions import make_session


@pytest.fixture
def folder(tmp_path):
    root = tmp_path / "lib"
    root.mkdir()
    make_session(root / "P001_2026-03-01_trial01.h5", "P001", 2.0, condition="pre-op", tags=("knee", "left"),
                 trial="trial01", body_verdict="warn")
    make_session(root / "P001_2026-04-12_trial01.h5", "P001", 3.0, "2026-04-12T10:00:00+00:00", condition="6 weeks",
                 trial="trial01")
    (root / "P002_2026-04-13_trial01.h5").write_bytes(b"broken")
    return root


def test_list_show_and_export(folder, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv(LIBRARY_ENV, str(folder))  # the configured folder when --library is not given
    assert main(["library", "list"]) == 0
    out = capsys.readouterr().out
    assert "2 subjects, 3 sessions (1 damaged)" in out
    assert "P001_2026-04-12_trial01.h5" in out and "DAMAGED: not an HDF5 file" in out
    assert main(["library", "show", "P001", "--library", str(folder)]) == 0
    out = capsys.readouterr().out
    assert "subject P001: height 1.70 m, dominant side left, 2 session(s)" in out
    assert "condition pre-op, tags knee, left" in out and "calibrations: body warn" in out
    assert "markers: start walking at 0.50 s" in out
    assert main(["library", "show", "P404", "--library", str(folder)]) == 1
    assert "no subject 'P404'" in capsys.readouterr().err
    target = tmp_path / "sessions.csv"
    assert main(["library", "export-csv", "--out", str(target), "--library", str(folder)]) == 0
    rows = list(csv.DictReader(target.open(encoding="utf-8")))
    assert [(r["subject"], r["condition"], r["status"]) for r in rows] == [
        ("P001", "pre-op", "ok"), ("P001", "6 weeks", "ok"), ("P002", "", "damaged")]
    assert rows[0]["tags"] == "knee;left" and rows[0]["duration_s"] == "2.001"
    assert rows[0]["sensors"] == "S01=pelvis S02=thigh_r" and rows[0]["verdicts"] == "body warn"
    assert "not an HDF5 file" in rows[2]["problem"] and rows[2]["file"] == "P002_2026-04-13_trial01.h5"


def test_rebuild_and_a_missing_folder(folder, tmp_path, capsys):
    assert main(["library", "list", "--library", str(folder)]) == 0
    before = Library(folder).index_rows()
    (folder / "mimucap-library.sqlite").unlink()
    assert main(["library", "rebuild", "--library", str(folder)]) == 0
    assert "from 3 session files, 1 damaged" in capsys.readouterr().out
    assert Library(folder).index_rows() == before
    (folder / "mimucap-library.sqlite").write_bytes(b"not a database" * 100)
    assert main(["library", "list", "--library", str(folder)]) == 1
    assert "is damaged" in capsys.readouterr().err
    assert main(["library", "rebuild", "--library", str(folder)]) == 0
    assert Library(folder).index_rows() == before
    assert main(["library", "list", "--library", str(tmp_path / "nowhere")]) == 1
    assert "does not exist" in capsys.readouterr().err


def test_record_into_the_library(folder, capsys):
    assert main(["library", "list", "--library", str(folder)]) == 0
    code = subprocess.run(
        [sys.executable, "-m", "mimucap", "record", "--source", "simulated:walk", "--duration", "1.5", "--quiet",
         "--subject", "P001", "--library", str(folder), "--condition", "3 months", "--tags", "knee, fast"],
        capture_output=True, text=True, timeout=120)
    assert code.returncode == 0, code.stderr
    assert "subject P001, trial trial" in code.stdout
    library = Library(folder)
    new = [s for s in library.sessions("P001") if s.condition == "3 months"]
    assert len(new) == 1 and new[0].tags == ("knee", "fast") and new[0].ok and new[0].duration_s > 0.0
    subject = read_metadata(library.file(new[0]))["subject"]
    assert subject["height_m"] == pytest.approx(1.70) and subject["dominance"] == "left"  # as the library knew P001
    assert main(["record", "--source", "simulated", "--duration", "1", "--out", str(folder / "x.h5"),
                 "--condition", "pre-op"]) == 1
    assert "--condition apply to recordings into the library only" in capsys.readouterr().err


def test_the_library_commands_start_without_qt(folder):
    code = ("import sys\nfrom mimucap.cli import main\n"
            f"assert main(['library', 'list', '--library', {str(folder)!r}]) == 0\n"
            "loaded = sorted(m for m in sys.modules if m.split('.')[0] in ('PyQt5', 'vtk', 'vtkmodules', 'pyqtgraph'))\n"
            "assert not loaded, loaded\n")
    completed = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert completed.returncode == 0, completed.stderr
