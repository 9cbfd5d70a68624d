"""Journal record codec and spec parser: exact round trips, and total on hostile input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mimucap.acquisition.source_spec import parse_source_spec
from mimucap.core.sensor_samples import SensorSamples, concatenate_samples
from mimucap.io.journal.records import decode_block, encode_block


def make_block(n: int, full: bool = True, first: int = 0) -> SensorSamples:
    seq = np.arange(first, first + n, dtype=np.int64)
    t = 100.0 + seq * 0.01
    extra = {}
    if full:
        extra = dict(acc=np.random.default_rng(n).normal(size=(n, 3)), mag_uT=np.ones((n, 3)),
                     q_world_from_sensor=np.tile([1.0, 0, 0, 0], (n, 1)),
                     calibration=np.full((n, 4), 3, dtype=np.int8), battery_pct=np.full(n, 55.0))
    return SensorSamples("S01", t, seq, device_time_s=t + 3.0, receive_time_s=t + 0.001, source="src",
                         gyr=np.zeros((n, 3)), **extra)


@pytest.mark.parametrize("n, full", [(0, True), (1, False), (17, True)])
def test_blocks_round_trip_exactly(n, full):
    block = make_block(n, full)
    decoded = decode_block(encode_block(block))
    assert decoded.sensor_id == "S01" and decoded.source == "src" and decoded.channels() == block.channels()
    for name in ("seq", "device_time_s", "t_s", "receive_time_s") + block.channels():
        np.testing.assert_array_equal(getattr(decoded, name), getattr(block, name))
        assert getattr(decoded, name).dtype == getattr(block, name).dtype


def test_concatenation_keeps_order_and_refuses_mixed_channels():
    joined = concatenate_samples([make_block(3), make_block(4, first=3)])
    np.testing.assert_array_equal(joined.seq, np.arange(7))
    with pytest.raises(ValueError):
        concatenate_samples([make_block(3), make_block(3, full=False, first=3)])


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 20), st.lists(st.tuples(st.integers(0, 5000), st.integers(0, 255)), max_size=6),
       st.integers(0, 5000))
def test_decoding_damaged_records_gives_a_block_or_value_error(n, flips, cut):
    data = bytearray(encode_block(make_block(n)))
    for position, value in flips:
        data[position % len(data)] = value
    data = bytes(data[: max(cut, 0) % (len(data) + 1)])
    try:
        block = decode_block(data)
    except ValueError:
        return
    assert len(block.seq) == len(block.t_s)


@settings(max_examples=500, deadline=None)
@given(st.text(max_size=60) | st.from_regex(r"(udp|serial|replay|simulated):[ -~]{0,30}", fullmatch=True))
def test_spec_parser_gives_a_spec_or_a_one_line_value_error(text):
    try:
        parse_source_spec(text)
    except ValueError as error:
        assert "\n" not in str(error) and "valid forms" in str(error)


@settings(max_examples=300, deadline=None)
@given(st.recursive(st.none() | st.booleans() | st.integers(-5, 5) | st.text(max_size=8),
                    lambda children: st.lists(children, max_size=4)
                    | st.dictionaries(st.text(max_size=8), children, max_size=4), max_leaves=12),
       st.binary(max_size=64))
def test_hostile_json_headers_give_value_error(header, tail):
    import json
    import struct
    text = json.dumps({"source": "x", "sensor_id": "S", "n": 2, "arrays": header}).encode()
    try:
        decode_block(struct.pack("<I", len(text)) + text + tail)
    except ValueError:
        pass
