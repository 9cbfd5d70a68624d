"""Joint-angle files: CSV with a self-describing header, OpenSim .mot with a correct header."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core import skeleton as sk
from mimucap.io import angles_export as ae

T = np.arange(5) * 0.01
ANGLES = {"knee_r_flexion_deg": np.array([0.0, 10.0, 20.5, 30.25, -1.0]),
          "hip_r_adduction_deg": np.array([1.0, 2.0, 3.0, 4.0, 5.0])}


def test_csv_header_names_sequence_signs_and_units(tmp_path):
    path = tmp_path / "a.csv"
    ae.write_angles_csv(path, T, ANGLES, "yxy", notes=["input: walk.sto"])
    text = path.read_text()
    comments = [line for line in text.splitlines() if line.startswith("#")]
    assert any("shoulders Y-X'-Y'' (ISB); every other joint Z-X'-Y''" in c for c in comments)
    assert any("knee's raw z angle" in c for c in comments)  # the sign convention is spelled out
    assert any("Units: t_s in seconds" in c and "degrees" in c for c in comments)
    assert "# input: walk.sto" in comments
    for line in sk.JOINT_ANGLE_SIGNS_DOC.splitlines():
        assert f"# {line}" in comments
    assert text.splitlines()[len(comments)] == "t_s,knee_r_flexion_deg,hip_r_adduction_deg"
    table = ae.read_angles_csv(path)
    np.testing.assert_allclose(table.t_s, T)
    for name, values in ANGLES.items():
        np.testing.assert_allclose(table.angles_deg[name], values)


def test_mot_header_is_what_opensim_expects(tmp_path):
    path = tmp_path / "a.mot"
    ae.write_angles_mot(path, T, ANGLES)
    lines = path.read_text().splitlines()
    end = lines.index("endheader")
    header = lines[:end]
    assert header[0] == "mimucap_joint_angles"
    assert "version=1" in header and "nRows=5" in header and "nColumns=3" in header
    assert "inDegrees=yes" in header
    # Free text lines carry no '=' (OpenSim would read them as metadata), except the keys above.
    assert [h for h in header if "=" in h] == ["version=1", "nRows=5", "nColumns=3", "inDegrees=yes"]
    assert lines[end + 1].split("\t") == ["time", "knee_r_flexion_deg", "hip_r_adduction_deg"]
    assert len(lines) == end + 2 + 5
    table = ae.read_angles_mot(path)
    for name, values in ANGLES.items():
        np.testing.assert_allclose(table.angles_deg[name], values)


def test_mot_in_radians_is_read_in_degrees(tmp_path):
    path = tmp_path / "r.mot"
    path.write_text("m\nversion=1\nnRows=2\nnColumns=2\ninDegrees=no\nendheader\ntime\tknee_r_flexion_deg\n0\t0\n0.01\t1.5707963267948966\n")
    table = ae.read_angles_mot(path)
    np.testing.assert_allclose(table.angles_deg["knee_r_flexion_deg"], [0.0, 90.0])
    path.write_text("m\nnRows=3\nendheader\ntime\tk_deg\n0\t0\n")
    with pytest.raises(ValueError, match="nRows=3 but 1 rows follow"):
        ae.read_angles_mot(path)


def test_write_by_suffix_and_bad_input(tmp_path):
    ae.write_angles(tmp_path / "x.csv", T, ANGLES)
    ae.write_angles(tmp_path / "x.mot", T, ANGLES)
    with pytest.raises(ValueError, match="written as .csv or .mot"):
        ae.write_angles(tmp_path / "x.txt", T, ANGLES)
    with pytest.raises(ValueError, match="must end in '_deg'"):
        ae.write_angles_csv(tmp_path / "y.csv", T, {"knee": np.zeros(5)})
    with pytest.raises(ValueError, match="5 rows.*t_s has 4|have 5 rows, t_s has 4"):
        ae.write_angles_csv(tmp_path / "y.csv", T[:4], ANGLES)
    with pytest.raises(ValueError, match="no joint angle columns"):
        ae.write_angles_csv(tmp_path / "y.csv", T, {})
    with pytest.raises(ValueError, match="unknown shoulder sequence"):
        ae.write_angles_csv(tmp_path / "y.csv", T, ANGLES, "abc")


def test_negative_zero_is_written_as_zero(tmp_path):
    path = tmp_path / "z.csv"
    ae.write_angles_csv(path, T[:1], {"knee_r_flexion_deg": np.array([-0.0])})
    assert path.read_text().splitlines()[-1] == "0.000000,0.000000"


@pytest.mark.parametrize("suffix", [".csv", ".mot"])
def test_columns_keep_machine_names_and_gain_readable_labels_and_markers(tmp_path, suffix):
    from mimucap.io.session import Marker

    path = tmp_path / f"m{suffix}"
    markers = [Marker(0.03, 'heel strike, "left"'), Marker(0.01, "start=go\tnow"), Marker(0.04, "Pause é")]
    ae.write_angles(path, T, ANGLES, markers=markers)
    table = ae.read_angles_csv(path) if suffix == ".csv" else ae.read_angles_mot(path)
    assert list(table.angles_deg) == ["knee_r_flexion_deg", "hip_r_adduction_deg"]
    assert table.labels == {"knee_r_flexion_deg": "Right knee flexion (°)",
                            "hip_r_adduction_deg": "Right hip adduction (°)"}
    assert [(m.t_s, m.label) for m in table.markers] == [
        (0.01, "start=go\tnow"), (0.03, 'heel strike, "left"'), (0.04, "Pause é")]
    assert any("+ flexion / − extension" in line for line in table.header)
    if suffix == ".mot":  # OpenSim's key=value lines stay the four it expects
        header = path.read_text(encoding="utf-8").split("endheader")[0].splitlines()
        assert [h for h in header if "=" in h] == ["version=1", "nRows=5", "nColumns=3", "inDegrees=yes"]


def test_a_damaged_marker_line_is_named(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text('# marker 1.0 "unterminated\nt_s,knee_r_flexion_deg\n0,1\n', encoding="utf-8")
    with pytest.raises(ValueError, match="bad.csv: damaged marker line"):
        ae.read_angles_csv(path)


def test_each_joint_gets_a_trust_column_after_its_angles_and_the_header_says_when_and_why(tmp_path):
    from mimucap.core import doubt

    angles = {"hip_r_flexion_deg": np.zeros(5), "knee_r_flexion_deg": np.ones(5), "knee_r_rotation_deg": np.ones(5)}
    knee = np.array([0, doubt.FIELD_MISMATCH, doubt.FIELD_MISMATCH, 0, 0], dtype=doubt.DOUBT_DTYPE)
    joint_doubt = {"hip_r": np.zeros(5, doubt.DOUBT_DTYPE), "knee_r": knee}
    for suffix in (".csv", ".mot"):
        path = tmp_path / f"a{suffix}"
        ae.write_angles(path, T, angles, joint_doubt=joint_doubt)
        text = path.read_text()
        assert ("t_s,hip_r_flexion_deg,hip_r_ok,knee_r_flexion_deg,knee_r_rotation_deg,knee_r_ok" in text
                or "time\thip_r_flexion_deg\thip_r_ok\tknee_r_flexion_deg\tknee_r_rotation_deg\tknee_r_ok" in text)
        assert "<joint>_ok is 1 where the joint's angles are trustworthy" in text
        assert ("doubtful knee_r 0.010-0.020 s: heading taken from a magnetic field that differs from the "
                "calibrated one") in text
        assert "doubtful hip_r: 0.0 % of the samples, 0 span(s)" in text
        table = ae.read_angles_csv(path) if suffix == ".csv" else ae.read_angles_mot(path)
        assert list(table.ok["knee_r"]) == [True, False, False, True, True] and table.ok["hip_r"].all()
        assert set(table.angles_deg) == set(angles)  # the trust columns are not angles
    opensim = tmp_path / "o.mot"
    ae.write_angles_mot(opensim, T, angles, opensim_names=True, joint_doubt=joint_doubt)
    text = opensim.read_text()
    assert "knee_r_ok" not in text.split("endheader")[1] and "doubtful knee_r 0.010-0.020 s" in text
