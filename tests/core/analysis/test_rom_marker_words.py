"""The ROM protocol's markers: stored machine-readable, read back by the analysis, shown in words."""

from __future__ import annotations

import pytest

from mimucap.core.analysis.rom import marker_words, parse_rom_marker, rom_marker_label


def test_a_rom_marker_is_stored_machine_readable_and_read_back():
    label = rom_marker_label("knee_flexion", "left", "start")
    assert label == "rom:knee_flexion:left:start"
    assert parse_rom_marker(label) == ("knee_flexion", "left", "start")
    assert parse_rom_marker("rom:knee_flexion:left:middle") is None
    assert parse_rom_marker("rom:nose_flexion:left:start") is None
    assert parse_rom_marker("heel strike") is None
    with pytest.raises(ValueError, match="start or an end"):
        rom_marker_label("knee_flexion", "left", "middle")


def test_a_person_reads_a_rom_marker_in_words_and_other_labels_as_they_are():
    assert marker_words("rom:knee_flexion:left:start") == "Knee flexion (left) — start"
    assert marker_words("rom:shoulder_abduction:right:end") == "Shoulder abduction (right) — end"
    assert marker_words("rom:trunk_flexion:both:start") == "Trunk flexion — start"
    assert marker_words("heel strike") == "heel strike"
    assert marker_words("rom:knee_flexion:left") == "rom:knee_flexion:left"  # not a ROM marker: as typed
