"""The firmware's protocol header (``firmware/include/mimucap_protocol.h``), compiled on this
machine with the system's g++, writes the same bytes as MimuCap's Python encoders for a set of
test vectors (edge values, NaN and infinities, sequence wrap, every channel subset), and
MimuCap's parsers read its packets and lines back (or refuse them with the reason the protocol
names)."""

from __future__ import annotations

import itertools
import shutil
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

from mimucap.acquisition import protocol_serial, protocol_udp
from mimucap.acquisition.rejections import Rejection
from mimucap.acquisition.samples import RefusedSample, Sample, SequenceUnwrapper, validate_sample

ROOT = Path(__file__).resolve().parents[2]
HEADER_DIR = ROOT / "firmware" / "include"
PROGRAM = Path(__file__).with_name("host_encoder.cpp")
NAN = float("nan")
INF = float("inf")


@pytest.fixture(scope="module")
def host_encoder(tmp_path_factory) -> Path:
    compiler = shutil.which("g++")
    if compiler is None:
        pytest.skip("g++ is not installed: the firmware's protocol header cannot be compiled on this machine")
    binary = tmp_path_factory.mktemp("firmware") / "host_encoder"
    done = subprocess.run([compiler, "-std=c++11", "-O1", "-Wall", "-Wextra", "-Werror", "-pedantic",
                           "-I", str(HEADER_DIR), str(PROGRAM), "-o", str(binary)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return binary


def f32(value: float) -> float:
    """``value`` rounded to the nearest float32 (what the firmware holds)."""
    return struct.unpack("<f", struct.pack("<f", value))[0]


def bits(value: float) -> str:
    return struct.pack(">f", value).hex()


def run(binary: Path, lines: list[str]) -> list[list[str]]:
    done = subprocess.run([str(binary)], input="\n".join(lines) + "\n", capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    return [line.split() for line in done.stdout.splitlines()]


def vector_line(s: Sample) -> str:
    """The host program's input for sample ``s`` (its device time in whole µs)."""
    mask = sum(1 << i for i, name in enumerate(("acc", "gyr", "mag_uT", "q_world_from_sensor", "calibration",
                                                "battery_pct")) if getattr(s, name) is not None)
    floats = [*(s.acc or (0, 0, 0)), *(s.gyr or (0, 0, 0)), *(s.mag_uT or (0, 0, 0)),
              *(s.q_world_from_sensor or (1, 0, 0, 0)), s.battery_pct if s.battery_pct is not None else 0.0]
    time_us = int(round(s.device_time_s * 1e6))
    return " ".join(["U", str(s.sensor_id), str(s.seq % 2**32), str(time_us), str(mask),
                     *(bits(v) for v in floats), *(str(c) for c in (s.calibration or (0, 0, 0, 0)))])


def samples() -> list[Sample]:
    """Test vectors: values the firmware can hold (float32), times in whole µs."""
    full = dict(acc=(f32(0.12), f32(-0.03), f32(9.81)), gyr=(f32(0.01), 0.0, f32(-0.02)),
                mag_uT=(f32(21.5), f32(-3.2), f32(-40.1)),
                q_world_from_sensor=(f32(0.7071068), 0.0, 0.0, f32(0.7071068)),
                calibration=(3, 2, 1, 0), battery_pct=f32(87.0))
    out = [Sample(3, 1024, 12.345678, **full)]
    names = list(full)
    for count in range(len(names) + 1):                 # every subset of channels (64 of them)
        for subset in itertools.combinations(names, count):
            out.append(Sample(7, 17 + count, 1.5 + 0.25 * count, **{k: full[k] for k in subset}))
    edges = [
        Sample(0, 0, 0.0, acc=(0.0, -0.0, f32(1e-40)), gyr=(f32(3.4e38), f32(-3.4e38), f32(1e-7)),
               battery_pct=0.0),
        Sample(65534, 2**32 - 1, 4000.0, acc=(f32(319.99), f32(-319.99), f32(123456.7)), battery_pct=100.0),
        Sample(65534, 2**32, 4000.01, acc=(1.0, 2.0, 3.0)),      # the counter wraps to 0
        Sample(1, 2**32 + 1, 4000.02, q_world_from_sensor=(1.0, 0.0, 0.0, 0.0)),
        Sample(2, 5, 1.0, gyr=(NAN, 0.0, 1.0)),                  # NaN: sent, refused by the host
        Sample(2, 6, 1.01, mag_uT=(INF, -INF, 1.0)),
        Sample(2, 7, 1.02, battery_pct=f32(2.5)),                # halves round to even
        Sample(2, 8, 1.03, battery_pct=f32(3.5)),
        Sample(2, 9, 1.04, battery_pct=f32(99.49)),
        Sample(2, 10, 1.05, calibration=(3, 3, 3, 3), q_world_from_sensor=(f32(0.5), f32(0.5), f32(-0.5), f32(0.5))),
        Sample(9, 11, 123456.789012, mag_uT=(f32(1e-5), f32(-0.000123), f32(4999.9))),
    ]
    return out + edges


def test_packets_and_lines_equal_the_python_encoders_and_parse_back(host_encoder):
    vectors = samples()
    for s in vectors:      # the device time survives the µs rounding of both encoders
        assert int(round(s.device_time_s * 1e6)) * 1e-6 == pytest.approx(s.device_time_s, abs=1e-9)
    results = run(host_encoder, [vector_line(s) for s in vectors])
    assert len(results) == len(vectors)
    unwrapper = SequenceUnwrapper()
    for s, (kind, packet_hex, line_hex) in zip(vectors, results):
        assert kind == "U"
        packet = bytes.fromhex(packet_hex)
        assert packet == protocol_udp.encode_sample(s), s
        line = bytes.fromhex(line_hex)
        assert line == protocol_serial.encode_line(s), (s, line)
        decoded_packet = protocol_udp.decode_packet(packet)
        decoded_line = protocol_serial.parse_line(line)
        verdict = validate_sample(s)    # what a host must make of it: the sample, or why it is refused
        if not isinstance(verdict, Rejection):
            for decoded in (decoded_packet, decoded_line):
                assert isinstance(decoded, Sample), (s, decoded)
                assert (decoded.sensor_id, decoded.seq) == (s.sensor_id, s.seq % 2**32)
                assert decoded.device_time_s == pytest.approx(s.device_time_s, abs=1e-6)
                assert decoded.channels() == s.channels()
            for name in ("acc", "gyr", "mag_uT", "q_world_from_sensor"):
                if getattr(s, name) is not None:
                    expected = np.asarray(getattr(s, name))
                    if name == "q_world_from_sensor":
                        expected = expected / np.linalg.norm(expected)
                    np.testing.assert_allclose(getattr(decoded_packet, name), expected, rtol=1e-6, atol=1e-12)
                    np.testing.assert_allclose(getattr(decoded_line, name), expected, rtol=1e-6, atol=1e-12)
            if s.battery_pct is not None:
                assert decoded_packet.battery_pct == round(s.battery_pct)
                assert decoded_line.battery_pct == pytest.approx(s.battery_pct, rel=1e-6)
            if s.calibration is not None:
                assert decoded_packet.calibration == decoded_line.calibration == s.calibration
        else:      # NaN, infinity or beyond the limits: refused with its reason, the number kept
            for decoded in (decoded_packet, decoded_line):
                assert isinstance(decoded, RefusedSample) and decoded.reason == verdict, (s, decoded)
                assert decoded.seq == s.seq % 2**32
    reasons = [validate_sample(s) for s in vectors]
    assert reasons.count(Rejection.NON_FINITE) == 2 and reasons.count(Rejection.OUT_OF_RANGE) == 2
    # the wrap: 2³²−1 then 0 and 1 on the wire are consecutive after unwrapping
    wrapped = [protocol_udp.decode_packet(bytes.fromhex(r[1])) for r in results[-10:-7]]
    assert [unwrapper.unwrap(w.seq) for w in wrapped] == [2**32 - 1, 2**32, 2**32 + 1]


def test_a_battery_that_is_not_a_number_is_sent_out_of_range(host_encoder):
    s = Sample(4, 1, 2.0, battery_pct=NAN)
    ((_, packet_hex, line_hex),) = run(host_encoder, [vector_line(s)])
    decoded = protocol_udp.decode_packet(bytes.fromhex(packet_hex))
    assert isinstance(decoded, RefusedSample) and decoded.reason == Rejection.OUT_OF_RANGE
    assert bytes.fromhex(line_hex) == protocol_serial.encode_line(s)     # ",B,nan": refused as non_finite
    assert protocol_serial.parse_line(bytes.fromhex(line_hex)).reason == Rejection.NON_FINITE


def test_the_longest_line_fits_the_protocol(host_encoder):
    """Every channel, every number at its longest text (sign, seven digits, exponent)."""
    big = f32(-1.234567e-30)
    s = Sample(65534, 2**32 - 1, 999999.999999, acc=(big,) * 3, gyr=(big,) * 3, mag_uT=(big,) * 3,
               q_world_from_sensor=(big,) * 4, calibration=(3, 3, 3, 3), battery_pct=big)
    line = protocol_serial.encode_line(s)
    ((_, _packet, line_hex),) = run(host_encoder, [vector_line(s)])
    assert len(line.rstrip(b"\r\n")) <= protocol_serial.MAX_LINE_BYTES
    assert bytes.fromhex(line_hex) == line
    assert isinstance(protocol_serial.parse_line(line), RefusedSample)   # the battery is negative


def test_time_sync_answers_and_requests(host_encoder):
    responses = [(3, 7, 1, 2, 3), (65534, 2**32 - 1, 2**64 - 1, 123456789012, 123456789999)]
    requests = [protocol_udp.SyncRequest(3, 99, 5_000_000), protocol_udp.SyncRequest(0xFFFF, 2**32 - 1, 2**63)]
    damaged = bytearray(protocol_udp.encode_sync_request(requests[0]))
    damaged[10] ^= 1
    sample_packet = protocol_udp.encode_sample(Sample(3, 1, 1.0, acc=(0.0, 0.0, 9.81)))
    lines = [f"S {' '.join(map(str, r))}" for r in responses]
    lines += [f"R {protocol_udp.encode_sync_request(r).hex()}" for r in requests]
    lines += [f"R {bytes(damaged).hex()}", f"R {sample_packet.hex()}"]
    results = run(host_encoder, lines)
    for (sensor, request, t1, t2, t3), (_, packet_hex) in zip(responses, results[:2]):
        expected = protocol_udp.SyncResponse(sensor, request, t1, t2, t3)
        assert bytes.fromhex(packet_hex) == protocol_udp.encode_sync_response(expected)
        assert protocol_udp.decode_packet(bytes.fromhex(packet_hex)) == expected
    for request, result in zip(requests, results[2:4]):
        assert result == ["R", "ok", str(request.target_id), str(request.request_id), str(request.host_send_us)]
    assert results[4:] == [["R", "bad"], ["R", "bad"]]


def test_hellos_and_hello_requests(host_encoder):
    """The node's hello (packet and serial line) equals the Python encoders' and parses back to
    its MAC; the node reads the host's hello requests, and nothing else, as such."""
    from mimucap.acquisition.hello import Hello, HelloRequest

    hellos = [(Hello(3, bytes.fromhex("A1B2C3D4E5F6")), 12345678), (Hello(65534, bytes.fromhex("020000000001")), 2**64 - 1)]
    requests = [HelloRequest(3), HelloRequest(0xFFFF)]
    sync = protocol_udp.encode_sync_request(protocol_udp.SyncRequest(3, 1, 2))
    lines = [f"H {hello.sensor_id} {time_us} {hello.mac.hex()}" for hello, time_us in hellos]
    lines += [f"Q {protocol_udp.encode_hello_request(r).hex()}" for r in requests] + [f"Q {sync.hex()}"]
    results = run(host_encoder, lines)
    for (hello, time_us), (kind, packet_hex, line_hex) in zip(hellos, results[:2]):
        assert kind == "H"
        assert bytes.fromhex(packet_hex) == protocol_udp.encode_hello(hello, time_us)
        assert protocol_udp.decode_packet(bytes.fromhex(packet_hex)) == hello
        assert bytes.fromhex(line_hex) == protocol_serial.encode_hello_line(hello)
        assert protocol_serial.parse_line(bytes.fromhex(line_hex)) == hello
    assert results[2:] == [["Q", "ok", "3"], ["Q", "ok", "65535"], ["Q", "bad"]]
    # an older node's request decoder takes a hello request for no time-sync request
    assert run(host_encoder, [f"R {protocol_udp.encode_hello_request(requests[0]).hex()}"]) == [["R", "bad"]]
