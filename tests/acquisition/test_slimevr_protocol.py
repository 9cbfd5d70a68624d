"""The SlimeVR protocol and driver without a network: packets built byte by byte as the
trackers send them (layouts from SlimeVR-Tracker-ESP ``connection.cpp``), the frame conversion
with a known rotation, version refusal, drops from packet numbers, bundles, the source spec."""

from __future__ import annotations

import math
import queue
import struct

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from mimucap.acquisition import slimevr_protocol as proto
from mimucap.acquisition.messages import BlocksMessage, WorkerReport
from mimucap.acquisition.outbox import Outbox
from mimucap.acquisition.rejections import Rejection
from mimucap.acquisition.slimevr import SlimeVrDriver, SlimeVrSourceConfig
from mimucap.acquisition.source_spec import SlimeVrSpec, format_source_spec, parse_source_spec
from mimucap.core import rotation
from mimucap.session.sources import source_configs

MAC = bytes([0x02, 0x4D, 0x43, 0x00, 0x00, 0x07])
TRACKER = ("192.0.2.7", 4242)


def handshake(build: int = 13, firmware: bytes = b"0.4.1", mac: bytes = MAC) -> bytes:
    payload = struct.pack(">7i", 5, 4, 2, 0, 0, 0, build) + bytes([len(firmware)]) + firmware + mac
    return proto.encode_tracker_packet(proto.PACKET_HANDSHAKE, 0, payload)


def rotation_packet(number: int, sensor: int, q_xyzw, kind: int = 1) -> bytes:
    return proto.encode_tracker_packet(proto.PACKET_ROTATION_DATA, number,
                                       struct.pack(">BB4fB", sensor, kind, *q_xyzw, 3))


class FakeSocket:
    def __init__(self) -> None:
        self.sent: list[tuple[bytes, tuple]] = []

    def sendto(self, data: bytes, address: tuple) -> None:
        self.sent.append((bytes(data), address))

    def close(self) -> None:
        pass


@pytest.fixture
def driver():
    messages: queue.Queue = queue.Queue()
    d = SlimeVrDriver(SlimeVrSourceConfig(), Outbox(messages, "slimevr"))
    d.sock = FakeSocket()
    d.messages = messages
    return d


def blocks_of(d: SlimeVrDriver) -> dict:
    d.flush()
    out: dict[str, list] = {}
    while not d.messages.empty():
        message = d.messages.get()
        if isinstance(message, BlocksMessage):
            for block in message.unpacked():
                out.setdefault(block.sensor_id, []).append(block)
    return out


def test_the_wire_frame_is_z_up_a_turn_about_the_trackers_vertical_turns_about_world_up():
    """A tracker lying flat, turned +90° about its vertical (wire z) axis: x, y, z, w =
    (0, 0, sin 45°, cos 45°). In world ENU its x axis must point north (+y), its z axis stay up;
    SlimeVR's own y-up conversion (−90° about x) would put that turn about world y instead."""
    q = proto.q_world_from_slimevr([0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)])
    np.testing.assert_allclose(rotation.rotate(q, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(rotation.rotate(q, [0.0, 0.0, 1.0]), [0.0, 0.0, 1.0], atol=1e-12)
    # a tilt: 30° about the tracker's x axis lifts its y axis towards up
    h = math.radians(15.0)
    q = proto.q_world_from_slimevr([math.sin(h), 0.0, 0.0, math.cos(h)])
    np.testing.assert_allclose(rotation.rotate(q, [0.0, 1.0, 0.0]),
                               [0.0, math.cos(math.radians(30)), math.sin(math.radians(30))], atol=1e-12)


def test_handshake_is_answered_and_sensor_info_acknowledged(driver):
    driver.handle_datagram(handshake(), TRACKER, 10.0)
    reply, address = driver.sock.sent[-1]
    assert address == TRACKER and reply[0] == 3 and reply[1:13] == b"Hey OVR =D 5"
    info = proto.encode_tracker_packet(proto.PACKET_SENSOR_INFO, 1, bytes([1, 1, 4]))
    driver.handle_datagram(info, TRACKER, 10.01)
    assert driver.sock.sent[-1] == (struct.pack(">IBB", 15, 1, 1), TRACKER)
    flags = proto.encode_tracker_packet(proto.PACKET_FEATURE_FLAGS, 2, bytes([0b10]))
    driver.handle_datagram(flags, TRACKER, 10.02)
    assert driver.sock.sent[-1][0] == struct.pack(">IQ", 22, 0) + proto.SERVER_FEATURES


@pytest.mark.parametrize("build, firmware", [(5, b"0.2.0"), (proto.MAX_PROTOCOL_BUILD + 1, b"0.9.0"), (13, b"")])
def test_other_protocol_versions_are_refused_with_a_message(driver, build, firmware):
    driver.handle_datagram(handshake(build, firmware), TRACKER, 10.0)
    assert driver.sock.sent == []          # no answer: the tracker keeps looking for a server
    report = driver.report("running")
    assert report.rejections == {"unsupported_version": 1}
    assert "02:4D:43:00:00:07" in report.warning
    assert f"{proto.MIN_PROTOCOL_BUILD}-{proto.MAX_PROTOCOL_BUILD}" in report.warning
    driver.handle_datagram(rotation_packet(1, 0, (0, 0, 0, 1)), TRACKER, 10.1)
    assert blocks_of(driver) == {}
    assert driver.report("running").rejections["unknown_address"] == 1


def test_rotations_battery_and_signal_of_every_sensor(driver):
    driver.handle_datagram(handshake(), TRACKER, 10.0)
    battery = proto.encode_tracker_packet(proto.PACKET_BATTERY, 0, struct.pack(">2f", 3.9, 0.75))
    driver.handle_datagram(battery, TRACKER, 10.0)
    signal = proto.encode_tracker_packet(proto.PACKET_SIGNAL_STRENGTH, 1, struct.pack(">Bb", 255, -61))
    driver.handle_datagram(signal, TRACKER, 10.0)
    q0, q1 = (0.0, 0.0, 0.6, 0.8), (0.48, 0.0, 0.0, 0.8775825618903728)
    for k in range(5):
        driver.handle_datagram(rotation_packet(2 + 2 * k, 0, q0), TRACKER, 10.1 + 0.01 * k)
        driver.handle_datagram(rotation_packet(3 + 2 * k, 1, q1), TRACKER, 10.1 + 0.01 * k)
    blocks = blocks_of(driver)
    assert sorted(blocks) == ["024D43000007-0", "024D43000007-1"]
    b0, b1 = blocks["024D43000007-0"][0], blocks["024D43000007-1"][0]
    assert b0.acc is None and b0.gyr is None and b0.mag_uT is None
    np.testing.assert_allclose(b0.q_world_from_sensor, np.tile([0.8, 0.0, 0.0, 0.6], (5, 1)), atol=1e-7)
    q1_wxyz = np.array([q1[3], *q1[:3]]) / np.linalg.norm(q1)
    np.testing.assert_allclose(b1.q_world_from_sensor, np.tile(q1_wxyz, (5, 1)), atol=1e-7)
    np.testing.assert_allclose(b0.battery_pct, 75.0, atol=1e-4)
    assert list(b0.seq) == [0, 1, 2, 3, 4]
    assert driver.report("running").signal_dbm == {"024D43000007-0": -61.0, "024D43000007-1": -61.0}


def test_lost_packets_are_drops_of_the_trackers_sensors_and_old_numbers_are_refused(driver):
    driver.handle_datagram(handshake(), TRACKER, 10.0)
    for number in (0, 1, 5, 6):           # 2, 3, 4 lost on the way
        driver.handle_datagram(rotation_packet(number, 0, (0, 0, 0, 1)), TRACKER, 10.0 + number * 0.01)
    driver.handle_datagram(rotation_packet(5, 0, (0, 0, 0, 1)), TRACKER, 10.1)   # a duplicate
    # the firmware echoes the server's ping as it came, numbered 0: taken, no drops, no refusal
    driver._send_heartbeats(10.11)
    pong = driver.sock.sent[-1][0]
    assert pong[:12] == struct.pack(">IQ", 10, 0)
    driver.handle_datagram(pong, TRACKER, 10.12)
    driver.handle_datagram(rotation_packet(7, 0, (0, 0, 0, 1)), TRACKER, 10.13)
    (block,) = blocks_of(driver)["024D43000007-0"]
    # the round trip 10.11 → 10.12 s: half of it is the network delay taken off the arrival
    assert block.t_s[-1] == pytest.approx(10.13 - 0.005)
    assert list(block.seq) == [0, 1, 5, 6, 7]  # three numbers missing: three drops
    assert driver.report("running").rejections == {"stale_sequence": 1}
    # the tracker reboots: a new handshake starts its numbers at 0 again, without false drops
    driver.handle_datagram(handshake(), TRACKER, 11.0)
    driver.handle_datagram(rotation_packet(0, 0, (0, 0, 0, 1)), TRACKER, 11.01)
    (block,) = blocks_of(driver)["024D43000007-0"]
    assert list(block.seq) == [8]


def test_bundles_carry_several_packets_and_refused_values_are_counted(driver):
    driver.handle_datagram(handshake(), TRACKER, 10.0)
    inner = [struct.pack(">I", 17) + struct.pack(">BB4fB", s, 1, 0, 0, 0, 1, 0) for s in range(3)]
    inner.append(struct.pack(">I", 17) + struct.pack(">BB4fB", 3, 1, float("nan"), 0, 0, 1, 0))
    inner.append(struct.pack(">I", 17) + struct.pack(">BB4fB", 4, 1, 0, 0, 0, 3.0, 0))   # norm 3
    payload = b"".join(struct.pack(">H", len(p)) + p for p in inner)
    driver.handle_datagram(proto.encode_tracker_packet(proto.PACKET_BUNDLE, 0, payload), TRACKER, 10.01)
    assert sorted(blocks_of(driver)) == [f"024D43000007-{s}" for s in range(3)]
    assert driver.report("running").rejections == {"non_finite": 1, "out_of_range": 1}


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=200))
def test_the_decoder_is_total(data):
    result = proto.decode_datagram(data)
    assert isinstance(result, (proto.Datagram, Rejection))
    if isinstance(result, proto.Datagram):
        for message in result.messages:
            if isinstance(message, proto.Rotation):
                assert all(math.isfinite(v) for v in message.q_xyzw)


@pytest.mark.parametrize("text, expected", [
    ("slimevr", SlimeVrSpec("0.0.0.0", 6969)),
    ("slimevr:6969", SlimeVrSpec("0.0.0.0", 6969)),
    ("slimevr:7000", SlimeVrSpec("0.0.0.0", 7000)),
    ("slimevr:127.0.0.1:6969", SlimeVrSpec("127.0.0.1", 6969)),
    ("slimevr:[::1]:6969", SlimeVrSpec("::1", 6969)),
])
def test_slimevr_specs_parse_and_round_trip(text, expected):
    spec = parse_source_spec(text)
    assert spec == expected
    assert parse_source_spec(format_source_spec(spec)) == spec
    (config,) = source_configs(text)
    assert isinstance(config, SlimeVrSourceConfig) and (config.bind_address, config.port) == (spec.bind_address, spec.port)


@pytest.mark.parametrize("text", ["slimevr:", "slimevr:0", "slimevr:99999", "slimevr::6969", "slimevr:host.x:6969"])
def test_malformed_slimevr_specs_say_why(text):
    with pytest.raises(ValueError, match=r"slimevr\[:\[BIND_ADDRESS:\]PORT\]"):
        parse_source_spec(text)


def test_a_refused_tracker_is_named_as_the_sources_problem():
    """Through the worker process and the live session: the user reads why a tracker is not there."""
    import socket
    import time

    from mimucap.session.live import open_live_session

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    live = open_live_session(f"slimevr:127.0.0.1:{port}")
    live.start()
    tracker = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline and "build 99" not in live.source_problem:
            tracker.sendto(handshake(build=99, firmware=b"9.9.9"), ("127.0.0.1", port))
            live.step()
            time.sleep(0.05)
        problem = live.source_problem
        assert "02:4D:43:00:00:07" in problem and "build 99" in problem and "9-17" in problem
        assert live.sensor_ids == ()
    finally:
        tracker.close()
        live.stop()


def test_each_sensor_of_a_tracker_is_a_device_named_by_the_trackers_mac(driver):
    """Sensor n of the tracker whose handshake says MAC 02:4D:43:00:00:07 is the device
    ``mac:024D43000007/n``; a tracker whose handshake carries no MAC (named by its address)
    has none, and the report says why."""
    from mimucap.core.device_identity import SensorDevice

    driver.handle_datagram(handshake(), TRACKER, 10.0)
    for k, sensor in enumerate((0, 1)):
        driver.handle_datagram(rotation_packet(1 + k, sensor, (0, 0, 0, 1)), TRACKER, 10.1)
    other = ("192.0.2.8", 4242)
    driver.handle_datagram(handshake(mac=bytes(6)), other, 10.2)
    driver.handle_datagram(rotation_packet(1, 0, (0, 0, 0, 1)), other, 10.3)
    devices = driver.report("running").devices
    assert devices["024D43000007-0"] == SensorDevice("mac:024D43000007/0")
    assert devices["024D43000007-1"] == SensorDevice("mac:024D43000007/1")
    assert devices["192.0.2.8:4242-0"].device_id is None and "no MAC" in devices["192.0.2.8:4242-0"].missing
