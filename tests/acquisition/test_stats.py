"""Per-sensor statistics: exact percentiles of recent latencies and rates over the window."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.acquisition.samples import SampleBlock
from mimucap.acquisition.stats import SensorStatsTracker, _RecentValues, percentiles_linear


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


def _block(first_seq: int, host_time_s: np.ndarray) -> SampleBlock:
    n = len(host_time_s)
    return SampleBlock(source="test", sensor_id="S01", seq=np.arange(first_seq, first_seq + n, dtype=np.int64),
                       device_time_s=host_time_s.copy(), host_time_s=host_time_s, receive_time_s=np.zeros(n),
                       acc=np.zeros((n, 3)), gyr=np.zeros((n, 3)), mag_uT=None, q_world_from_sensor=None)


@pytest.mark.parametrize("ordered", [True, False])
def test_rate_counts_the_samples_that_arrived_within_the_window(ordered):
    rng = np.random.default_rng(7)
    tracker = SensorStatsTracker("S01", "test", window_s=2.0, latency_samples=500)
    arrivals, latencies, seq, t = [], [], 0, 10.0
    for k in range(400):
        n = int(rng.integers(1, 6))
        arrival = t if ordered or k % 9 else t - 0.3  # now and then a late poll time
        host = arrival - rng.uniform(0.001, 0.02, size=n)
        tracker.add_block(_block(seq, host), arrival)
        arrivals.append((arrival, n))
        latencies.extend((arrival - host).tolist())
        seq += n
        t += 0.013
        arrivals = [(a, m) for a, m in arrivals if a >= arrival - 2.0]
        if k % 50 == 49:
            for now in (t, t + 1.0, t + 5.0):
                stats = tracker.snapshot(now)
                in_window = [m for a, m in arrivals if a >= now - 2.0]
                span = min(2.0, max(now - arrivals[0][0], 1e-3)) if in_window else 2.0
                assert stats.rate_hz == (sum(in_window) / span if in_window else 0.0)
                assert [stats.latency_p50_s, stats.latency_p95_s] == np.percentile(latencies[-500:], [50, 95]).tolist()
                assert stats.received == seq and stats.drops == 0
