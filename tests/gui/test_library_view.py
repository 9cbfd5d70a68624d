"""The Library workspace: two sessions of a subject recorded through the GUI, found, compared,
opened in Review and in Analysis; and the library view's own actions on a prepared library (filters, damaged files, renames, tags, trash)."""

from __future__ import annotations

import numpy as np
import pytest
from PyQt5 import QtCore, QtWidgets

from mimucap.gui.library_view import LibraryView
from mimucap.io.library import Library
from mimucap.io.library_settings import LIBRARY_ENV
from mimucap.io.session import read_metadata
from tests.gui.live_window import closed, live_window
from tests.library_sessions import make_session


@pytest.fixture
def app_window(qtbot, tmp_path, monkeypatch):
    monkeypatch.setenv(LIBRARY_ENV, str(tmp_path / "library"))
    window = live_window(qtbot, "simulated:walk")
    yield window
    closed(window)


def _record(window, qtbot, seconds: float, markers=()) -> object:
    """Record ``seconds`` of simulated time with ``markers`` (label, at s) through the panel."""
    qtbot.mouseClick(window.mode_bar.record_button, QtCore.Qt.LeftButton)
    assert window.live.recording
    for label, at_s in markers:
        qtbot.waitUntil(lambda: window.live.recording_info().elapsed_s >= at_s, timeout=10000)
        window.add_marker(label)
    qtbot.waitUntil(lambda: window.live.recording_info().elapsed_s >= seconds, timeout=10000)
    with qtbot.waitSignal(window.recording_saved, timeout=30000) as saved:
        qtbot.mouseClick(window.mode_bar.record_button, QtCore.Qt.LeftButton)
    return saved.args[0]


def test_two_sessions_recorded_found_and_compared(app_window, qtbot, tmp_path):
    window = app_window
    qtbot.waitUntil(lambda: not window.starting, timeout=180000)  # the filters compiled once per install
    qtbot.waitUntil(lambda: window.live.samples_received > 100, timeout=30000)
    # The sensors' mounting as the body calibration (as a calibration procedure would find it):
    # the sessions then carry a body calibration verdict.
    from mimucap.core import skeleton
    from mimucap.core.bodycal import BodyCalibration, CalibrationQuality

    mounting = window.live.feed.simulator.mounting
    window.live.apply_body_calibration(BodyCalibration(
        q_world_from_body=skeleton.q_world_from_body_facing(0.0), up_world=np.array([0.0, 0.0, 1.0]),
        sensors={m.segment: sid for sid, m in mounting.items()},
        q_segment_from_sensor={m.segment: m.q_segment_from_sensor for m in mounting.values()},
        quality=CalibrationQuality("known mounting", ())))
    panel = window.session_panel
    panel.subject_id.setText("P042")
    panel.height.setValue(1.68)
    panel.dominance.setCurrentText("left")
    panel.notes.setPlainText("right knee")
    panel.condition.setText("pre-op")
    panel.tags.setText("knee, baseline")
    first = _record(window, qtbot, 6.0, [("walk start", 1.0), ("walk end", 5.0)])
    assert first.session_path.parent == tmp_path / "library" and first.session_path.name.endswith("_trial01.h5")

    # The Library workspace lists it under its subject.
    window.action_library.trigger()
    library = window.library_view
    assert window.workspace == "library"
    library.wait_for_scan()
    assert "P042" in library.subjects
    library.select_subject("P042")
    assert len(library.visible_paths()) == 1

    # A new session for the selected subject: the panel is filled from the library.
    panel.subject_id.setText("someone else")
    panel.height.setValue(1.90)
    qtbot.mouseClick(library.new_session_button, QtCore.Qt.LeftButton)
    assert window.workspace == "capture"  # the next recording is made there
    assert panel.subject_id.text() == "P042" and panel.height.value() == pytest.approx(1.68)
    assert panel.dominance.currentText() == "left" and panel.notes.toPlainText() == "right knee"
    panel.condition.setText("6 weeks")
    panel.tags.setText("knee")
    with qtbot.waitSignal(library.refreshed, timeout=30000):
        second = _record(window, qtbot, 5.0, [("walk start", 0.5), ("walk end", 4.5)])
    assert second.session_path.name.endswith("_trial02.h5")
    assert read_metadata(second.session_path)["library"] == {"condition": "6 weeks", "tags": ["knee"],
                                                              "trial": "trial02"}
    paths = library.visible_paths()
    assert len(paths) == 2 and library.subjects["P042"].sessions == 2
    entries = [library.entries[p] for p in paths]
    assert [e.condition for e in entries] == ["pre-op", "6 weeks"]  # sorted by date
    assert all(e.ok and len(e.sensors) == 10 and [label for _t, label in e.markers] == ["walk start", "walk end"]
               for e in entries)
    assert entries[0].verdicts["body"] == window.live.body_calibration.quality.verdict

    # Filters: condition, tag, date.
    library.condition_filter.setCurrentIndex(library.condition_filter.findData("6 weeks"))
    assert [library.entries[p].condition for p in library.visible_paths()] == ["6 weeks"]
    library.clear_filters()
    library.tag_filter.setCurrentIndex(library.tag_filter.findData("baseline"))
    assert [library.entries[p].condition for p in library.visible_paths()] == ["pre-op"]
    library.clear_filters()
    library.set_date_range("2000-01-02", "2000-12-31")
    assert library.visible_paths() == []
    library.clear_filters()
    assert len(library.visible_paths()) == 2

    # Compare the two: A is the older one; ROM over the whole recordings, then between markers.
    library.select_paths(set(paths))
    assert library.buttons["compare"].isEnabled()
    qtbot.mouseClick(library.buttons["compare"], QtCore.Qt.LeftButton)
    compare = library.compare_dialogs[-1]
    qtbot.waitUntil(lambda: bool(compare.tables) or compare.error is not None, timeout=60000)
    assert compare.error is None and [t.name for t in compare.tables] == ["Joint-angle range of motion"]
    assert compare.result == "reprocessed"
    with qtbot.waitSignal(compare.compared, timeout=60000):
        compare.result_combo.setCurrentIndex(compare.result_combo.findData("live"))
    assert compare.error is None and {r.result for r in compare.reviews} == {"live"}
    assert [e.condition for e in compare.entries] == ["pre-op", "6 weeks"]
    rows = {row[0]: row for row in compare.tables[0].rows}
    knee = rows["Right knee flexion"]
    assert knee[3] > 30.0 and knee[6] > 30.0  # walking bends the knee
    assert knee[7] == pytest.approx(knee[6] - knee[3])
    # (How close these ranges come to the simulator's own is tested without the GUI, in
    # tests/session/test_library_compare.py: here the magnetometers are not calibrated.)
    whole_a = knee[3]
    picker = compare.pickers[0]
    with qtbot.waitSignal(compare.compared, timeout=5000):
        picker.set_bounds(0, 1)
    narrowed_rows = compare.tables[0].rows
    narrowed = {row[0]: row for row in narrowed_rows}["Right knee flexion"]
    assert narrowed[3] <= whole_a + 1e-9 and narrowed[6] == pytest.approx(knee[6])
    assert "walk start" in compare.tables[0].note
    with qtbot.waitSignal(compare.compared, timeout=5000):
        picker.set_bounds(1, 1)  # one marker is no part: said, no table
    assert compare.error and "choose two different markers" in compare.error and not compare.tables
    with qtbot.waitSignal(compare.compared, timeout=5000):
        picker.set_bounds(1, 0)  # markers in either order, as the export takes them
    assert compare.error is None and compare.tables[0].rows == narrowed_rows
    picker.set_bounds(None, None)
    csv_text = compare.save_csv(tmp_path / "compare.csv").read_text()
    assert csv_text.startswith("Joint-angle range of motion\nJoint angle,A min (°)")
    assert "Right knee flexion," in csv_text

    compare.close()
    # Open one for review from the library: the Review workspace shows it.
    window.show_workspace("library")
    library.select_paths({paths[0]})
    review = library.open_selected()
    assert review is window.review.view and review.path == first.session_path and window.workspace == "review"
    qtbot.waitUntil(lambda: review.player is not None, timeout=30000)
    # ... or for analysis: Review loads it, then the Analysis workspace analyses it.
    window.show_workspace("library")
    library.select_paths({paths[1]})
    assert library.buttons["analyse"].isEnabled()
    qtbot.mouseClick(library.buttons["analyse"], QtCore.Qt.LeftButton)
    assert window.workspace == "analysis" and window.review.view.path == second.session_path
    assert "Opening" in window.analysis.empty.text.text()  # the analysis follows the loading
    qtbot.waitUntil(lambda: window.analysis.view is not None, timeout=30000)
    assert window.workspace == "analysis" and window.analysis.view.data is window.review.view.player.data

    # The library rebuilt from the files gives the same index.
    library = Library(tmp_path / "library")
    before = library.index_rows()
    library.index_path.unlink()
    Library(tmp_path / "library").rebuild()
    assert Library(tmp_path / "library").index_rows() == before


@pytest.fixture
def prepared(tmp_path):
    root = tmp_path / "lib"
    root.mkdir()
    make_session(root / "P001_2026-03-01_trial01.h5", "P001", 2.0, condition="pre-op", tags=("knee",), trial="trial01")
    make_session(root / "P001_2026-04-12_trial01.h5", "P001", 3.0, "2026-04-12T10:00:00+00:00", condition="6 weeks",
                 trial="trial01")
    make_session(root / "P002_2026-04-13_trial01.h5", "P002", 1.0, "2026-04-13T10:00:00+00:00", trial="trial01")
    (root / "P002_2026-04-14_trial01.h5").write_bytes(b"\x89HDF\r\n\x1a\n truncated")
    return root


def test_the_window_changes_files_and_shows_damaged_ones(prepared, qtbot, monkeypatch):
    reviewed, started = [], []
    window = LibraryView(prepared, open_review=reviewed.append, new_session=lambda *a: started.append(a))
    qtbot.addWidget(window)
    window.show()
    window.wait_for_scan()
    assert sorted(window.subjects) == ["P001", "P002"] and len(window.visible_paths()) == 4
    damaged = window.entries["P002_2026-04-14_trial01.h5"]
    assert not damaged.ok and "damaged or truncated" in damaged.problem
    row = window.visible_paths().index(damaged.path)
    assert window.proxy.index(row, 9).data().startswith("damaged: ")
    window.select_paths({damaged.path})
    assert not window.buttons["open"].isEnabled() and window.buttons["trash"].isEnabled()
    window.select_subject("P002")
    assert len(window.visible_paths()) == 2
    qtbot.mouseClick(window.new_session_button, QtCore.Qt.LeftButton)
    assert started == [("P002", pytest.approx(1.70), "left", "notes of P002")]

    # Sorting by duration, longest first.
    window.select_subject(None)
    window.table.sortByColumn(5, QtCore.Qt.DescendingOrder)
    assert [window.entries[p].duration_s for p in window.visible_paths()][:3] == pytest.approx([3.001, 2.001, 1.001])

    # Rename, tag, set the condition, trash: into the files, then shown.
    window.select_paths({"P001_2026-04-12_trial01.h5"})
    with qtbot.waitSignal(window.refreshed, timeout=10000):
        renamed = window.rename_trial("tug")
    assert renamed.path.endswith("_tug.h5") and (prepared / renamed.path).exists()
    window.select_paths({renamed.path})
    with qtbot.waitSignal(window.refreshed, timeout=10000):
        window.set_tags(["knee", "fast"])
    window.select_paths({renamed.path})
    with qtbot.waitSignal(window.refreshed, timeout=10000):
        window.set_condition("6 weeks post-op")
    assert read_metadata(prepared / renamed.path)["library"] == {"condition": "6 weeks post-op",
                                                                 "tags": ["knee", "fast"], "trial": "tug"}
    assert window.tag_filter.findData("fast") > 0 and window.condition_filter.findData("6 weeks post-op") > 0
    window.select_paths({renamed.path})
    QtWidgets.QApplication.setActiveWindow(window)
    window.table.setFocus()
    qtbot.keyClick(window.table, QtCore.Qt.Key_Return)
    assert reviewed == [prepared / renamed.path]
    window.select_paths({damaged.path, "P002_2026-04-13_trial01.h5"})
    asked = []
    monkeypatch.setattr(QtWidgets.QMessageBox, "question",
                        lambda *a, **k: asked.append(a[2]) or QtWidgets.QMessageBox.Yes)
    with qtbot.waitSignal(window.refreshed, timeout=10000):
        qtbot.keyClick(window.table, QtCore.Qt.Key_Delete)
    assert asked and "Move 2 session files" in asked[0]
    moved = [prepared / "trash" / p for p in (damaged.path, "P002_2026-04-13_trial01.h5")]
    assert all(p.exists() for p in moved) and not (prepared / damaged.path).exists()
    assert sorted(window.subjects) == ["P001"] and len(window.visible_paths()) == 2
    # A damaged index is said in the banner and made again from the files.
    listed = window.visible_paths()
    (prepared / "mimucap-library.sqlite").write_bytes(b"no database" * 500)
    with qtbot.waitSignal(window.refreshed, timeout=10000):
        window.refresh()
    assert window.banner.isVisible() and "is damaged" in window.banner.text() and window.visible_paths() == []
    with qtbot.waitSignal(window.refreshed, timeout=10000):
        qtbot.mouseClick(window.rebuild_button, QtCore.Qt.LeftButton)
    assert not window.banner.isVisible() and sorted(window.visible_paths()) == sorted(listed)
    # A refused index is said in the banner, and nothing is listed.
    import sqlite3
    with sqlite3.connect(prepared / "mimucap-library.sqlite") as connection:
        connection.execute("PRAGMA user_version = 99")
    window.set_folder(prepared)
    assert window.banner.isVisible() and "Update MimuCap" in window.banner.text()
    assert window.visible_paths() == [] and np.all([not b.isEnabled() for b in window.buttons.values()])
    window.shutdown()


def test_the_library_folder_is_chosen_once_and_remembered(window, qtbot, tmp_path, monkeypatch):
    from PyQt5 import QtWidgets

    from mimucap.io.library_settings import remembered_library_folder

    monkeypatch.delenv(LIBRARY_ENV, raising=False)
    documents = QtCore.QStandardPaths.writableLocation(QtCore.QStandardPaths.DocumentsLocation)
    monkeypatch.setattr(QtCore.QStandardPaths, "writableLocation", lambda *a: str(tmp_path / "Documents"))
    assert window.recording_folder() == tmp_path / "Documents" / "MimuCap Library"  # the default
    assert documents  # Qt knows a documents folder here too
    window.action_library.trigger()
    library = window.library_view
    library.wait_for_scan()
    assert library.library.root == tmp_path / "Documents" / "MimuCap Library"
    chosen = tmp_path / "clinic library"
    chosen.mkdir()
    make_session(chosen / "P007_2026-01-05_trial01.h5", "P007")
    monkeypatch.setattr(QtWidgets.QFileDialog, "getExistingDirectory", lambda *a, **k: str(chosen))
    window.action_folder.trigger()
    assert remembered_library_folder() == chosen and window.recording_folder() == chosen
    library.wait_for_scan()
    assert list(library.subjects) == ["P007"] and str(chosen) == library.folder_label.toolTip()
    # A library folder out of reach is said in the window (never replaced by another folder).
    blocked = tmp_path / "a_file"
    blocked.write_text("x")
    monkeypatch.setenv(LIBRARY_ENV, str(blocked / "library"))
    window.action_library.trigger()
    assert window.library_view is library
    assert library.library is None and library.banner.isVisible()
    assert "cannot use" in library.banner.text() and library.visible_paths() == []


def test_compare_is_offered_for_two_calibrated_sessions_only(qtbot, tmp_path):
    root = tmp_path / "lib"
    root.mkdir()
    make_session(root / "P001_2026-03-01_trial01.h5", "P001", 2.0, body_verdict="good")
    make_session(root / "P001_2026-04-12_trial01.h5", "P001", 2.0, "2026-04-12T10:00:00+00:00", body_verdict="good")
    make_session(root / "P001_2026-04-13_trial01.h5", "P001", 2.0, "2026-04-13T10:00:00+00:00")
    window = LibraryView(root)
    qtbot.addWidget(window)
    window.show()
    window.wait_for_scan()
    window.select_paths({"P001_2026-03-01_trial01.h5", "P001_2026-04-12_trial01.h5"})
    assert window.buttons["compare"].isEnabled()
    window.select_paths({"P001_2026-03-01_trial01.h5", "P001_2026-04-13_trial01.h5"})
    compare = window.buttons["compare"]
    assert not compare.isEnabled()
    assert "P001_2026-04-13_trial01.h5: no body calibration" in compare.toolTip()
    assert window.compare_selected() is None
    window.shutdown()


def test_the_trend_shows_a_subjects_clinical_test_visits_and_prints(qtbot, tmp_path):
    """Three visits of one subject with stored Timed Up and Go results (as the guided test or
    `mimucap protocol` keep them): the trend plots them oldest first beside the reference, lists
    them newest first and saves a PDF."""
    from mimucap.gui.trend_dialog import TrendDialog
    from mimucap.session.recorded.clinical_test_results import RESULT_PREFIX

    root = tmp_path / "lib"
    root.mkdir()
    dates = ("2026-03-01", "2026-04-12", "2026-05-20")
    for date in dates:
        make_session(root / f"P001_{date}_trial01.h5", "P001", 2.0, f"{date}T10:00:00+00:00", body_verdict="good")
    library = Library(root)
    library.scan()
    reference = {"key": "total_s", "mean": 9.2, "ci95_low": 8.2, "ci95_high": 10.2, "group": "people 70-79 years",
                 "statistic": "mean and 95% confidence interval (s)", "source": "Bohannon 2006"}
    totals = (14.0, 12.5, 11.0)
    for date, total in zip(dates, totals):
        library.store_result(f"P001_{date}_trial01.h5", RESULT_PREFIX + "tug",
                             {"test": "tug", "total_s": total, "sit_to_stand_s": 1.5, "result": "reprocessed",
                              "reference": reference})
    window = LibraryView(root)
    qtbot.addWidget(window)
    window.show()
    window.wait_for_scan()
    window.select_subject("P001")
    assert window.trend_button.isEnabled()
    dialog = window.open_trend()
    assert isinstance(dialog, TrendDialog) and dialog.test == "tug" and dialog.key == "total_s"
    assert [v.values["total_s"] for v in dialog.visits] == list(totals)
    curve = [item for item in dialog.plot.listDataItems()][0]
    assert list(curve.yData) == list(totals)
    assert dialog.table.item(0, 2).text() == "11.0 s"  # newest first
    assert "Change since the first visit: -3.0 s" in dialog.note.text()
    assert "Timed Up and Go (3 visits)" == dialog.test_combo.currentText()
    pdf = dialog.save_pdf(tmp_path / "trend.pdf")
    assert pdf.stat().st_size > 3000
    dialog.test_combo.setCurrentIndex(dialog.test_combo.findData("10mwt"))
    assert dialog.visits == [] and "No 10-metre walk test of P001" in dialog.note.text()
    assert not dialog.pdf_button.isEnabled()
    dialog.close()
    window.shutdown()
