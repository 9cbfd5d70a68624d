"""Skeleton models by name or from a JSON file of one's own; bad files are named in the error."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mimucap.core import skeleton
from mimucap.io.skeleton_model_file import load_model, save_model_document


def test_names_give_the_built_in_models():
    for name in skeleton.MODEL_NAMES:
        assert load_model(name) is skeleton.load_model(name)
    assert load_model("fifteen_segment").segment_names[-2:] == ("foot_l", "foot_r")


def test_a_written_model_reads_back_and_an_edited_one_changes_the_figure(tmp_path):
    path = save_model_document("ten_segment", tmp_path / "mine.json")
    mine = load_model(path)
    ten = skeleton.load_model("ten_segment")
    assert mine.segment_names == ten.segment_names and mine.segments == ten.segments
    data = json.loads(path.read_text(encoding="utf-8"))
    data["name"] = "long_shanks"
    for segment in data["segments"]:
        if segment["name"].startswith("shank"):
            segment["length_ratio"] *= 1.1
    edited = tmp_path / "long_shanks.json"
    edited.write_text(json.dumps(data), encoding="utf-8")
    model = load_model(str(edited))
    assert model.name == "long_shanks"
    assert np.isclose(skeleton.segment_lengths(model, 1.8)["shank_r"], 1.1 * skeleton.segment_lengths(ten, 1.8)["shank_r"])


def test_bad_files_are_refused_with_their_name(tmp_path):
    with pytest.raises(ValueError, match="unknown skeleton model 'octopus'"):
        load_model("octopus")
    with pytest.raises(ValueError, match="cannot read skeleton model .*missing.json"):
        load_model(tmp_path / "missing.json")
    broken = tmp_path / "broken.json"
    broken.write_text('{\n  "format": "mimucap-skeleton",\n  oops\n}', encoding="utf-8")
    with pytest.raises(ValueError, match="broken.json: invalid JSON at line 3"):
        load_model(broken)
    foreign = tmp_path / "foreign.json"
    foreign.write_text(json.dumps({"segments": []}), encoding="utf-8")
    with pytest.raises(ValueError, match="foreign.json: not a MimuCap skeleton model"):
        load_model(foreign)
    with pytest.raises(ValueError, match="unknown skeleton model"):
        save_model_document("octopus", tmp_path / "x.json")
