"""The library index (io/library.py): files are the truth, the index is safe to lose, to share and to crash."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from mimucap.io.library import (
    INDEX_NAME, SCHEMA_VERSION, STATUS_DAMAGED, Library, LibraryError, LibraryVersionError, library_fields,
)
from mimucap.io.library_settings import (
    LIBRARY_ENV, configured_library_folder, remember_library_folder, remembered_library_folder,
)
from mimucap.io.session import read_metadata

from tests.library_sessions import make_session

APP_DIR = Path(__file__).resolve().parents[2] / "app"


@pytest.fixture
def library(tmp_path) -> Library:
    lib = Library(tmp_path / "lib")
    make_session(lib.root / "P001_2026-03-01_trial01.h5", "P001", 2.0, condition="pre-op", tags=("knee",),
                 trial="trial01", body_verdict="good")
    make_session(lib.root / "P001_2026-04-12_trial01.h5", "P001", 3.0, "2026-04-12T10:00:00+00:00",
                 condition="6 weeks", trial="trial01", height_m=1.71)
    (lib.root / "elsewhere").mkdir()
    make_session(lib.root / "elsewhere" / "anything.h5", "P002", 1.0, "2026-02-01T08:00:00+00:00")
    lib.scan()
    return lib


def test_a_scan_lists_subjects_and_sessions_from_the_files(library):
    sessions = library.sessions()
    assert [s.path for s in sessions] == ["elsewhere/anything.h5", "P001_2026-03-01_trial01.h5",
                                          "P001_2026-04-12_trial01.h5"]  # oldest first
    first = library.session("P001_2026-03-01_trial01.h5")
    assert first.ok and first.subject_id == "P001" and first.condition == "pre-op" and first.tags == ("knee",)
    assert first.trial == "trial01" and first.date == first.date[:10] and first.recorded_utc.startswith("2026-03-01")
    assert first.duration_s == pytest.approx(2.001, abs=1e-9)  # the two sensors' span
    assert first.sensors == {"S01": "pelvis", "S02": "thigh_r"}
    assert first.verdicts == {"body": "good"} and first.markers == ((0.5, "start walking"),)
    subjects = {s.subject_id: s for s in library.subjects()}
    assert set(subjects) == {"P001", "P002"} and subjects["P001"].sessions == 2
    assert subjects["P001"].height_m == pytest.approx(1.71)  # the newest session's record
    assert subjects["P001"].dominance == "left" and subjects["P001"].notes == "notes of P001"
    report = library.scan()
    assert report.unchanged == 3 and not (report.added or report.updated or report.removed)


def test_a_damaged_file_is_listed_with_its_reason_and_hides_nothing(library):
    (library.root / "P001_2026-05-01_trial01.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 100)
    (library.root / "P003_2026-05-02_trial01.h5").write_bytes(b"not a session at all")
    (library.root / "P004_2026-05-03_trial01.h5.journal").write_bytes(b"journal")
    report = library.scan()
    assert len(report.damaged) == 3
    entries = {s.path: s for s in library.sessions()}
    assert len(entries) == 6 and sum(s.ok for s in entries.values()) == 3
    damaged = entries["P003_2026-05-02_trial01.h5"]
    assert damaged.status == STATUS_DAMAGED and "not an HDF5 file" in damaged.problem
    assert damaged.subject_id == "P003"  # from the file name when the metadata cannot be read
    assert "damaged or truncated" in entries["P001_2026-05-01_trial01.h5"].problem
    assert "mimucap recover P004_2026-05-03_trial01.h5" in entries["P004_2026-05-03_trial01.h5.journal"].problem
    assert library.subject("P001").sessions == 3 and library.subject("P001").height_m == pytest.approx(1.71)
    with pytest.raises(ValueError, match="damaged"):
        library.set_tags("P003_2026-05-02_trial01.h5", ["x"])


def test_files_copied_in_or_removed_by_hand_show_after_a_rescan(library, tmp_path):
    outside = make_session(tmp_path / "copied.h5", "P009", 1.5)
    os.replace(outside, library.root / "elsewhere" / "copied.h5")
    (library.root / "elsewhere" / "anything.h5").unlink()
    report = library.scan()
    assert report.added == ("elsewhere/copied.h5",) and report.removed == ("elsewhere/anything.h5",)
    assert [s.subject_id for s in library.subjects()] == ["P001", "P009"]


def test_changes_go_into_the_files_and_a_rebuild_gives_the_same_index(library):
    library.set_tags("P001_2026-04-12_trial01.h5", ["knee", " follow-up ", "knee", ""])
    library.set_condition("P001_2026-04-12_trial01.h5", "6 weeks post-op")
    library.store_result("P001_2026-04-12_trial01.h5", "gait/cadence_spm", 112.5)
    renamed = library.rename_trial("P001_2026-04-12_trial01.h5", "walk-fast")
    assert renamed.path == f"P001_{renamed.date}_walk-fast.h5" and renamed.trial == "walk-fast"
    assert not (library.root / "P001_2026-04-12_trial01.h5").exists()
    on_file = read_metadata(library.file(renamed))["library"]
    assert on_file == {"condition": "6 weeks post-op", "tags": ["knee", "follow-up"], "trial": "walk-fast"}
    assert library.results(renamed.path) == {"gait/cadence_spm": 112.5}  # results follow the file
    before = library.index_rows()
    library.index_path.unlink()
    library = Library(library.root)
    assert library.sessions() == []
    library.rebuild()
    assert library.index_rows() == before
    # A rebuild over an existing index keeps the results of files still there.
    library.store_result(renamed.path, "gait/cadence_spm", 113.0)
    library.rebuild()
    assert library.index_rows() == before and library.result(renamed.path, "gait/cadence_spm") == 113.0
    first = library.session("P001_2026-03-01_trial01.h5")
    (library.root / f"P001_{first.date}_taken.h5").write_bytes(b"")
    with pytest.raises(FileExistsError, match="exists already"):
        library.rename_trial(first.path, "taken")
    with pytest.raises(ValueError, match="trial name"):
        library.rename_trial(renamed.path, "walk fast/2")
    with pytest.raises(ValueError, match="tag"):
        library.set_tags(renamed.path, ["a,b"])


def test_trash_keeps_the_file_out_of_the_library(library):
    where = library.move_to_trash("elsewhere/anything.h5")
    assert where == library.root / "trash" / "elsewhere" / "anything.h5" and where.exists()
    assert "elsewhere/anything.h5" not in [s.path for s in library.sessions()]
    library.rebuild()
    assert [s.subject_id for s in library.subjects()] == ["P001"]  # the trash is never scanned


def test_recording_paths_number_the_trials_of_a_day(library):
    from datetime import datetime

    day = datetime(2026, 3, 1, 15, 0)
    assert library.recording_path("P001", now=day).name == "P001_2026-03-01_trial02.h5"
    assert library.recording_path("P002", now=day).name == "P002_2026-03-01_trial01.h5"
    assert library.recording_path("P001", "tug", now=day).name == "P001_2026-03-01_tug.h5"
    with pytest.raises(FileExistsError):
        library.recording_path("P001", "trial01", now=day)
    with pytest.raises(ValueError, match="subject id"):
        library.recording_path("P 1", now=day)


def test_results_are_json_values_keyed_by_session_and_name(library):
    path = "P001_2026-03-01_trial01.h5"
    library.store_results(path, {"rom/knee_r": {"rom_deg": 61.2}, "steps": 14})
    assert library.results(path) == {"rom/knee_r": {"rom_deg": 61.2}, "steps": 14}
    with pytest.raises(ValueError, match="JSON"):
        library.store_result(path, "bad", float("nan"))
    with pytest.raises(KeyError):
        library.store_result("nowhere.h5", "x", 1)
    assert library.results(path) == {"rom/knee_r": {"rom_deg": 61.2}, "steps": 14}  # nothing half-written


def test_an_index_from_a_newer_version_is_refused_and_left_unchanged(library):
    with sqlite3.connect(library.index_path) as connection:
        connection.execute(f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    before = library.index_path.read_bytes()
    for action in (lambda: Library(library.root), library.sessions, library.scan, library.rebuild):
        with pytest.raises(LibraryVersionError, match="Update MimuCap"):
            action()
    assert library.index_path.read_bytes() == before


def test_a_damaged_index_is_reported_and_rebuilt(library):
    before = library.index_rows()
    library.index_path.write_bytes(b"garbage" * 1000)
    with pytest.raises(LibraryError, match="rebuild"):
        library.sessions()
    library.rebuild()
    assert library.index_rows() == before
    assert list(library.root.glob(f"{INDEX_NAME}.damaged-*"))  # kept aside, not destroyed


def test_the_configured_folder(tmp_path, monkeypatch):
    monkeypatch.delenv(LIBRARY_ENV, raising=False)
    assert remembered_library_folder() is None
    assert configured_library_folder(tmp_path / "docs") == tmp_path / "docs"
    remember_library_folder(tmp_path / "chosen")
    assert configured_library_folder(tmp_path / "docs") == tmp_path / "chosen"
    monkeypatch.setenv(LIBRARY_ENV, str(tmp_path / "env"))
    assert configured_library_folder() == tmp_path / "env"


def _child(code: str, *args: str) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(APP_DIR) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(code), *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)


#: A writer that stops in the middle of its fourth transaction (after 250 of 500 rows, with a
#: page cache so small that SQLite has already written changed pages into the index file) and
#: waits there to be killed.
_KILLED_WRITER = """
    import sqlite3, sys, time
    import mimucap.io.library as library
    real_connect = sqlite3.connect
    def small_cache(*args, **kwargs):
        connection = real_connect(*args, **kwargs)
        connection.execute("PRAGMA cache_size = 5")
        return connection
    library.sqlite3.connect = small_cache
    real_json, written = library._result_json, [0]
    def counting(name, value):
        written[0] += 1
        if written[0] == 3 * 500 + 250:
            print("inside", flush=True)
            time.sleep(120)
        return real_json(name, value)
    library._result_json = counting
    lib = library.Library(sys.argv[1])
    for i in range(10):
        lib.store_results(sys.argv[2], {f"t{i}/r{k}": {"values": list(range(40))} for k in range(500)})
        print("committed", i, flush=True)
"""


def test_a_writer_killed_mid_transaction_leaves_the_last_good_index(library):
    session = "P001_2026-03-01_trial01.h5"
    before = library.index_rows()
    child = _child(_KILLED_WRITER, str(library.root), session)
    try:
        lines = []
        while (line := child.stdout.readline()) and line.strip() != "inside":
            lines.append(line.strip())
        assert lines == ["committed 0", "committed 1", "committed 2"], child.stderr.read()
        journal = Path(str(library.index_path) + "-journal")
        assert journal.exists() and journal.stat().st_size > 0  # a transaction is open, pages changed
        os.kill(child.pid, signal.SIGKILL)
    finally:
        child.kill()
        child.wait()
    assert child.returncode == -signal.SIGKILL
    reopened = Library(library.root)
    with sqlite3.connect(reopened.index_path) as connection:
        assert connection.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    results = reopened.results(session)
    assert len(results) == 1500 and {name.split("/")[0] for name in results} == {"t0", "t1", "t2"}
    assert reopened.index_rows() == before
    reopened.store_result(session, "after", 1)  # and it takes writes again
    assert reopened.result(session, "after") == 1


_WRITER = """
    import sys
    from mimucap.io.library import Library
    lib = Library(sys.argv[1])
    for i in range(60):
        lib.store_result(sys.argv[2], f"{sys.argv[3]}/{i}", i)
        if i % 15 == 0:
            lib.rebuild()
    print("done", flush=True)
"""


def test_two_processes_write_one_library_without_losing_anything(library):
    session = "P001_2026-03-01_trial01.h5"
    before = library.index_rows()
    children = [_child(_WRITER, str(library.root), session, name) for name in ("a", "b")]
    for child in children:
        out, err = child.communicate(timeout=120)
        assert child.returncode == 0 and out.strip() == "done", err
    results = library.results(session)
    assert sorted(results) == sorted(f"{n}/{i}" for n in "ab" for i in range(60))
    assert all(results[f"{n}/{i}"] == i for n in "ab" for i in range(60))
    assert library.index_rows() == before


def test_a_metadata_change_that_fails_leaves_the_file_as_it_was(library, monkeypatch):
    import h5py

    from mimucap.io import session as session_io

    path = library.file("P001_2026-03-01_trial01.h5")
    before = path.read_bytes()
    with pytest.raises(ValueError, match="JSON"):
        session_io.update_metadata(path, {"library": {"condition": float("nan")}})

    real_file = h5py.File

    def failing_file(name, mode="r", *args, **kwargs):
        if mode == "r+":  # the copy being changed
            raise OSError("disk full")
        return real_file(name, mode, *args, **kwargs)

    monkeypatch.setattr(h5py, "File", failing_file)
    with pytest.raises(OSError, match="disk full"):
        library.set_condition(path, "after")
    assert path.read_bytes() == before and not list(library.root.glob(".*.part"))
    assert library.session(path).condition == "pre-op"
