"""Range of motion over a time window."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core.analysis.rom import range_of_motion, window_mask


def test_rom_is_max_minus_min_in_the_window_without_gaps():
    t = np.linspace(0.0, 4.0, 401)
    knee = 30.0 + 25.0 * np.sin(2 * np.pi * t)            # 5..55 over a whole period
    hip = np.where(t < 2.0, 10.0 * t, np.nan)               # a gap after 2 s
    found = range_of_motion(t, {"knee_r_flexion_deg": knee, "hip_r_flexion_deg": hip})
    assert found["knee_r_flexion_deg"].rom_deg == pytest.approx(50.0, abs=1e-6)
    assert found["hip_r_flexion_deg"].max_deg == pytest.approx(10.0 * t[t < 2.0][-1])
    assert found["hip_r_flexion_deg"].samples == int(np.sum(t < 2.0))
    quarter = range_of_motion(t, {"knee_r_flexion_deg": knee}, 0.0, 0.25)["knee_r_flexion_deg"]
    assert quarter.min_deg == pytest.approx(30.0) and quarter.max_deg == pytest.approx(55.0)
    assert range_of_motion(t, {"hip_r_flexion_deg": hip}, 2.5, 3.0) == {}  # nothing finite there


def test_bad_windows_and_lengths_are_refused():
    t = np.arange(5.0)
    assert window_mask(t, None, 2.0).tolist() == [True, True, True, False, False]
    with pytest.raises(ValueError, match="ends"):
        window_mask(t, 3.0, 1.0)
    with pytest.raises(ValueError, match="knee"):
        range_of_motion(t, {"knee": np.zeros(4)})
