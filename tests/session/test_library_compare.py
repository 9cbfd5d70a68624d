"""The comparison model: named tables from two sessions of a subject."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.io.library import SessionEntry
from mimucap.io.session import Marker
from mimucap.session.library import (
    COMPARISON_TABLES, ComparedSession, ComparisonTable, TimeWindow, compare, comparison_csv,
)


def _side(path: str, amplitude: float, subject: str = "P001", window: TimeWindow | None = None) -> ComparedSession:
    t = np.linspace(0.0, 10.0, 1001)
    angles = {"knee_r_flexion_deg": amplitude * (1 - np.cos(2 * np.pi * t)) / 2,
              "hip_r_flexion_deg": np.where(t < 5.0, 20.0, 40.0)}
    markers = [Marker(1.0, "start"), Marker(4.0, "stop")]
    return ComparedSession(SessionEntry(path, subject), t, angles, markers, window or TimeWindow())


def test_the_rom_table_has_both_sides_and_the_difference():
    before, after = _side("a.h5", 40.0), _side("b.h5", 55.0)
    tables = compare(before, after)
    assert [t.name for t in tables] == ["Joint-angle range of motion"]
    rows = {row[0]: row for row in tables[0].rows}
    assert rows["knee_r_flexion"][3] == pytest.approx(40.0) and rows["knee_r_flexion"][6] == pytest.approx(55.0)
    assert rows["knee_r_flexion"][7] == pytest.approx(15.0)
    assert rows["hip_r_flexion"][3] == pytest.approx(20.0)
    # Between markers (in either order) the hip does not move.
    window = TimeWindow.between_markers(before.markers, 1, 0)
    assert (window.start_s, window.end_s) == (1.0, 4.0) and "start" in window.label
    assert TimeWindow.between_markers(before.markers, None, 0).end_s == 1.0
    assert TimeWindow.between_markers(before.markers, 1, None).start_s == 4.0
    assert TimeWindow.between_markers(before.markers, None, None) == TimeWindow()
    with pytest.raises(ValueError, match="two different markers"):
        TimeWindow.between_markers(before.markers, 1, 1)
    with pytest.raises(ValueError, match="marker 2 does not exist"):
        TimeWindow.between_markers(before.markers, None, 2)
    rows = {row[0]: row for row in compare(_side("a.h5", 40.0, window=window), after)[0].rows}
    assert rows["hip_r_flexion"][3] == pytest.approx(0.0) and rows["hip_r_flexion"][7] == pytest.approx(20.0)


def test_more_tables_are_added_as_builders_and_subjects_must_match():
    def steps(a, b):
        return ComparisonTable("Steps", ("measure", "A", "B", "B − A"), (("steps", 10.0, 12.0, 2.0),))

    tables = compare(_side("a.h5", 40.0), _side("b.h5", 50.0), builders=[*COMPARISON_TABLES, steps,
                                                                           lambda a, b: None])
    assert [t.name for t in tables] == ["Joint-angle range of motion", "Steps"]
    text = comparison_csv(tables)
    assert "Steps\nmeasure,A,B,B − A\nsteps,10.00,12.00,2.00\n" in text
    with pytest.raises(ValueError, match="not sessions of one subject"):
        compare(_side("a.h5", 40.0), _side("b.h5", 40.0, subject="P002"))


def test_two_recordings_of_the_simulated_suit_compare_as_the_simulator_moved():
    """Recorded through the live pipeline (error-free sensors, their mounting as the body
    calibration), processed by ``load_review`` (reprocessed), compared: each range of motion
    within 6° of the simulator's (a range rests on two extreme samples, each with the filter's
    2-3° error)."""
    import tempfile
    from pathlib import Path

    from mimucap.core import skeleton
    from mimucap.core.bodycal import BodyCalibration, CalibrationQuality
    from mimucap.core.analysis.rom import range_of_motion
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.io.session import read_session
    from mimucap.session.feeds import SimulatorFeed
    from mimucap.session.live import LiveSession
    from mimucap.session.review import load_review

    now = [50.0]
    live = LiveSession(SimulatorFeed(SimulationConfig(scenario="walk", errors="ideal"), clock=lambda: now[0]), clock=lambda: now[0])
    live.start()

    def run(seconds: float) -> None:
        for _ in range(int(round(seconds / 0.04))):
            now[0] += 0.04
            live.step()

    mounting = live.feed.simulator.mounting
    live.apply_body_calibration(BodyCalibration(
        q_world_from_body=skeleton.q_world_from_body_facing(0.0), up_world=np.array([0.0, 0.0, 1.0]),
        sensors={m.segment: sid for sid, m in mounting.items()},
        q_segment_from_sensor={m.segment: m.q_segment_from_sensor for m in mounting.values()},
        quality=CalibrationQuality("known mounting", ())))
    sides = []
    try:
        run(1.0)
        with tempfile.TemporaryDirectory() as folder:
            for index in range(2):
                live.start_recording(Path(folder) / f"P001_2026-01-0{index + 1}_trial01.h5", {"id": "P001"})
                run(0.5)
                live.add_marker("stride")
                run(1.2)
                live.add_marker("stride end")
                run(2.0)
                path = live.stop_recording().session_path
                review = load_review(path)
                sides.append((ComparedSession(SessionEntry(path.name, "P001"), review.t_s, review.angles_deg,
                                              review.markers), read_session(path).truth))
    finally:
        live.stop()
    (a, truth_a), (b, truth_b) = sides
    b.window = TimeWindow.between_markers(b.markers, 0, 1)
    rows = {row[0]: row for row in compare(a, b)[0].rows}
    expected_a = range_of_motion(truth_a.t_s, truth_a.joint_angles_deg)
    expected_b = range_of_motion(truth_b.t_s, truth_b.joint_angles_deg, b.window.start_s, b.window.end_s)
    for column in ("knee_r_flexion", "knee_l_flexion", "hip_r_flexion"):
        assert rows[column][3] == pytest.approx(expected_a[f"{column}_deg"].rom_deg, abs=6.0), column
        assert rows[column][6] == pytest.approx(expected_b[f"{column}_deg"].rom_deg, abs=6.0), column
    assert rows["knee_r_flexion"][3] > 40.0  # walking bends the knee


def test_sessions_without_a_body_calibration_or_of_another_result_are_not_compared():
    """Joint angles mean nothing without a body calibration, and two results of different kinds
    differ by their processing: such pairs are refused with the reason."""
    calibrated, other = _side("a.h5", 40.0), _side("b.h5", 40.0)
    other.calibrated = False
    with pytest.raises(ValueError, match="b.h5 has no body calibration, the other session has one"):
        compare(calibrated, other)
    calibrated.calibrated = False
    with pytest.raises(ValueError, match="neither a.h5 nor b.h5 has a body calibration"):
        compare(calibrated, other)
    live = _side("b.h5", 40.0)
    live.result = "live"
    with pytest.raises(ValueError, match="a.h5 is reprocessed .*, b.h5 as seen live"):
        compare(_side("a.h5", 40.0), live)
