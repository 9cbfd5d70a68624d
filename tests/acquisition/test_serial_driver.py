"""The serial driver's line splitting, without a device: torn, oversized and garbage input."""

from __future__ import annotations

from mimucap.acquisition import protocol_serial
from mimucap.acquisition.intake import IntakeSettings
from mimucap.acquisition.outbox import Outbox
from mimucap.acquisition.serial_port import SerialDriver, SerialSourceConfig
from mimucap.acquisition.wire_sample import Sample


class ListQueue:
    def __init__(self):
        self.items = []

    def put_nowait(self, item):
        self.items.append(item)

    put = put_nowait


def test_lines_split_across_reads_oversized_and_garbage_are_counted():
    queue = ListQueue()
    driver = SerialDriver(SerialSourceConfig(intake=IntakeSettings(flush_interval_s=1e-6)), Outbox(queue, "serial"))
    lines = b"".join(protocol_serial.encode_line(Sample(sensor_id=2, seq=k, device_time_s=10 + k * 0.01,
                                                        gyr=(0.0, 0.0, 0.5))) for k in range(20))
    stream = lines[:510] + b"X" * 1000 + b"\r\n" + lines[510:] + b"\x00\xff garbage\r\n"  # 510: inside line 16
    for start in range(0, len(stream), 37):          # arbitrary read boundaries
        driver.handle_bytes(stream[start:start + 37], now=100.0 + start * 1e-5)
    driver.intake.flush()
    received = sum(len(block) for message in queue.items for block in message.unpacked())
    rejections = driver.intake.rejections.as_dict()
    # the line cut by the oversized burst is lost (one malformed), the rest arrives
    assert rejections == {"oversized": 1, "malformed_line": 2}
    assert received == 19


def test_a_line_with_nan_is_a_rejection_of_its_sensor_and_not_a_drop():
    queue = ListQueue()
    driver = SerialDriver(SerialSourceConfig(intake=IntakeSettings(flush_interval_s=1e-6)), Outbox(queue, "serial"))
    for k in range(10):
        gyr = (float("nan") if k in (3, 4) else 0.0, 0.0, 0.5)
        driver.handle_bytes(protocol_serial.encode_line(Sample(sensor_id=2, seq=k, device_time_s=10 + k * 0.01,
                                                               gyr=gyr)), now=100.0 + k * 0.01)
    driver.intake.flush()
    report = driver.intake.report("running")
    assert report.rejections == {"non_finite": 2}
    assert report.rejections_by_sensor == {"2": {"non_finite": 2}}
    assert report.refused_in_gaps == {"2": 2}
    assert [int(s) for m in queue.items for b in m.unpacked() for s in b.seq] == [0, 1, 2, 5, 6, 7, 8, 9]
