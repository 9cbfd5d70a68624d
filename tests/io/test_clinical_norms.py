"""The shipped clinical norms: every table carries its source, and the reference for a subject
is the row of the subject's age and sex (or the prediction from the reference equations)."""

from __future__ import annotations

import json

import pytest

from mimucap.io.clinical_norms import read_norms, reference_for
from mimucap.io.session import make_subject


def test_every_table_names_its_source_and_what_was_left_out():
    norms = read_norms()
    assert set(norms["tests"]) == {"tug", "10mwt", "2mwt", "6mwt", "chair-stand"}
    for table in norms["tests"].values():
        assert table["source"] and table["key"] and table["statistic"]
    assert "Bohannon" in norms["tests"]["tug"]["source"] and "2006" in norms["tests"]["tug"]["source"]
    assert "Enright" in norms["tests"]["6mwt"]["source"] and "ATS statement" in norms["tests"]["6mwt"]["guidance"]


def test_the_reference_is_the_row_of_the_subjects_age_and_sex():
    norms = read_norms()
    tug, note = reference_for(norms, "tug", {"age_years": 74.5})
    assert note == "" and tug.values == {"mean": 9.2, "ci95_low": 8.2, "ci95_high": 10.2}
    assert tug.group == "adults 70-79 years" and tug.key == "total_s"
    walk, _ = reference_for(norms, "10mwt", {"age_years": 45, "sex": "female"})
    assert walk.values["mean"] == pytest.approx(1.390)
    stands, _ = reference_for(norms, "chair-stand", {"age_years": 81, "sex": "male"})
    assert (stands.values["p25"], stands.values["p75"]) == (10, 15)
    assert reference_for(norms, "tug", {"age_years": 40})[0] is None  # the meta-analysis starts at 60
    none, why = reference_for(norms, "10mwt", {"age_years": 45})
    assert none is None and "sex" in why
    none, why = reference_for(norms, "tug", {})
    assert none is None and "age" in why


def test_the_six_minute_walk_reference_is_enright_and_sherrills_prediction():
    norms = read_norms()
    subject = make_subject("S1", 1.75, age_years=60, sex="male", weight_kg=75)
    found, _ = reference_for(norms, "6mwt", subject)
    predicted = 7.57 * 175 - 5.02 * 60 - 1.76 * 75 - 309
    assert found.values["predicted"] == pytest.approx(predicted)
    assert found.values["lower_limit"] == pytest.approx(predicted - 153)
    woman, _ = reference_for(norms, "6mwt", {"age_years": 60, "sex": "female", "height_m": 1.62, "weight_kg": 60})
    assert woman.values["predicted"] == pytest.approx(2.11 * 162 - 2.29 * 60 - 5.78 * 60 + 667)
    none, why = reference_for(norms, "6mwt", {"age_years": 60, "sex": "male", "height_m": 1.75})
    assert none is None and "weight" in why


def test_a_file_without_sources_is_refused(tmp_path):
    bad = tmp_path / "norms.json"
    bad.write_text(json.dumps({"format": "mimucap-clinical-norms 1", "tests": {"tug": {"key": "total_s"}}}))
    with pytest.raises(ValueError, match="lack their source"):
        read_norms(bad)


def test_the_subject_record_takes_age_sex_and_weight():
    record = make_subject("S1", 1.7, "left", "", age_years=70, sex="female", weight_kg=62.5)
    assert (record["age_years"], record["sex"], record["weight_kg"]) == (70.0, "female", 62.5)
    assert "age_years" not in make_subject("S1")
    with pytest.raises(ValueError, match="sex"):
        make_subject("S1", sex="other")
    with pytest.raises(ValueError, match="age"):
        make_subject("S1", age_years=130)
