"""The export dialog writes the motion files for other programs, and File → Open imports an Xsens
MVNX file as a session and reviews it, as a user would click through them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PyQt5 import QtGui, QtWidgets


def test_export_dialog_writes_c3d_bvh_sto_and_opensim_mot(qtbot, tmp_path, calibrated_walk):
    from mimucap.gui.export_dialog import ExportDialog
    from mimucap.io.angles_export import read_angles_mot
    from mimucap.session.recorded.review import load_review

    # A calibrated walk: joint angles mean something only with a body calibration.
    dialog = ExportDialog(None, load_review(calibrated_walk))
    qtbot.addWidget(dialog)
    for box in (dialog.want_csv, dialog.want_mot, dialog.want_summary):
        box.setChecked(False)
    for box in (dialog.want_c3d, dialog.want_bvh, dialog.want_sto, dialog.want_opensim_mot):
        box.setChecked(True)
    dialog.base_path.setText(str(tmp_path / "out"))
    dialog.start_export()
    qtbot.waitUntil(lambda: dialog.result is not None, timeout=30000)
    names = sorted(p.name for p in dialog.result.files)
    assert names == ["out_motion.c3d", "out_opensim_coordinates.mot", "out_orientations.sto",
                     "out_orientations_calibration.sto", "out_skeleton.bvh", "out_skeleton_markers.csv"]
    mot = read_angles_mot(tmp_path / "out_opensim_coordinates.mot")
    assert "knee_angle_r" in mot.angles_deg and np.ptp(mot.angles_deg["knee_angle_r"]) > 20.0
    assert "Exported" in dialog.message.text()


@pytest.mark.data("mvnx")
def test_open_imports_an_mvnx_file_and_reviews_it(qtbot, tmp_path, monkeypatch, shared_data):
    from mimucap.gui.main_window import MainWindow

    sample = shared_data / "body" / "mvnx_sample" / "test_mocap.mvnx"
    window = MainWindow(None)
    qtbot.addWidget(window)
    out = tmp_path / "imported.h5"
    monkeypatch.setattr(QtWidgets.QFileDialog, "getOpenFileName", lambda *a, **k: (str(sample), ""))
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName", lambda *a, **k: (str(out), ""))
    window.ask_open_session()
    assert out.exists()
    review = window.review.view
    assert window.workspace == "review" and review.path == out
    qtbot.waitUntil(lambda: review.player is not None, timeout=30000)
    assert review.player.model.name == "fifteen_segment"
    assert review.player.pose_source == "body calibration"
    window.close()


def test_the_summary_chart_and_table_say_what_they_hold(qtbot, tmp_path, calibrated_walk):
    """The summary PNG's caption and the summary CSV's header carry the result's record (result,
    body and magnetometer calibrations, model, software, file), as every export does."""
    from mimucap.gui.export_dialog import ExportDialog
    from mimucap.session.recorded.review import load_review

    data = load_review(calibrated_walk)
    dialog = ExportDialog(None, data)
    qtbot.addWidget(dialog)
    assert not dialog.calibration_note.isVisible()
    png = dialog.save_summary_png(tmp_path / "summary.png")
    lines = data.provenance.lines()
    assert dialog.summary_caption.splitlines() == lines
    assert lines[0].startswith("Result: reprocessed") and lines[1].startswith("Body calibration: N-pose/T-pose")
    image = QtGui.QImage(str(png))
    assert image.height() > 90 + 24 * dialog.summary.rowCount()  # the caption is drawn below the bars
    header = [line[2:] for line in dialog.save_summary_csv(tmp_path / "summary.csv").read_text().splitlines()
              if line.startswith("# ")]
    assert all(line in header for line in lines)


@pytest.fixture(scope="module")
def uncalibrated_walk(tmp_path_factory) -> Path:
    from mimucap.cli import main

    path = tmp_path_factory.mktemp("uncalibrated") / "walk.h5"
    assert main(["simulate", "--scenario", "walk", "--duration", "3", "--out", str(path)]) == 0
    return path


def test_without_a_body_calibration_only_the_sensor_data_can_be_exported(qtbot, tmp_path, uncalibrated_walk):
    """Joint angles, ranges of motion and segments mean nothing without a body calibration: the
    dialog offers the sensor data alone, says why, and has no summary to save."""
    from mimucap.gui.export_dialog import ExportDialog
    from mimucap.session.recorded.review import load_review

    dialog = ExportDialog(None, load_review(uncalibrated_walk))
    qtbot.addWidget(dialog)
    dialog.show()
    assert dialog.calibration_note.isVisible() and "Only the sensor data" in dialog.calibration_note.text()
    for box in (dialog.want_csv, dialog.want_mot, dialog.want_opensim_mot, dialog.want_summary,
                dialog.want_c3d, dialog.want_bvh, dialog.want_sto):
        assert not box.isEnabled() and not box.isChecked() and "body calibration" in box.toolTip()
    assert dialog.want_sensors.isEnabled() and dialog.want_sensors.isChecked()
    assert not dialog.summary.isVisible()
    assert not dialog.summary_csv_button.isEnabled() and not dialog.summary_png_button.isEnabled()
    assert dialog.export_button.isEnabled()


def test_review_plots_no_joint_angles_without_a_body_calibration(qtbot, uncalibrated_walk, calibrated_walk):
    from mimucap.gui.review_view import ReviewView
    from mimucap.session.recorded.analysis import NEEDS_BODY_CALIBRATION

    for path, calibrated in ((uncalibrated_walk, False), (calibrated_walk, True)):
        review = ReviewView(path)
        qtbot.addWidget(review)
        review.show()
        review.load()
        qtbot.waitUntil(lambda r=review: r.player is not None, timeout=30000)
        plots = review.plots
        assert bool(plots.selected_joints) == calibrated
        assert plots.joint_button.isEnabled() == calibrated
        if not calibrated:
            assert NEEDS_BODY_CALIBRATION in plots.joint_button.toolTip()
        review.shutdown()


def test_exports_go_to_a_folder_of_their_own_where_every_file_dialog_starts(qtbot, tmp_path, monkeypatch,
                                                                             uncalibrated_walk):
    """Not the library folder itself, not the program's working folder: the session's own
    export folder, named after it, created when a file dialog needs it."""
    from mimucap.gui.export_dialog import ExportDialog
    from mimucap.session.recorded.review import load_review

    monkeypatch.chdir(tmp_path)
    dialog = ExportDialog(None, load_review(uncalibrated_walk))
    qtbot.addWidget(dialog)
    folder = uncalibrated_walk.with_name("walk_exports")
    assert dialog.export_base_path() == folder / "walk"
    asked = []
    monkeypatch.setattr(QtWidgets.QFileDialog, "getSaveFileName", lambda parent, title, start, kinds: (asked.append(start), ("", ""))[1])
    dialog._ask_summary_png()
    dialog._ask_summary_csv()
    dialog._browse()
    assert asked == [str(folder / "walk_joint_angle_summary.png"), str(folder / "walk_joint_angle_summary.csv"),
                     str(folder / "walk")]
    assert folder.is_dir()
    dialog.start_export()
    qtbot.waitUntil(lambda: dialog.result is not None, timeout=30000)
    assert sorted(p.name for p in dialog.result.files) == [f"walk_sensor_{s}_raw.csv" for s in sorted(
        dialog.data.session.sensors)]
    assert all(p.parent == folder for p in dialog.result.files)
