"""UDP and serial protocols: round trips, named rejections (the same for recorded rows), and fuzzing
(never raise, never NaN)."""

from __future__ import annotations

import math
import struct
import zlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mimucap.acquisition import protocol_serial, protocol_udp
from mimucap.acquisition.rejections import Rejection
from mimucap.acquisition.wire_sample import RefusedSample, Sample, refused_rows, validate_sample

FULL = Sample(sensor_id=7, seq=123456, device_time_s=1234.567891, acc=(0.1, -0.2, 9.81),
              gyr=(0.01, 0.02, -0.03), mag_uT=(20.0, -5.5, -40.25),
              q_world_from_sensor=(0.5, 0.5, 0.5, 0.5), calibration=(3, 2, 1, 0), battery_pct=87.0)


def _close(a, b, tol=1e-5):
    return a is None and b is None or all(abs(x - y) <= tol * max(1.0, abs(y)) for x, y in zip(a, b))


def _assert_same(decoded: Sample, original: Sample) -> None:
    assert isinstance(decoded, Sample), decoded
    assert decoded.sensor_id == original.sensor_id and decoded.seq == original.seq
    assert abs(decoded.device_time_s - original.device_time_s) < 1e-6
    for name in ("acc", "gyr", "mag_uT", "q_world_from_sensor"):
        assert _close(getattr(decoded, name), getattr(original, name)), name
    assert decoded.calibration == original.calibration
    assert decoded.battery_pct == original.battery_pct


@pytest.mark.parametrize("codec", ["udp", "serial"])
def test_round_trip_full_and_partial_samples(codec):
    encode, decode = ((protocol_udp.encode_sample, protocol_udp.decode_packet) if codec == "udp"
                      else (protocol_serial.encode_line, protocol_serial.parse_line))
    _assert_same(decode(encode(FULL)), FULL)
    partial = Sample(sensor_id=1, seq=0, device_time_s=0.5, gyr=(1.0, 2.0, 3.0))
    decoded = decode(encode(partial))
    _assert_same(decoded, partial)
    assert decoded.acc is None and decoded.mag_uT is None  # absent, not zero-filled


def test_udp_sync_messages_round_trip():
    request = protocol_udp.SyncRequest(3, 99, 1_000_000)
    assert protocol_udp.decode_packet(protocol_udp.encode_sync_request(request)) == request
    response = protocol_udp.SyncResponse(3, 99, 1_000_000, 5_000_100, 5_000_150)
    assert protocol_udp.decode_packet(protocol_udp.encode_sync_response(response)) == response


def test_udp_rejections_are_named():
    good = protocol_udp.encode_sample(FULL)
    corrupted = bytearray(good)
    corrupted[25] ^= 0x40
    assert protocol_udp.decode_packet(bytes(corrupted)) is Rejection.BAD_CHECKSUM
    assert protocol_udp.decode_packet(good[:10]) is Rejection.TOO_SHORT
    assert protocol_udp.decode_packet(b"XX" + good[2:]) is Rejection.BAD_MAGIC
    assert protocol_udp.decode_packet(good + bytes(300)) is Rejection.OVERSIZED

    def reframe(body: bytes) -> bytes:
        return body + struct.pack("<I", zlib.crc32(body))

    body = good[:-4]
    assert protocol_udp.decode_packet(reframe(body[:2] + b"\x09" + body[3:])) is Rejection.UNSUPPORTED_VERSION
    assert protocol_udp.decode_packet(reframe(body[:-3])) is Rejection.LENGTH_MISMATCH
    nan_sample = reframe(body[:20] + struct.pack("<f", math.nan) + body[24:])
    # a valid frame with refused values keeps its sensor and sequence number
    assert protocol_udp.decode_packet(nan_sample) == RefusedSample(FULL.sensor_id, FULL.seq,
                                                                   Rejection.NON_FINITE)
    huge = reframe(body[:20] + struct.pack("<f", 1e6) + body[24:])
    assert protocol_udp.decode_packet(huge) == RefusedSample(FULL.sensor_id, FULL.seq,
                                                             Rejection.OUT_OF_RANGE)


def test_serial_rejections_are_named():
    line = protocol_serial.encode_line(FULL)
    assert protocol_serial.parse_line(line.replace(b"9.81", b"9.82")) is Rejection.BAD_CHECKSUM
    assert protocol_serial.parse_line(b"hello\r\n") is Rejection.MALFORMED_LINE
    assert protocol_serial.parse_line(b"$" + b"A" * 400 + b"*00") is Rejection.OVERSIZED

    def framed(body: str) -> bytes:
        raw = body.encode()
        return b"$" + raw + b"*" + f"{protocol_serial.checksum(raw):02X}".encode()

    assert protocol_serial.parse_line(framed("MIMU,1,2,3,A,nan,0,0")) == RefusedSample(1, 2, Rejection.NON_FINITE)
    assert protocol_serial.parse_line(framed("MIMU,1,2,3,A,inf,0,0")) == RefusedSample(1, 2, Rejection.NON_FINITE)
    assert protocol_serial.parse_line(framed("MIMU,1,2,3,A,nan,0,0,x")) is Rejection.BAD_FIELD
    assert protocol_serial.parse_line(framed("MIMU,1,2,3,A,x,0,0")) is Rejection.BAD_FIELD
    assert protocol_serial.parse_line(framed("MIMU,1,2,3,G,0,0,0,A,0,0,0")) is Rejection.BAD_FIELD
    assert protocol_serial.parse_line(framed("MIMU,1,-2,3")) is Rejection.BAD_FIELD
    assert protocol_serial.parse_line(framed("MIMU,1,2,3,Q,0.1,0,0,0")) == RefusedSample(1, 2, Rejection.OUT_OF_RANGE)
    assert isinstance(protocol_serial.parse_line(framed("MIMU,1,2,3,Q,1,0,0,0")), Sample)


def test_recorded_rows_are_refused_as_validate_sample_refuses_the_same_samples():
    """The replay source validates a recording's rows in columns: every row gets the reason
    (or acceptance) that :func:`validate_sample` gives the same sample from a live source."""
    rng = np.random.default_rng(11)
    n = 400
    channels = {"acc": rng.normal(0.0, 5.0, (n, 3)), "gyr": rng.normal(0.0, 1.0, (n, 3)),
                "mag_uT": rng.normal(0.0, 40.0, (n, 3)), "q_world_from_sensor": rng.normal(size=(n, 4)),
                "calibration": rng.integers(0, 4, (n, 4)).astype(np.int8), "battery_pct": rng.uniform(0, 100, n)}
    channels["q_world_from_sensor"] /= np.linalg.norm(channels["q_world_from_sensor"], axis=1, keepdims=True)
    for name, bad in (("acc", np.nan), ("acc", 400.0), ("gyr", -np.inf), ("gyr", 80.0), ("mag_uT", 6000.0),
                      ("q_world_from_sensor", np.nan), ("q_world_from_sensor", 1.5), ("battery_pct", np.nan),
                      ("battery_pct", 120.0), ("calibration", 4)):
        rows = rng.choice(n, 12, replace=False)
        values = channels[name]
        if values.ndim == 1:
            values[rows] = bad
        else:
            values[rows, rng.integers(0, values.shape[1], rows.size)] = bad
    reasons = refused_rows(channels)
    for row in range(n):
        sample = Sample(1, row, 1.0 + row, **{name: tuple(v[row].tolist()) if v.ndim > 1 else float(v[row])
                                              for name, v in channels.items()})
        expected = validate_sample(sample)
        assert reasons[row] == (expected.value if isinstance(expected, Rejection) else ""), row
    assert {"non_finite", "out_of_range", ""} == set(reasons.tolist())


# ---------------------------------------------------------------- fuzzing

def _check_total(result) -> None:
    assert isinstance(result, (Sample, RefusedSample, Rejection, protocol_udp.SyncRequest,
                               protocol_udp.SyncResponse))
    if isinstance(result, RefusedSample):
        assert result.reason in (Rejection.NON_FINITE, Rejection.OUT_OF_RANGE)
    if isinstance(result, Sample):
        for name in ("acc", "gyr", "mag_uT", "q_world_from_sensor"):
            value = getattr(result, name)
            assert value is None or all(math.isfinite(v) for v in value)
        assert math.isfinite(result.device_time_s)
        assert result.battery_pct is None or math.isfinite(result.battery_pct)


finite = st.floats(-60, 60, allow_nan=False, width=32)  # inside every channel's limits
vec3 = st.none() | st.tuples(finite, finite, finite)
samples = st.builds(
    Sample, sensor_id=st.integers(0, 0xFFFE), seq=st.integers(0, 2**32 - 1),
    device_time_s=st.floats(0, 1e6, allow_nan=False), acc=vec3, gyr=vec3, mag_uT=vec3,
    q_world_from_sensor=st.none() | st.just((1.0, 0.0, 0.0, 0.0)),
    calibration=st.none() | st.tuples(*[st.integers(0, 3)] * 4),
    battery_pct=st.none() | st.integers(0, 100).map(float))
FUZZ = settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@FUZZ
@given(st.binary(max_size=300))
def test_udp_decoder_is_total_on_random_bytes(data):
    _check_total(protocol_udp.decode_packet(data))


@FUZZ
@given(samples, st.lists(st.tuples(st.integers(0, 200), st.integers(0, 255)), max_size=4),
       st.booleans())
def test_udp_decoder_is_total_on_mutated_packets(sample, flips, fix_crc):
    packet = bytearray(protocol_udp.encode_sample(sample))
    for position, value in flips:
        packet[position % len(packet)] = value
    if fix_crc:  # mutations behind a valid CRC reach the payload checks
        packet[-4:] = struct.pack("<I", zlib.crc32(bytes(packet[:-4])))
    result = protocol_udp.decode_packet(bytes(packet))
    _check_total(result)
    if not flips:
        assert isinstance(result, Sample)


@FUZZ
@given(st.binary(max_size=300))
def test_serial_parser_is_total_on_random_bytes(data):
    _check_total(protocol_serial.parse_line(data))


@FUZZ
@given(samples, st.lists(st.tuples(st.integers(0, 300), st.sampled_from(
    list(b"0123456789,.-+eEnaifAGMQCB$*\r\n x"))), max_size=4), st.booleans())
def test_serial_parser_is_total_on_mutated_lines(sample, edits, fix_checksum):
    line = bytearray(protocol_serial.encode_line(sample).rstrip(b"\r\n"))
    for position, value in edits:
        line[position % len(line)] = value
    if fix_checksum and b"*" in line[1:]:
        body = bytes(line[1:line.rindex(b"*")])
        line = bytearray(b"$" + body + b"*" + f"{protocol_serial.checksum(body):02X}".encode())
    result = protocol_serial.parse_line(bytes(line))
    _check_total(result)
    if not edits:
        assert isinstance(result, Sample)
