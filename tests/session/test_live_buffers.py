"""Ring buffers and plain-Python events of the live session."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.session.views.cpu_meter import CpuMeter
from mimucap.session.events import EmitterGroup
from mimucap.session.live.ring_buffer import RingBuffer


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


@pytest.mark.parametrize("capacity", [1, 4, 7])
def test_since_and_latest_time_agree_with_the_ordered_data(capacity):
    """``since`` copies only the samples asked for, wrapped or not; the same as slicing ``data``."""
    rng = np.random.default_rng(capacity)
    buffer = RingBuffer(capacity, (2,))
    assert np.isnan(buffer.latest_t())
    t_next = 0.0
    for _ in range(40):
        n = int(rng.integers(0, capacity + 2))
        t = t_next + np.arange(n) * 0.5
        t_next += 0.5 * n
        buffer.append(t, rng.normal(size=(n, 2)))
        t_all, v_all = buffer.data()
        if len(buffer):
            assert buffer.latest_t() == t_all[-1]
        for t_from in (-1.0, t_next - 1.2, t_next - 0.5, t_next + 1.0, *t_all):
            first = int(np.searchsorted(t_all, t_from, side="left"))
            t_since, v_since = buffer.since(t_from)
            np.testing.assert_array_equal(t_since, t_all[first:])
            np.testing.assert_array_equal(v_since, v_all[first:])
            assert v_since.shape == (len(t_since), 2)
            if len(v_since):
                v_since[0] = 1e9  # a copy: the buffer keeps its values
                assert not np.any(buffer.data()[1] == 1e9)


def test_a_single_time_stamp_appends_one_sample():
    buffer = RingBuffer(3, (3,))
    buffer.append(2.5, [1.0, 2.0, 3.0])
    assert buffer.latest_t() == 2.5 and buffer.latest()[1].tolist() == [1.0, 2.0, 3.0]
    with pytest.raises(ValueError):
        buffer.append([1.0, 2.0], np.zeros(3))
