"""Per-sensor statistics: exact percentiles of recent latencies and rates over the window, and
drops that count packet loss only (not samples the source received and refused)."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from mimucap.acquisition.replay import ReplayDriver, ReplaySourceConfig, replayable
from mimucap.acquisition.stats import SensorStatsTracker, _RecentValues, percentiles_linear
from mimucap.core.sensor_samples import SensorSamples


@pytest.mark.parametrize("n", [1, 2, 3, 10, 101, 4096])
def test_percentiles_are_numpys_linear_percentiles(n):
    rng = np.random.default_rng(n)
    for trial in range(10):
        values = rng.normal(size=n) * 10.0 ** rng.uniform(-6, 3)
        if trial == 1:
            values = np.round(values)  # ties
        expected = np.percentile(values, [50, 95, 0, 100, 33.3]).tolist()
        assert percentiles_linear(values, (50, 95, 0, 100, 33.3)) == expected
    values[n // 2] = np.nan
    assert all(np.isnan(percentiles_linear(values, (50, 95))))


@pytest.mark.parametrize("capacity", [0, 1, 5, 2000])
def test_recent_values_keep_the_newest_in_order(capacity):
    rng = np.random.default_rng(capacity)
    recent, everything = _RecentValues(capacity), []
    for _ in range(300):
        block = rng.normal(size=int(rng.integers(0, 9)))
        recent.extend(block)
        everything.extend(block.tolist())
        expected = everything[max(len(everything) - capacity, 0):] if capacity else []
        assert recent.values().tolist() == expected and len(recent) == len(expected)


def _block(first_seq: int, host_time_s: np.ndarray) -> SensorSamples:
    n = len(host_time_s)
    return SensorSamples(source="test", sensor_id="S01", seq=np.arange(first_seq, first_seq + n, dtype=np.int64),
                         device_time_s=host_time_s.copy(), t_s=host_time_s, receive_time_s=np.zeros(n),
                         acc=np.zeros((n, 3)), gyr=np.zeros((n, 3)), mag_uT=None, q_world_from_sensor=None)


@pytest.mark.parametrize("ordered", [True, False])
def test_latencies_and_counts_follow_every_block(ordered):
    rng = np.random.default_rng(7)
    tracker = SensorStatsTracker("S01", "test", window_s=2.0, latency_samples=500)
    latencies, seq, t = [], 0, 10.0
    for k in range(400):
        n = int(rng.integers(1, 6))
        arrival = t if ordered or k % 9 else t - 0.3  # now and then a late poll time
        host = arrival - rng.uniform(0.001, 0.02, size=n)
        tracker.add_block(_block(seq, host), arrival)
        latencies.extend((arrival - host).tolist())
        seq += n
        t += 0.013
        if k % 50 == 49:
            stats = tracker.snapshot(t)
            assert [stats.latency_p50_s, stats.latency_p95_s] == np.percentile(latencies[-500:], [50, 95]).tolist()
            assert stats.received == seq and stats.drops == 0


@pytest.mark.parametrize("poll_s", [0.016, 0.0167, 0.04, 0.005])
def test_a_steady_stream_reads_its_true_rate_whenever_the_panel_looks(poll_s):
    """Was: every sample that arrived within the window over the window's length, off by up
    to a batch at each end: a steady 100 Hz suit polled every 16 ms read 97.5 Hz, 0 drops."""
    rate = 100.0
    tracker = SensorStatsTracker("S01", "test", window_s=2.0)
    seq, produced, poll = 0, 0.0, 5.0
    readings = []
    while poll < 9.0:
        due = int(np.floor((poll - 5.0) * rate)) + 1 - seq       # samples made since the last poll
        if due:
            host = 5.0 + np.arange(seq, seq + due) / rate
            tracker.add_block(_block(seq, host), poll + 0.003)     # 3 ms transport
            seq += due
        for phase in (0.0, 0.3, 0.7, 0.99):                        # the panel reads at any moment
            readings.append(tracker.rate_hz(poll + 0.003 + phase * poll_s))
        poll += poll_s
    readings = np.array(readings[len(readings) // 2:])              # a full window in
    assert np.abs(readings - rate).max() < 0.55    # within one sample over the 2 s window


def test_a_sensor_that_stops_shows_a_falling_rate_then_zero():
    tracker = SensorStatsTracker("S01", "test", window_s=2.0)
    for k in range(200):                                           # 100 Hz in 16 ms polls for 2 s
        t = 1.0 + 0.016 * k
        tracker.add_block(_block(2 * k, np.array([t - 0.006, t])), t)
    last = 1.0 + 0.016 * 199
    assert tracker.rate_hz(last + 0.05) == pytest.approx(125.0, rel=0.01)   # 2 samples / 16 ms
    assert tracker.rate_hz(last + 1.0) < 0.6 * 125.0
    assert tracker.rate_hz(last + 1.9) < tracker.rate_hz(last + 1.0)
    assert tracker.rate_hz(last + 2.5) == 0.0


def test_a_replayed_stream_refuses_invalid_rows_and_reports_them_not_as_gaps():
    """Rows with NaN/inf or beyond the limits are not released; the replay driver counts them
    as rejections per sensor and reports those lying between released rows (which leave gaps
    in the sequence numbers that are not packet loss)."""
    n = 50
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    acc[10:14] = np.nan          # 4 refused between released rows
    acc[20, 0] = 500.0           # 1 out of range between released rows
    acc[47:] = np.inf            # 3 refused after the last released row
    seq = np.arange(n) + np.where(np.arange(n) >= 30, 2, 0)   # 2 packets really lost
    stream, refused = replayable(SensorSamples("S07", np.arange(n) / 100.0, seq, acc=acc))
    assert len(refused) == 8 and len(stream.t_s) == n - 8 and np.isfinite(stream.acc).all()
    blocks, reports = [], []

    class Outbox:
        overflow_samples = 0

        def send_blocks(self, message):
            blocks.extend(message.blocks)

        def send_report(self, report, final=False):
            reports.append(report)

        def report_due(self, now_s):
            return False

    driver = ReplayDriver(ReplaySourceConfig(name="replay", streams=(stream,), refused=(("S07", refused),), speed=100.0),
                          Outbox())
    driver.run(threading.Event())
    report = reports[-1]
    assert report.state == "finished" and report.rejections == {"non_finite": 7, "out_of_range": 1}
    assert report.rejections_by_sensor == {"S07": {"non_finite": 7, "out_of_range": 1}}
    assert report.refused_in_gaps == {"S07": 5}
    np.testing.assert_array_equal(np.concatenate([b.seq for b in blocks]), stream.seq)
    tracker = SensorStatsTracker("S07", "replay")
    for block in blocks:
        tracker.add_block(block, 1.0)
    assert tracker.snapshot(1.0).drops == 7                 # the gaps alone: 5 refused + 2 lost
    tracker.refused_in_gaps = report.refused_in_gaps["S07"]
    assert tracker.snapshot(1.0).drops == 2                 # only the 2 packets really lost
