"""The normative-band file format: a band written by hand is read back; mistakes name the line."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.io.normative_bands import read_normative_bands

GOOD = """# mimucap-normative-bands 1
# source: hand-made test band, no real subjects
joint,axis,percent,mean_deg,sd_deg
knee,flexion,0,5,2
knee,flexion,50,10,4
knee,flexion,100,5,2
hip,flexion,0,30,5
hip,flexion,100,30,5
"""


def test_a_band_file_is_read_and_applied(tmp_path):
    path = tmp_path / "band.csv"
    path.write_text(GOOD)
    bands = read_normative_bands(path)
    knee = bands[("knee", "flexion")]
    assert knee.source.startswith("hand-made")
    low, high = knee.on_cycle()
    assert low[25] == pytest.approx(4.5) and high[25] == pytest.approx(10.5)
    assert knee.fraction_inside(np.full(101, 6.0)) == 1.0
    assert knee.fraction_inside(np.full(101, 20.0)) == 0.0


@pytest.mark.parametrize("text, message", [
    ("joint,axis\n", "line 1 must be"),
    (GOOD.replace("# source: hand-made test band, no real subjects\n", ""), "source"),
    (GOOD.replace("knee,flexion,50,10,4", "knee,flexion,50,ten,4"), "line 5: percent and angles must be numbers"),
    (GOOD.replace("knee,flexion,50,10,4", "knee,flexion,0,10,4"), "line 5: percent must increase"),
    (GOOD.replace("hip,flexion,100,30,5", "hip,flexion,90,30,5"), "hip flexion must cover 0 to 100"),
    (GOOD.replace("knee,flexion,50,10,4", "knee,bending,50,10,4"), "line 5: joint"),
    (GOOD.replace("mean_deg,sd_deg", "mean,sd"), "line 3: header"),
])
def test_mistakes_are_named(tmp_path, text, message):
    path = tmp_path / "band.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        read_normative_bands(path)
