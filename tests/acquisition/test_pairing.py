"""The paired suit at the intake of the network sources: a sample of a device that is not paired,
or not identified yet, is refused as ``unpaired_device`` and counted, its sensor reported as
unpaired and never among the devices, and its sequence and clock left untouched; a source that
checks no pairing lets everything in as before."""

from __future__ import annotations

import queue

from mimucap.acquisition.hello import HELLO_WAIT_S, NO_HELLO, Hello
from mimucap.acquisition.intake import IntakeSettings, SampleIntake
from mimucap.acquisition.messages import BlocksMessage
from mimucap.acquisition.outbox import Outbox
from mimucap.acquisition.pairing import UnpairedSensor, admits
from mimucap.acquisition.slimevr import SlimeVrDriver, SlimeVrSourceConfig
from mimucap.core.device_identity import SensorDevice, mac_device_id
from mimucap.session.sources.source_configs import SourceOptions, source_configs
from tests.acquisition.test_slimevr_protocol import TRACKER, FakeSocket, handshake, rotation_packet

OURS, THEIRS = bytes.fromhex("02000000000A"), bytes.fromhex("02000000000B")


def sample(sensor: int, k: int):
    from mimucap.acquisition.wire_sample import Sample

    return Sample(sensor, k, 0.01 * k, acc=(0.0, 0.0, 9.81))


def test_admits_only_a_paired_device_id_when_a_suit_is_given():
    suit = frozenset({mac_device_id(OURS)})
    assert admits(None, None) and admits(None, SensorDevice(None, NO_HELLO))
    assert admits(suit, SensorDevice(mac_device_id(OURS)))
    assert not admits(suit, SensorDevice(mac_device_id(THEIRS)))
    assert not admits(suit, None) and not admits(suit, SensorDevice(None, NO_HELLO))
    assert not admits(frozenset(), SensorDevice(mac_device_id(OURS)))       # an empty suit lets nothing in


def test_the_intake_refuses_and_counts_unpaired_and_unidentified_sensors():
    sent = []
    intake = SampleIntake("udp", IntakeSettings(paired_devices=frozenset({mac_device_id(OURS)})), sent.append)
    assert intake.accept(sample(1, 0), 10.0) is False                   # before its hello: not known yet
    assert intake.awaiting_hello(1) and not intake.admitted(1)
    intake.identify(Hello(1, OURS), 10.01)
    intake.identify(Hello(2, THEIRS), 10.01)
    assert intake.admitted(1) and not intake.admitted(2) and not intake.awaiting_hello(2)
    accepted = [intake.accept(sample(1, k), 10.0 + 0.01 * k) for k in range(1, 6)]
    refused = [intake.accept(sample(2, k), 10.0 + 0.01 * k) for k in range(5)]
    intake.accept(sample(3, 0), 10.1)                                    # a node that never says hello
    intake.accept(sample(3, HELLO_WAIT_S * 100), 10.1 + HELLO_WAIT_S)
    intake.flush()
    assert accepted == [True] * 5 and refused == [False] * 5
    rows = [block for message in sent for block in message.unpacked()]
    assert [block.sensor_id for block in rows] == ["1"] and list(rows[0].seq) == [1, 2, 3, 4, 5]
    report = intake.report("running")
    assert report.rejections == {"unpaired_device": 1 + 5 + 2}
    assert report.rejections_by_sensor["2"] == {"unpaired_device": 5}
    assert report.devices == {"1": SensorDevice(mac_device_id(OURS))}   # the refused are no device of the session
    assert report.unpaired == {"2": UnpairedSensor("2", SensorDevice(mac_device_id(THEIRS)), 5),
                               "3": UnpairedSensor("3", SensorDevice(None, NO_HELLO), 2)}
    assert report.unpaired["2"].pairable and not report.unpaired["3"].pairable
    # sensor 1's refusal before its hello is not an unpaired sensor: its device is paired
    assert "1" not in report.unpaired


def test_without_a_suit_the_intake_lets_every_device_in():
    sent = []
    intake = SampleIntake("udp", IntakeSettings(), sent.append)
    assert intake.accept(sample(2, 0), 10.0) and intake.admitted(2)
    intake.identify(Hello(2, THEIRS), 10.01)
    assert intake.accept(sample(2, 1), 10.01)
    assert intake.report("running").unpaired == {} and intake.report("running").rejections == {}


def _slimevr(paired):
    messages: queue.Queue = queue.Queue()
    driver = SlimeVrDriver(SlimeVrSourceConfig(paired_devices=paired), Outbox(messages, "slimevr"))
    driver.sock = FakeSocket()
    return driver, messages


def test_a_slimevr_tracker_that_is_not_paired_is_served_but_its_rotations_are_refused():
    from tests.acquisition.test_slimevr_protocol import MAC

    driver, messages = _slimevr(frozenset({mac_device_id(MAC, 1)}))    # only its sensor 1 is ours
    driver.handle_datagram(handshake(), TRACKER, 10.0)
    assert driver.sock.sent[-1][0][0] == 3                              # answered: it keeps this server
    for k in range(4):
        driver.handle_datagram(rotation_packet(1 + 2 * k, 0, (0, 0, 0, 1)), TRACKER, 10.1 + 0.01 * k)
        driver.handle_datagram(rotation_packet(2 + 2 * k, 1, (0, 0, 0, 1)), TRACKER, 10.1 + 0.01 * k)
    driver.flush()
    names = set()
    while not messages.empty():
        message = messages.get()
        if isinstance(message, BlocksMessage):
            names.update(block.sensor_id for block in message.unpacked())
    assert names == {"024D43000007-1"}
    report = driver.report("running")
    assert report.rejections == {"unpaired_device": 4}
    assert set(report.devices) == {"024D43000007-1"}
    assert report.unpaired == {"024D43000007-0": UnpairedSensor("024D43000007-0",
                                                                SensorDevice(mac_device_id(MAC, 0)), 4)}


def test_the_network_sources_get_the_suit_and_a_fixed_set_up_by_address_checks_none():
    suit = frozenset({mac_device_id(OURS)})
    (udp,) = source_configs("udp:127.0.0.1:5600", SourceOptions(paired_devices=suit))
    (fixed,) = source_configs("udp:127.0.0.1:5600", SourceOptions(paired_devices=suit, allowed_addresses=("10.0.0.2",)))
    (slime,) = source_configs("slimevr:127.0.0.1:6969", SourceOptions(paired_devices=suit))
    (serial,) = source_configs("serial:/dev/ttyUSB0", SourceOptions(paired_devices=suit))
    assert udp.intake.paired_devices == suit and slime.paired_devices == suit
    assert fixed.intake.paired_devices is None and serial.intake.paired_devices is None
