"""What the live plots draw: decimation keeps every peak and gap, ranges stay still until they
must move, ticks are round and labelled."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.session.views.plot_scaling import SteadyRange, column_bounds, nice_ticks, peak_decimate


def test_peak_decimation_keeps_every_peak_and_every_gap():
    x = np.arange(10_000) / 100.0
    y = np.zeros((10_000, 2))
    y[1234, 0] = 5.0   # a one-sample spike
    y[7777, 1] = -3.0
    y[5000:5100, :] = np.nan  # one second without data
    dx, dy = peak_decimate(x, y, 1000)
    assert len(dx) <= 1000 and dy.shape == (len(dx), 2)
    assert np.nanmax(dy[:, 0]) == 5.0 and np.nanmin(dy[:, 1]) == -3.0
    assert np.isnan(dy).any()
    assert np.all(np.diff(dx) >= 0)
    same_x, same_y = peak_decimate(x[:500], y[:500], 1000)
    np.testing.assert_array_equal(same_x, x[:500])
    np.testing.assert_array_equal(same_y, y[:500])


def test_vertical_range_grows_at_once_and_shrinks_only_after_a_while():
    steady = SteadyRange(min_span=2.0)
    assert steady.update(0.0, 10.0, now_s=0.0)
    assert steady.low < 0.0 and steady.high > 10.0
    assert not steady.update(4.0, 6.0, now_s=0.5)   # small data: range kept ...
    assert not steady.update(4.0, 6.0, now_s=1.5)
    assert steady.update(4.0, 6.0, now_s=2.6)      # ... until 2 s have passed
    assert steady.low <= 4.0 and steady.high >= 6.0 and steady.high - steady.low < 5.0
    assert not steady.update(None, None, now_s=3.0)    # no data: nothing changes
    assert steady.update(-50.0, -50.0, now_s=3.1)
    assert steady.low <= -50.0
    tiny = SteadyRange(min_span=10.0)
    tiny.update(0.0, 0.01, now_s=0.0)
    assert tiny.high - tiny.low >= 10.0  # noise is never blown up to full height


@pytest.mark.parametrize("low, high", [(-0.66, 0.66), (-1.2, 1.2), (-13.0, 13.0), (-35.0, 2.0), (0.0, 65.0),
                                       (9.5, 10.3), (-1e-3, 1e-3)])
def test_every_range_gets_a_few_round_labelled_ticks(low, high):
    ticks = nice_ticks(low, high)
    values = [v for v, _ in ticks]
    assert 3 <= len(ticks) <= 8
    assert all(low <= v <= high for v in values)
    steps = np.diff(values)
    np.testing.assert_allclose(steps, steps[0])
    mantissa = steps[0] / 10 ** np.floor(np.log10(steps[0]))
    assert min(abs(mantissa - m) for m in (1, 2, 5, 10)) < 1e-9
    assert len({label for _, label in ticks}) == len(ticks)  # labels tell the ticks apart
    assert "-0" not in [label.rstrip("0.") or "0" for _, label in ticks if abs(float(label)) == 0]


def test_column_bounds_skip_gaps_and_name_an_empty_column():
    values = np.array([[1.0, np.nan, -2.0], [np.nan, np.nan, 5.0], [3.0, np.nan, np.nan]])
    low, high = column_bounds(values)
    assert low == [1.0, None, -2.0] and high == [3.0, None, 5.0]
    assert column_bounds(np.zeros((0, 3))) == ([None] * 3, [None] * 3)


@pytest.mark.parametrize("low, high, most, expected", [
    (-35.8, 13.0, 1, [-20.0, 0.0]), (-12.5, 3.2, 2, [-10.0, 0.0]), (0.0, 65.0, 3, [0.0, 50.0]),
    (0.0, 65.0, 1, [0.0, 50.0]),        # never a single label when two round values fit
    (-5.0, 5.0, 2, [0.0, 5.0]),         # a coarser step (10) would leave 0 alone: the two nearest 0
    (-0.66, 0.66, 2, [0.0, 0.5]), (-1.2, 1.2, 2, [0.0, 1.0])
])
def test_a_short_plot_gets_fewer_coarser_ticks(low, high, most, expected):
    assert len(nice_ticks(low, high, 4)) > most
    assert [v for v, _ in nice_ticks(low, high, 4, most=most)] == pytest.approx(expected)
