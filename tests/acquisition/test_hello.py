"""A node's hello says which device its sensor is: the UDP hello and hello request, the serial
hello line, their refusals, and the device each source reports (a node's MAC over loopback UDP
and a pseudo-terminal; none, with the reason, for nodes older than the hello, which keep
working)."""

from __future__ import annotations

import threading
import time

import pytest

from mimucap.acquisition import protocol_serial, protocol_udp
from mimucap.acquisition.emulate_common import EmulatorSettings, node_mac
from mimucap.acquisition.emulate_serial import SerialEmulator
from mimucap.acquisition.hello import HELLO_WAIT_S, NO_HELLO, Hello, HelloRequest
from mimucap.acquisition.intake import IntakeSettings, SampleIntake
from mimucap.acquisition.rejections import Rejection
from mimucap.acquisition.samples import Sample
from mimucap.acquisition.serial_port import SerialSourceConfig
from mimucap.acquisition.supervisor import Supervisor
from mimucap.acquisition.udp import UdpSourceConfig
from mimucap.core.device_identity import SensorDevice, mac_device_id

from tests.acquisition.test_udp_loopback import free_udp_port, run_emulator, wait_for

MAC = bytes.fromhex("A1B2C3D4E5F6")


def test_the_udp_hello_and_its_request_round_trip_and_bad_ones_are_refused_with_a_reason():
    hello = Hello(7, MAC)
    packet = protocol_udp.encode_hello(hello, 123456)
    assert len(packet) == 30 and protocol_udp.decode_packet(packet) == hello
    assert hello.device_id == "mac:A1B2C3D4E5F6"
    for target in (7, protocol_udp.BROADCAST_ID):
        assert protocol_udp.decode_packet(protocol_udp.encode_hello_request(HelloRequest(target))) == HelloRequest(target)
    no_mac = protocol_udp._frame(protocol_udp.TYPE_HELLO, 7, 0, 0, 0, bytes(6))
    short = protocol_udp._frame(protocol_udp.TYPE_HELLO, 7, 0, 0, 0, MAC[:5])
    flagged = protocol_udp._frame(protocol_udp.TYPE_HELLO, 7, 1, 0, 0, MAC)
    everyone = protocol_udp._frame(protocol_udp.TYPE_HELLO, protocol_udp.BROADCAST_ID, 0, 0, 0, MAC)
    damaged = bytearray(packet)
    damaged[25] ^= 0xFF
    assert [protocol_udp.decode_packet(p) for p in (no_mac, short, flagged, everyone, bytes(damaged))] == [
        Rejection.OUT_OF_RANGE, Rejection.LENGTH_MISMATCH, Rejection.UNKNOWN_FLAGS, Rejection.UNKNOWN_SENSOR,
        Rejection.BAD_CHECKSUM]


def test_the_serial_hello_line_round_trips_and_bad_ones_are_refused_with_a_reason():
    hello = Hello(3, MAC)
    line = protocol_serial.encode_hello_line(hello)
    assert line.startswith(b"$MIMUH,3,A1B2C3D4E5F6*") and line.endswith(b"\r\n")
    assert protocol_serial.parse_line(line) == hello

    def framed(body: str) -> bytes:
        return b"$" + body.encode() + b"*" + f"{protocol_serial.checksum(body.encode()):02X}".encode() + b"\r\n"

    assert [protocol_serial.parse_line(framed(body)) for body in (
        "MIMUH,3,000000000000", "MIMUH,3,A1B2C3", "MIMUH,x,A1B2C3D4E5F6", "MIMUH,3", "MIMUH,3,A1B2C3D4E5FG")] == [
        Rejection.OUT_OF_RANGE, Rejection.BAD_FIELD, Rejection.BAD_FIELD, Rejection.MALFORMED_LINE, Rejection.BAD_FIELD]


def test_the_intake_reports_the_hellos_device_and_after_a_wait_why_a_sensor_has_none():
    intake = SampleIntake("udp", IntakeSettings(sensor_ids=(1, 2)), lambda message: None)
    sample = lambda sensor, t: Sample(sensor, int(t * 100), t, acc=(0.0, 0.0, 9.81))  # noqa: E731
    intake.accept(sample(1, 0.0), 10.0)
    intake.accept(sample(2, 0.0), 10.0)
    assert intake.identify(Hello(1, MAC), 10.1) is True and intake.identify(Hello(1, MAC), 10.2) is False
    assert intake.report("running").devices == {"1": SensorDevice("mac:A1B2C3D4E5F6")}   # 2 may still say hello
    intake.accept(sample(2, HELLO_WAIT_S), 10.0 + HELLO_WAIT_S)
    assert intake.report("running").devices == {"1": SensorDevice("mac:A1B2C3D4E5F6"), "2": SensorDevice(None, NO_HELLO)}
    assert intake.identify(Hello(1, bytes.fromhex("020000000001")), 13.0) is True   # another node under id 1
    assert intake.identify(Hello(9, MAC), 13.0) is False and intake.unknown == {"id 9": 1}


@pytest.mark.parametrize("hello", [True, False])
def test_udp_nodes_say_which_device_they_are_and_older_ones_keep_working(synthetic_motion, hello):
    n, rate = 3, 100.0
    settings = EmulatorSettings(n_sensors=n, rate_hz=rate, duration_s=HELLO_WAIT_S + 2.0, seed=11, hello=hello)
    port = free_udp_port()
    config = UdpSourceConfig(name="udp", port=port, intake=IntakeSettings(sensor_ids=tuple(settings.sensor_ids())))
    expected = ({str(i): SensorDevice(mac_device_id(node_mac(11, i))) for i in settings.sensor_ids()} if hello else
                {str(i): SensorDevice(None, NO_HELLO) for i in settings.sensor_ids()})
    with Supervisor([config]) as supervisor:
        wait_for(lambda: supervisor.sources()["udp"].state == "running", supervisor)
        started = time.monotonic()
        run_emulator(settings, port, synthetic_motion(n, rate))
        wait_for(lambda: supervisor.sources()["udp"].devices == expected, supervisor)
        told_s = time.monotonic() - started
        wait_for(lambda: all(s.received > 100 for s in supervisor.stats().values()) and len(supervisor.stats()) == n,
                 supervisor)
    if hello:
        assert told_s < 1.0   # asked at once, answered at once, reported at once
    assert len({device.device_id for device in expected.values()}) == (n if hello else 1)


def test_another_emulator_seed_is_another_set_of_devices():
    assert node_mac(1, 5) != node_mac(2, 5) and node_mac(1, 5) == node_mac(1, 5)
    assert node_mac(1, 5)[0] == 0x02        # locally administered, unicast


def test_a_serial_node_says_hello_on_its_line(tmp_path, synthetic_motion):
    n, rate = 2, 100.0
    settings = EmulatorSettings(n_sensors=n, rate_hz=rate, seed=4)
    emulator = SerialEmulator(settings, synthetic_motion(n, rate))
    stop = threading.Event()
    thread = threading.Thread(target=emulator.run, args=(stop,), daemon=True)
    config = SerialSourceConfig(name="radio", device=emulator.device_path,
                                intake=IntakeSettings(sensor_ids=tuple(settings.sensor_ids())))
    expected = {str(i): SensorDevice(mac_device_id(node_mac(4, i))) for i in settings.sensor_ids()}
    try:
        thread.start()
        with Supervisor([config]) as supervisor:
            wait_for(lambda: supervisor.sources()["radio"].devices == expected, supervisor)
            status = supervisor.sources()["radio"]
            assert "malformed_line" not in status.rejections and "bad_field" not in status.rejections
    finally:
        stop.set()
        thread.join(5)
        emulator.close()
