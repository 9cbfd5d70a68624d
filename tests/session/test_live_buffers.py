"""Ring buffers and plain-Python events of the live session."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.session.diagnostics import CpuMeter
from mimucap.session.events import EmitterGroup
from mimucap.session.ring_buffer import RingBuffer


def test_ring_buffer_keeps_the_newest_samples_in_time_order():
    buffer = RingBuffer(5, (3,))
    buffer.append([0.0, 1.0, 2.0], np.arange(9.0).reshape(3, 3))
    buffer.append([3.0, 4.0, 5.0, 6.0], np.arange(12.0).reshape(4, 3) + 100)
    t, v = buffer.data()
    assert list(t) == [2.0, 3.0, 4.0, 5.0, 6.0]
    assert v[0].tolist() == [6.0, 7.0, 8.0] and v[-1].tolist() == [109.0, 110.0, 111.0]
    assert buffer.latest()[0] == 6.0 and len(buffer) == 5 and buffer.total_appended == 7
    t_since, _ = buffer.since(4.5)
    assert list(t_since) == [5.0, 6.0]
    assert buffer.at(3.5)[0] == 3.0
    buffer.append(np.arange(10.0, 20.0), np.zeros((10, 3)))  # more than the capacity at once
    assert list(buffer.data()[0]) == [15.0, 16.0, 17.0, 18.0, 19.0]
    with pytest.raises(ValueError):
        RingBuffer(0)


def test_events_call_subscribers_in_order_and_disconnect():
    events = EmitterGroup("blocks", "frame")
    calls = []
    first = events.blocks.connect(lambda x: calls.append(("a", x)))
    events.blocks.connect(lambda x: calls.append(("b", x)))
    events.blocks.emit(1)
    events.blocks.disconnect(first)
    events.blocks.emit(2)
    assert calls == [("a", 1), ("b", 1), ("b", 2)]
    with pytest.raises(AttributeError):
        events.nonexistent  # noqa: B018


def test_cpu_meter_reports_busy_work():
    meter = CpuMeter()
    total = 0.0
    for i in range(200_000):
        total += i * 0.5
    assert meter.sample() > 10.0
