"""Clock offset and drift estimation against clocks with known truth."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.acquisition.timesync import ClockSync, ClockSyncSettings, theil_sen


def _exchanges(rng, offset_s, drift_ppm, duration_s=20.0, rate_hz=5.0, outlier_fraction=0.3):
    """Round trips with 0.1–0.3 ms base delays and ``outlier_fraction`` queued 5–50 ms on one leg."""
    rate = 1 + drift_ppm * 1e-6
    device = lambda h: offset_s + rate * h  # noqa: E731
    for t1 in 1000.0 + np.arange(0, duration_s, 1 / rate_hz):
        up, down = rng.uniform(0.5e-4, 1.5e-4, size=2)
        if rng.random() < outlier_fraction:
            up += rng.uniform(5e-3, 50e-3)   # asymmetric queueing: the worst case for NTP
        t2 = device(t1 + up)
        t3 = t2 + 20e-6
        t4 = t1 + up + 20e-6 / rate + down
        yield t1, t2, t3, t4


def test_round_trips_recover_offset_and_drift_despite_outliers():
    rng = np.random.default_rng(1)
    sync = ClockSync()
    for exchange in _exchanges(rng, offset_s=-3.25, drift_ppm=150.0):
        sync.add_round_trip(*exchange)
    estimate = sync.refresh()
    assert estimate is not None
    assert estimate.drift_ppm == pytest.approx(150.0, abs=10.0)
    for host in (1000.0, 1010.0, 1020.0):
        true_device = -3.25 + (1 + 150e-6) * host
        assert abs(float(estimate.device_from_host(host)) - true_device) < 1e-4
        assert abs(float(estimate.host_from_device(true_device)) - host) < 1e-4
    assert 0 < estimate.uncertainty_s < 2e-4


def test_one_way_timestamps_track_the_clock_up_to_the_minimum_delay():
    rng = np.random.default_rng(2)
    sync = ClockSync()
    rate = 1 + 80e-6
    for host_send in 500.0 + np.arange(0, 10, 0.01):
        delay = 1e-3 + rng.exponential(2e-3)   # serial: at least 1 ms, sometimes much more
        sync.add_one_way(7.0 + rate * host_send, host_send + delay)
    estimate = sync.refresh()
    assert estimate.drift_ppm == pytest.approx(80.0, abs=30.0)
    # mapped time = send time + minimum delay (1 ms) within a fraction of a millisecond
    mapped = float(estimate.host_from_device(7.0 + rate * 505.0))
    assert mapped - 505.0 == pytest.approx(1e-3, abs=3e-4)


def test_estimate_follows_a_drift_change_within_the_window():
    sync = ClockSync(ClockSyncSettings(window_s=10.0))
    device = 0.0
    for k in range(400):          # 40 s at 10 Hz; drift 0 ppm, then 500 ppm after 20 s
        host = k * 0.1
        device += 0.1 * (1.0 if host < 20 else 1 + 500e-6)
        sync.add_round_trip(host, device + 1e-4, device + 1e-4, host + 2e-4)
    estimate = sync.refresh()
    assert estimate.drift_ppm == pytest.approx(500.0, abs=5.0)


def test_implausible_round_trips_are_ignored():
    sync = ClockSync()
    assert not sync.add_round_trip(1.0, 5.0, 4.0, 1.1)      # node answered before it received
    assert not sync.add_round_trip(1.0, 5.0, 5.0, 0.9)      # negative round trip
    assert not sync.add_round_trip(float("nan"), 5.0, 5.0, 1.0)
    assert sync.estimate is None


def test_theil_sen_ignores_a_minority_of_outliers():
    x = np.arange(20.0)
    y = 2.0 * x + 1.0
    y[[3, 11, 17]] += [50.0, -40.0, 100.0]
    slope, intercept = theil_sen(x, y)
    assert slope == pytest.approx(2.0) and intercept == pytest.approx(1.0)


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

any_float = st.floats(allow_nan=True, allow_infinity=True) | st.floats(-1e9, 1e9)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(any_float, any_float, any_float, any_float), max_size=40),
       st.lists(st.tuples(any_float, any_float), max_size=40))
def test_any_observations_give_a_finite_estimate_or_none(round_trips, one_ways):
    sync = ClockSync()
    for device, host in one_ways:
        sync.add_one_way(device, host)
    for exchange in round_trips:
        sync.add_round_trip(*exchange)
    estimate = sync.refresh()
    if estimate is not None:
        values = (estimate.host_ref_s, estimate.device_ref_s, estimate.rate, estimate.uncertainty_s)
        assert all(np.isfinite(values)) and estimate.rate > 0
