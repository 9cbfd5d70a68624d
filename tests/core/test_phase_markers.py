"""Phase windows from a session's markers."""

from __future__ import annotations

from mimucap.core import phase_markers
from mimucap.io.session import Marker


def test_a_phase_lasts_from_its_marker_to_the_next_or_the_end() -> None:
    markers = [Marker(30.0, "T-pose (right arm)"), Marker(0.0, "magnetometer turns"), Marker(26.0, "N-pose"),
               Marker(33.0, "n-pose "), Marker(35.0, "walk")]
    assert phase_markers.phase_windows(markers, phase_markers.MAG_TURNS, 90.0) == [(0.0, 26.0)]
    assert phase_markers.phase_windows(markers, phase_markers.NPOSE, 90.0) == [(26.0, 30.0), (33.0, 35.0)]
    assert phase_markers.phase_windows(markers, phase_markers.TPOSE, 90.0) == [(30.0, 33.0)]
    assert phase_markers.phase_windows([(35.0, "walk"), (5.0, "walk")], phase_markers.WALK, 40.0) == [(5.0, 35.0), (35.0, 40.0)]
    assert phase_markers.phase_windows(markers, phase_markers.WALK, 35.0) == []        # starts at the end: empty
    assert phase_markers.phase_windows(markers, "T-pose (right", 90.0) == []   # whole labels only
    assert not phase_markers.is_phase("N-poses", phase_markers.NPOSE)
