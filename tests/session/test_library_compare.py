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
