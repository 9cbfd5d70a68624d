"""Source spec strings: every valid form parses and round-trips; malformed ones say why."""

from __future__ import annotations

import pytest

from mimucap.acquisition.source_spec import (
    ReplaySpec, SerialSpec, SimulatedSpec, UdpSpec, format_source_spec, parse_source_spec,
)


@pytest.mark.parametrize("text, expected", [
    ("simulated", SimulatedSpec("demo")),
    ("simulated:walk", SimulatedSpec("walk")),
    ("simulated:demo@clinic", SimulatedSpec("demo", "clinic")),
    ("simulated@treadmill", SimulatedSpec("demo", "treadmill")),
    ("simulated:walk@clean", SimulatedSpec("walk", "clean")),
    ("udp:0.0.0.0:5555", UdpSpec("0.0.0.0", 5555)),
    ("udp:127.0.0.1:9", UdpSpec("127.0.0.1", 9)),
    ("udp:[::1]:5555", UdpSpec("::1", 5555)),
    ("serial:/dev/ttyUSB0", SerialSpec("/dev/ttyUSB0", 115200)),
    ("serial:/dev/ttyACM1@921600", SerialSpec("/dev/ttyACM1", 921600)),
    ("replay:/data/s1.h5", ReplaySpec("/data/s1.h5", 1.0)),
    ("replay:take@2.h5@4", ReplaySpec("take@2.h5", 4.0)),
])
def test_valid_specs_parse_and_round_trip(text, expected):
    spec = parse_source_spec(text)
    assert spec == expected
    assert parse_source_spec(format_source_spec(spec)) == spec


@pytest.mark.parametrize("text", [
    "", "tcp:1.2.3.4:5", "udp:5555", "udp:1.2.3.4:99999", "udp:nohost:5", "udp:1.2.3.4:x",
    "serial:", "serial:/dev/ttyUSB0@fast", "replay:", "replay:f.h5@0", "replay:f.h5@-1",
    "simulated:bad name", "simulated:demo@", "simulated@", "simulated@bad room", "simulatedx",
])
def test_malformed_specs_give_one_line_listing_the_valid_forms(text):
    with pytest.raises(ValueError) as info:
        parse_source_spec(text)
    message = str(info.value)
    assert "\n" not in message
    for form in ("simulated[:SCENARIO]", "udp:BIND_ADDRESS:PORT", "serial:DEVICE[@BAUD]", "replay:FILE[@SPEED]"):
        assert form in message


def test_a_clean_room_is_left_out_of_the_spec_string():
    """Specs written before rooms existed read the same, and a clean room writes them as before."""
    assert parse_source_spec("simulated:demo") == SimulatedSpec("demo", "clean")
    assert format_source_spec(SimulatedSpec("demo", "clean")) == "simulated:demo"
    assert format_source_spec(SimulatedSpec("tug", "clinic")) == "simulated:tug@clinic"
