"""Gait analysis against independent references: the gaitmap example's optical events and heel
positions (real foot IMUs), and the simulated suit's contact truth (whole pipeline: session
without truth, body calibration from its N/T-pose, review, analysis)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mimucap.core.analysis.gait import GaitInput, analyse_gait
from mimucap.core.simulate.config import SimulationConfig
from mimucap.io.analysis_tables import read_table
from mimucap.io.gaitmap import read_foot_imu_csv, read_gaitmap_reference
from mimucap.session.recorded.analysis import write_analysis_csv
from mimucap.session.recorded.gait_validation import (
    compare,
    simulated_analysis,
    simulated_reference,
    straight_reference,
    walk_windows,
)
from tests.external_data import data_path


@pytest.fixture(scope="module")
def gaitmap_result():
    folder = data_path("gaitmap")
    feet = read_foot_imu_csv(folder / "imu_sample.csv", 204.8, "deg/s")
    gait = analyse_gait([GaitInput(side, "foot", side, imu.t_s, imu.sagittal_rate, imu.acc, imu.gyr)
                         for side, imu in feet.items()])
    return gait, read_gaitmap_reference(folder)


@pytest.mark.data("gaitmap")
def test_gaitmap_events_and_stride_lengths_meet_the_goals(gaitmap_result):
    gait, reference = gaitmap_result
    straight = straight_reference(reference)
    assert len(straight) == 55  # 28 + 29 reference strides minus the two turning ones
    figures = compare(gait.strides, straight).summary()
    assert figures["missed"] == 0 and figures["extra"] == 0
    assert figures["ic_median_ms"] <= 20.0
    assert figures["fc_median_ms"] <= 30.0
    assert figures["length_mae_cm"] <= 5.0


@pytest.mark.data("gaitmap")
def test_gaitmap_turns_are_refused_and_found(gaitmap_result):
    gait, reference = gaitmap_result
    turning_reference = [r for r in reference if abs(r.heading_change_deg) > 45.0]
    assert len(turning_reference) == 2
    for r in turning_reference:
        # No analysed stride ends with the turning stride's final contact.
        assert not any(s.analysed and s.side == r.side and abs(s.next_ic_s - r.ic) < 0.15 for s in gait.strides)
    # The 180° turn half-way (about 18 s) is found with its angle.
    middle = [t for t in gait.turns if t.start_s < 18.0 < t.end_s]
    assert len(middle) == 1 and 140.0 < abs(middle[0].angle_deg) < 220.0
    assert all(s.refused_because for s in gait.strides if not s.analysed)


@pytest.mark.data("gaitmap")
def test_gaitmap_stride_time_agrees_with_the_optical_reference(gaitmap_result):
    gait, reference = gaitmap_result
    straight = straight_reference(reference)
    for side in ("left", "right"):
        expected = np.mean([r.ic - r.pre_ic for r in straight if r.side == side])
        assert gait.parameters.get("stride_time", side).mean == pytest.approx(expected, abs=0.01)


@pytest.mark.parametrize("n_sensors, ic_ms, length_cm", [(17, 50.0, 3.0), (10, 30.0, 6.0)])
def test_simulated_suit_events_and_stride_lengths(tmp_path, n_sensors, ic_ms, length_cm):
    """Pipeline-dependent: sensor orientations (on-board, BNO055-like), body calibration and
    review; the goals are asserted below (figures in the README)."""
    config = SimulationConfig(scenario="demo", duration_s=30.0, n_sensors=n_sensors, errors="bno055", seed=5)
    result, analysis = simulated_analysis(config, tmp_path)
    assert analysis.gait is not None
    reference = simulated_reference(result)
    assert len(reference) >= 12
    figures = compare(analysis.gait.strides, reference,
                      windows=walk_windows(result.markers, float(result.truth.t_s[-1]))).summary()
    assert figures["missed"] == 0 and figures["extra"] == 0
    assert figures["ic_median_ms"] <= ic_ms
    assert figures["fc_median_ms"] <= 50.0
    assert figures["length_mae_cm"] <= length_cm
    # The turns between the walks are found.
    assert len(analysis.gait.turns) >= 1
    # Every table is written, and the curves cover every joint of the legs.
    written = write_analysis_csv(tmp_path / "out", analysis)
    names = {p.name for p in written}
    assert {"strides.csv", "parameters.csv", "gait_cycle_curves.csv"} <= names
    assert "knee_r_flexion_deg" in analysis.curves and "hip_l_flexion_deg" in analysis.curves
    knee = analysis.curves["knee_r_flexion_deg"]
    # Swing knee flexion peaks in swing, after the stance/swing boundary (simulated gait: ~60°).
    assert np.argmax(knee.mean_deg) > knee.stance_percent - 5
    rows = read_table(tmp_path / "out" / "strides.csv")
    assert {r["foot"] for r in rows} == {"left", "right"}


@pytest.mark.parametrize("seed", [1, 4])
@pytest.mark.parametrize("n_sensors", [17, 10], ids=["feet", "shanks"])
def test_simulated_feet_and_shanks_meet_the_gait_goals(tmp_path, n_sensors, seed):
    """On the simulated walk (feet that meet the floor, contacts as marker events) the events of
    foot sensors (17-sensor suit) and of shank sensors (10) meet the goals: median |IC| ≤ 20 ms,
    median |FC| ≤ 30 ms, stride length MAE ≤ 5 cm, every stride found. Two subjects' seeds that
    no setting was chosen on."""
    config = SimulationConfig(scenario="demo", duration_s=30.0, n_sensors=n_sensors, errors="bno055", seed=seed)
    result, analysis = simulated_analysis(config, tmp_path)
    reference = simulated_reference(result)
    assert len(reference) >= 12
    comparison = compare(analysis.gait.strides, reference,
                         windows=walk_windows(result.markers, float(result.truth.t_s[-1])))
    figures = comparison.summary()
    assert figures["missed"] == 0 and figures["extra"] == 0
    assert figures["ic_median_ms"] <= 20.0
    assert figures["fc_median_ms"] <= 30.0
    assert figures["length_mae_cm"] <= 5.0
    # The initial contacts come from the heel strike's impact, which the simulated floor makes.
    impacts = sum(int(e.ic_at_impact.sum()) for e in analysis.gait.events.values())
    assert impacts >= 0.75 * sum(len(e) for e in analysis.gait.events.values())


@pytest.mark.data("gaitmap")
def test_gaitmap_without_known_axes_uses_the_dominant_gyroscope_axis():
    """A sensor without body calibration: the sagittal axis is found from the gyroscope
    alone (its dominant axis), and the goals still hold on the real data."""
    from mimucap.core.analysis.sagittal import dominant_axis, sagittal_rate_dominant

    folder = data_path("gaitmap")
    feet = read_foot_imu_csv(folder / "imu_sample.csv", 204.8, "deg/s")
    for imu in feet.values():
        assert dominant_axis(imu.gyr) @ np.array([0.0, -1.0, 0.0]) > 0.85  # the foot's mediolateral axis
    gait = analyse_gait([GaitInput(side, "foot", side, imu.t_s, sagittal_rate_dominant(imu.gyr), imu.acc, imu.gyr)
                         for side, imu in feet.items()])
    figures = compare(gait.strides, straight_reference(read_gaitmap_reference(folder))).summary()
    assert figures["missed"] == 0 and figures["extra"] == 0
    assert figures["ic_median_ms"] <= 20.0 and figures["fc_median_ms"] <= 30.0
