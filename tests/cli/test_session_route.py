"""The README's command-line route on a simulated session: simulate → magcal fit --save →
bodycal (pose windows from the session's markers, stored magnetometer calibrations) → angles.
The simulator's truth, stored in the session, is the independent reference: no command reads it."""

from __future__ import annotations

import importlib.util
import json

import numpy as np
import pytest

from mimucap.cli import main
from mimucap.core import phase_markers
from mimucap.io.angles_export import read_angles_csv
from mimucap.io.session import read_session
from mimucap.session.angle_accuracy import angle_errors

COLUMNS = ("hip_l_flexion_deg", "hip_r_flexion_deg", "knee_l_flexion_deg", "knee_r_flexion_deg")


@pytest.fixture(scope="module")
def route(tmp_path_factory):
    """The route's files, and the user data folder where magcal stored the calibrations."""
    folder = tmp_path_factory.mktemp("route")
    session = folder / "demo.h5"
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MIMUCAP_DATA_DIR", str(folder / "data"))
        assert main(["simulate", "--scenario", "demo", "--duration", "90", "--seed", "3", "--out", str(session)]) == 0
        assert main(["magcal", "fit", str(session), "--save"]) == 0
        calibration = folder / "CAL.json"
        assert main(["bodycal", str(session), "--out", str(calibration)]) == 0
    return folder, session, calibration


@pytest.fixture(autouse=True)
def _route_data(route, monkeypatch):
    monkeypatch.setenv("MIMUCAP_DATA_DIR", str(route[0] / "data"))


@pytest.mark.parametrize("live", [False, True])
def test_knee_and_hip_flexion_while_walking_match_the_truth(route, live, capsys):
    folder, session, calibration = route
    out = folder / f"angles{'_live' if live else ''}.csv"
    assert main(["angles", str(session), "--calibration", str(calibration), "--out", str(out)]
                + (["--live"] if live else [])) == 0
    printed = capsys.readouterr().out
    assert "magnetometer S01: stored" in printed
    header = [line for line in out.read_text().splitlines() if line.startswith("#")]
    assert any(("as seen live" if live else "reprocessed") in line for line in header)
    table = read_angles_csv(out)
    recorded = read_session(session)
    assert [m.label for m in table.markers] == [m.label for m in recorded.markers]  # the record's markers
    walks = phase_markers.phase_windows(recorded.markers, phase_markers.WALK, float(table.t_s[-1]))
    assert len(walks) >= 2
    for window in walks:
        errors = angle_errors(table.t_s, table.angles_deg, recorded.truth.t_s, recorded.truth.joint_angles_deg,
                              span_s=(window[0] + 1.0, window[1]))
        for column in COLUMNS:
            assert errors[column].rms_deg < 3.0, (window, column, errors[column])



def test_the_npose_orientations_come_from_the_still_calibrated_sensors(route):
    """Every sensor has a stored magnetometer calibration: its N-pose orientation is the static
    alignment of its accelerometer and calibrated field, within a few degrees of the smoothed
    filter's (what the calibration file records per sensor)."""
    _folder, _session, calibration = route
    document = json.loads(calibration.read_text())
    differences = document["npose_track_vs_given_deg"]
    assert set(differences) == {entry["sensor"] for entry in document["segments"].values()}
    assert max(differences.values()) < 5.0, differences

def test_a_poor_calibration_is_refused_unless_accepted(route, tmp_path, capsys):
    folder, session, calibration = route
    document = json.loads(calibration.read_text())
    document["verdict"] = "poor"
    document["quality"]["verdict"] = "poor"
    document["quality"]["problems"] = ["the arms disagree"]
    poor = tmp_path / "poor.json"
    poor.write_text(json.dumps(document))
    assert main(["angles", str(session), "--calibration", str(poor), "--out", str(tmp_path / "a.csv")]) != 0
    assert "verdict is poor (the arms disagree)" in capsys.readouterr().err
    assert not (tmp_path / "a.csv").exists()
    assert main(["angles", str(session), "--calibration", str(poor), "--out", str(tmp_path / "a.csv"),
                 "--accept-poor"]) == 0


def test_bodycal_without_pose_markers_says_what_to_give(tmp_path, capsys):
    session = tmp_path / "walk.h5"
    assert main(["simulate", "--scenario", "walk", "--duration", "5", "--no-magcal-turns", "--out", str(session)]) == 0
    assert main(["bodycal", str(session), "--out", str(tmp_path / "cal.json")]) != 0
    assert "give --npose and --tpose" in capsys.readouterr().err


# --------------------------------------------------------------------------------------------
# The route's exports: segment orientations and OpenSense (issue 31, points 1 and 2)
# --------------------------------------------------------------------------------------------

def route_windows(markers, end_s: float) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """The held part of every N-pose (from a second after its marker to 0.3 s before the next)
    and every walk (from a second after its marker)."""
    still = [(a + 1.0, b - 0.3) for a, b in phase_markers.phase_windows(markers, phase_markers.NPOSE, end_s)]
    walking = [(a + 1.0, b) for a, b in phase_markers.phase_windows(markers, phase_markers.WALK, end_s)]
    return still, walking


def test_exported_segment_headings_follow_the_truth_in_the_n_pose_and_walking(route, tmp_path, capsys):
    """C3D, BVH and OpenSense exports of the route (``--calibration CAL.json``), read back by
    other programs' readers: every segment's heading within 3° of the simulator's, in each
    N-pose (mean) and while walking (RMS). Before the body calibration carried the magnetometer
    calibrations it was made with, the export fused the raw field and every segment was turned
    by its own constant (tens of degrees)."""
    from tests.io.exported_segments import bvh_segments, c3d_segments, heading_figures, sto_segments

    folder, session, calibration = route
    recorded = read_session(session)
    still, walking = route_windows(recorded.markers, float(recorded.truth.t_s[-1]))
    assert len(still) == 4 and len(walking) == 3
    readers = {"c3d": lambda p: c3d_segments(p, recorded.markers), "bvh": lambda p: bvh_segments(p, recorded.markers),
               "sto": sto_segments}
    worst = {}
    for fmt, read in readers.items():
        path = tmp_path / f"route.{fmt}"
        assert main(["export", str(session), "--calibration", str(calibration), "--format", fmt,
                     "--out", str(path)]) == 0
        t, segments = read(path)
        assert len(segments) == 10
        figures = heading_figures(t, segments, recorded.truth, still, walking)
        worst[fmt] = (max(f[0] for f in figures.values()), max(f[1] for f in figures.values()))
        for segment, (npose_deg, walking_deg) in figures.items():
            assert npose_deg < 3.0 and walking_deg < 3.0, (fmt, segment, npose_deg, walking_deg)
    with capsys.disabled():
        print("\ncommand-line route, worst segment heading error (N-pose mean, walking RMS), deg: "
              + ", ".join(f"{fmt} {a:.2f} / {b:.2f}" for fmt, (a, b) in worst.items()))


def test_exported_headings_on_the_seed_whose_gyroscopes_cost_most(tmp_path, monkeypatch, capsys):
    """Seed 5's demo (46 s), whose units' 1-2 % gyroscope scale errors turned the exported
    headings 3.7° off before ``magcal fit`` estimated the scale factors from the turns: through
    the whole route, every segment of the OpenSense table within 3° of the truth (N-pose mean,
    walking RMS). The magnetometer calibrations stored by ``magcal fit`` carry the correction."""
    from mimucap.io.calibration_store import CalibrationStore
    from tests.io.exported_segments import heading_figures, sto_segments

    monkeypatch.setenv("MIMUCAP_DATA_DIR", str(tmp_path / "data"))
    session, calibration, table = tmp_path / "demo.h5", tmp_path / "CAL.json", tmp_path / "route.sto"
    assert main(["simulate", "--scenario", "demo", "--duration", "46", "--seed", "5", "--out", str(session)]) == 0
    assert main(["magcal", "fit", str(session), "--save"]) == 0
    assert main(["bodycal", str(session), "--out", str(calibration)]) == 0
    assert main(["export", str(session), "--calibration", str(calibration), "--format", "sto", "--out", str(table)]) == 0
    store = CalibrationStore()
    assert all(store.load(sensor_id).corrects_gyr for sensor_id in store.sensor_ids())
    recorded = read_session(session)
    still, walking = route_windows(recorded.markers, float(recorded.truth.t_s[-1]))
    t, segments = sto_segments(table)
    figures = heading_figures(t, segments, recorded.truth, still, walking)
    assert len(figures) == 10
    for segment, (npose_deg, walking_deg) in figures.items():
        assert npose_deg < 3.0 and walking_deg < 3.0, (segment, npose_deg, walking_deg)
    with capsys.disabled():
        print(f"\ncommand-line route, seed 5, worst segment heading error (N-pose mean, walking RMS), deg: "
              f"{max(f[0] for f in figures.values()):.2f} / {max(f[1] for f in figures.values()):.2f}")


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("opensim") is None,
                    reason="opensim (OpenSim 4.6, test extra) is not installed: pip install opensim")
@pytest.mark.data("opensense")
def test_opensense_on_the_route_with_its_calibration_table(route, shared_data, tmp_path, capsys):
    """The route's first walk exported as an OpenSense table (``--calibration CAL.json``) with its
    calibration table, OpenSim 4.6's IMUPlacer on the calibration table and IMU inverse
    kinematics on the table: knee flexion within 3° RMS of the simulator's while walking."""
    from tests.io.exported_segments import opensense_knee_errors

    folder, session, calibration = route
    recorded = read_session(session)
    (walk_start, walk_end), *_ = phase_markers.phase_windows(recorded.markers, phase_markers.WALK, float(recorded.truth.t_s[-1]))
    table = tmp_path / "walk.sto"
    assert main(["export", str(session), "--calibration", str(calibration), "--format", "sto",
                 "--from", f"{walk_start + 1.0}", "--to", f"{walk_end}", "--out", str(table)]) == 0
    model = shared_data / "body" / "opensense_example" / "Rajagopal_2015.osim"
    truth = recorded.truth
    errors = opensense_knee_errors(table, tmp_path / "walk_calibration.sto", model, tmp_path / "ik",
                                   lambda t, column: np.interp(t, truth.t_s, truth.joint_angles_deg[column]))
    with capsys.disabled():
        print("\nOpenSense IK (calibration table) vs truth while walking, command-line route, RMS deg: "
              + ", ".join(f"{k} {v:.2f}" for k, v in errors.items()))
    assert max(errors.values()) < 3.0, errors


# --------------------------------------------------------------------------------------------
# No analysis without a body calibration (issue 31, point 4)
# --------------------------------------------------------------------------------------------

def route_reference(recorded):
    """The simulator's strides of the route's steady walking (contacts and stride lengths from
    the stored truth, :func:`mimucap.session.recorded.gait_validation.simulated_reference`)."""
    from types import SimpleNamespace

    from mimucap.session.recorded.gait_validation import simulated_reference

    truth = recorded.truth
    suit = SimpleNamespace(t_s=truth.t_s, q_world_from_segment=truth.q_world_from_segment,
                           root_position_m=truth.extra["root_position_m"], foot_contact=truth.extra["foot_contact"])
    return simulated_reference(SimpleNamespace(truth=suit, markers=[(m.t_s, m.label) for m in recorded.markers],
                                               model_name=recorded.metadata["skeleton_model"],
                                               height_m=recorded.metadata["height_m"]))


def test_gait_and_report_refuse_a_session_without_a_body_calibration(route, tmp_path, capsys):
    folder, session, calibration = route
    capsys.readouterr()
    assert main(["gait", str(session), "--out", str(tmp_path / "gait")]) == 1
    said = capsys.readouterr().err
    assert "no body calibration" in said and "--calibration CAL.json" in said
    assert not (tmp_path / "gait").exists()
    assert main(["report", str(session), "--out", str(tmp_path / "report.pdf")]) == 1
    said = capsys.readouterr().err
    assert "no body calibration" in said and "--calibration CAL.json" in said
    assert not (tmp_path / "report.pdf").exists()
    # The temporal parameters alone, when asked for, labelled so in every table.
    from mimucap.io.analysis_tables import read_table

    assert main(["gait", str(session), "--temporal-only", "--out", str(tmp_path / "temporal")]) == 0
    assert "temporal gait parameters only" in capsys.readouterr().out
    for name in ("strides.csv", "parameters.csv", "bouts_turns.csv"):
        header = [line for line in (tmp_path / "temporal" / name).read_text().splitlines() if line.startswith("#")]
        assert any(line.startswith("# Analysis: no body calibration") for line in header), name
        assert any(line.startswith("# Body calibration: none") for line in header), name
    rows = {(r["parameter"], r["side"]): r for r in read_table(tmp_path / "temporal" / "parameters.csv")}
    assert 100.0 < float(rows[("cadence", "both")]["mean"]) < 125.0
    assert rows[("stride_length", "both")]["mean"] == "" and rows[("gait_speed", "both")]["mean"] == ""
    assert [r for r in read_table(tmp_path / "temporal" / "bouts_turns.csv") if r["kind"] == "turn"] == []
    assert not (tmp_path / "temporal" / "gait_cycle_curves.csv").exists()


def test_gait_and_report_with_the_calibration_find_the_turns_and_stride_lengths(route, tmp_path, capsys):
    """With ``--calibration`` the route's three turns (marked ``turn``) are found, none while the
    sensors were turned in the hands, and the stride lengths follow the simulator's."""
    from mimucap.io.analysis_tables import read_table
    from mimucap.session.recorded.gait_validation import compare

    folder, session, calibration = route
    out = tmp_path / "gait"
    assert main(["gait", str(session), "--calibration", str(calibration), "--out", str(out)]) == 0
    recorded = read_session(session)
    end_s = float(recorded.truth.t_s[-1])
    marked = phase_markers.phase_windows(recorded.markers, phase_markers.TURN, end_s)
    turns = [(float(r["start_s"]), float(r["end_s"]), float(r["angle_deg"]))
             for r in read_table(out / "bouts_turns.csv") if r["kind"] == "turn"]
    assert len(turns) == len(marked) == 3, turns
    for (start, end, angle), (a, b) in zip(turns, marked):
        assert a - 1.0 < start < b and 150.0 < abs(angle) < 210.0, (start, end, angle, a, b)
    strides = read_table(out / "strides.csv")
    lengths = [float(s["stride_length_m"]) for s in strides if s["analysed"] == "true"]
    assert len(lengths) >= 20 and all(np.isfinite(lengths))
    from mimucap.session.recorded.analysis import analyse_review
    from mimucap.session.recorded.review import load_review

    analysis = analyse_review(load_review(session, calibration_file=calibration))
    figures = compare(analysis.gait.strides, route_reference(recorded)).summary()
    with capsys.disabled():
        print(f"\ncommand-line route with --calibration: {len(turns)} turns "
              f"({', '.join(f'{t[2]:+.0f}° at {t[0]:.1f} s' for t in turns)}), stride length error "
              f"{figures['length_mean_cm']:+.1f} ± {figures['length_sd_cm']:.1f} cm over {figures['n_reference']} strides")
    assert figures["missed"] == 0 and figures["length_mae_cm"] < 5.0, figures
    pdf = tmp_path / "report.pdf"
    assert main(["report", str(session), "--calibration", str(calibration), "--out", str(pdf)]) == 0
    assert pdf.read_bytes().startswith(b"%PDF")
