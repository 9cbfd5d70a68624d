"""The analysis tables as shown by the Analysis window and the PDF report: one builder for the
gait parameter rows, the ROM rows and the grouping of the cycle curves."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from mimucap.core.analysis.gait import GaitAnalysis
from mimucap.core.analysis.gait_cycle import CycleCurve
from mimucap.core.analysis.gait_parameters import PARAMETERS, GaitParameters, ParameterSummary
from mimucap.core.analysis.rom import RomResult
from mimucap.session.recorded.analysis import (
    GAIT_PARAMETER_HEADER,
    ROM_HEADER,
    SessionAnalysis,
    curve_groups,
    format_value,
    gait_parameter_rows,
    rom_rows,
)

MODEL = SimpleNamespace(joint_names=("lumbar", "hip_l", "hip_r", "knee_l", "knee_r"))


def gait_with(means: dict[str, float]) -> GaitAnalysis:
    summaries = {}
    for name, _, _ in PARAMETERS:
        for k, side in enumerate(("left", "right", "both")):
            mean = means.get(name, math.nan) + k
            summaries[(name, side)] = ParameterSummary(name, side, 10, mean, 0.25, 12.345)
    symmetry = {"stride_time": 3.21, "stance": -0.001}
    return GaitAnalysis([], [], [], GaitParameters(summaries, symmetry))


def curve(column: str, side: str, offset: float) -> CycleCurve:
    return CycleCurve(column, side, np.full(101, offset), np.ones(101), 5, 60.0)


def analysis_with(curves: dict[str, CycleCurve]) -> SessionAnalysis:
    return SessionAnalysis(SimpleNamespace(model=MODEL), None, "", curves)


def test_values_are_formatted_once():
    assert format_value(1.234) == "1.23"
    assert format_value(-0.004) == "0.00"  # no sign the rounding took away
    assert format_value(-0.04, 1) == "0.0" and format_value(-0.06, 1) == "-0.1"
    assert format_value(math.nan) == "–" and format_value(None) == "–"


def test_gait_rows_carry_label_unit_values_symmetry_and_typical_value():
    rows = gait_parameter_rows(gait_with({"cadence": 110.04, "stride_time": 1.1, "stance": 61.0}))
    assert [r.name for r in rows] == [name for name, _, _ in PARAMETERS]
    cadence, stride_time, stance = rows[0], rows[1], rows[3]
    assert cadence.unit == "steps/min" and cadence.digits == 1
    cells = cadence.cells()
    assert len(cells) == len(GAIT_PARAMETER_HEADER)
    assert cells[:4] == ["Cadence (steps/min)", "110.0 ± 0.2", "111.0 ± 0.2", "112.0 ± 0.2"]
    assert cells[4] == "12.3" and cells[5] == "" and cells[6] == "113.0"  # no symmetry index for cadence
    assert stride_time.cells()[1] == "1.10 ± 0.25" and stride_time.cells()[5] == "3.2"
    assert stride_time.cells()[6] == format_value(120.0 / 113.0)
    assert stance.cells()[5] == "0.0"
    swing = rows[4]
    assert swing.cells()[1] == "– ± 0.2" and swing.cells()[5] == "–"  # a symmetry parameter without an index


def test_rom_rows_show_the_left_minus_right_difference_once():
    rom = {("knee_flexion", "left"): RomResult("knee_flexion", "left", (130.0, 134.0), (128.0, 132.0), 135.0),
           ("knee_flexion", "right"): RomResult("knee_flexion", "right", (120.0,), (121.0,), 135.0),
           ("trunk_flexion", "both"): RomResult("trunk_flexion", "both", (), (), 80.0)}
    rows = rom_rows(rom)
    assert [(r.label, r.side) for r in rows] == [("Knee flexion", "left"), ("Knee flexion", "right"),
                                                ("Trunk flexion", "both")]
    assert rows[0].left_minus_right_deg == 130.0 - 121.0 and rows[1].left_minus_right_deg is None
    left = rows[0].cells()
    assert len(left) == len(ROM_HEADER)
    assert left == ["Knee flexion", "left", "2", "130.0", "132.0", "130 134", "9.0", "135", "96"]
    assert rows[1].cells()[6] == "" and rows[2].cells()[2:5] == ["0", "–", "–"]


def test_curves_are_grouped_by_joint_angle_in_model_order():
    before = analysis_with({
        "knee_l_flexion_deg": curve("knee_l_flexion_deg", "left", 1.0),
        "knee_r_flexion_deg": curve("knee_r_flexion_deg", "right", 2.0),
        "hip_l_adduction_deg": curve("hip_l_adduction_deg", "left", 3.0),
        "hip_l_flexion_deg": curve("hip_l_flexion_deg", "left", 4.0),
        "lumbar_flexion_deg@right": curve("lumbar_flexion_deg", "right", 5.0),
    })
    after = analysis_with({"knee_r_flexion_deg": curve("knee_r_flexion_deg", "right", 6.0),
                           "elbow_l_flexion_deg": curve("elbow_l_flexion_deg", "left", 7.0)})
    groups = curve_groups([before])
    assert [g.label for g in groups] == ["Lumbar spine flexion", "Hip flexion", "Hip adduction", "Knee flexion"]
    knee = groups[-1]
    assert set(knee.curves[0]) == {"left", "right"} and knee.curves[0]["right"].mean_deg[0] == 2.0
    both = curve_groups([before, after])
    assert [g.label for g in both][-1] == "Elbow flexion"  # not in the first review's model: last
    knee = next(g for g in both if g.label == "Knee flexion")
    assert len(knee.curves) == 2 and knee.curves[1]["right"].mean_deg[0] == 6.0 and "left" not in knee.curves[1]
    assert curve_groups([analysis_with({})]) == []
