"""Common timeline: interpolation against analytic signals, gaps, and online = batch."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.acquisition.alignment import AlignmentSettings, TimelineAligner, align, frame_grid
from mimucap.acquisition.samples import SampleBlock
from mimucap.core import rotation as rot


def _sensor(t: np.ndarray, w: float):
    """Sensor turning about z at ``w`` rad/s; gyr is a linear ramp in x (exact under linear interpolation)."""
    q = rot.from_axis_angle(np.array([0.0, 0.0, 1.0]), w * t)
    gyr = np.column_stack([2.0 * t, np.zeros_like(t), np.full_like(t, w)])
    return q, gyr


def test_two_sensors_with_different_rates_and_phases_land_on_one_grid():
    rng = np.random.default_rng(0)
    ta = 10.0 + np.arange(0, 2, 1 / 100) + rng.uniform(0, 2e-3, 200)     # 100 Hz with jitter
    tb = 10.003 + np.arange(0, 2, 1 / 60)                                  # 60 Hz, offset phase
    qa, ga = _sensor(ta, 0.7)
    qb, gb = _sensor(tb, -1.3)
    grid = frame_grid(10.1, 11.9, 50.0)
    frames = align({"a": (ta, {"gyr": ga, "q_world_from_sensor": qa}),
                    "b": (tb, {"gyr": gb, "q_world_from_sensor": qb})}, grid, max_gap_s=0.05)
    assert np.allclose(grid * 50.0, np.round(grid * 50.0))
    for name, w in (("a", 0.7), ("b", -1.3)):
        track = frames.sensors[name]
        assert track.valid.all()
        np.testing.assert_allclose(track.channels["gyr"][:, 0], 2.0 * grid, atol=1e-9)
        truth = rot.from_axis_angle(np.array([0.0, 0.0, 1.0]), w * grid)
        assert np.max(rot.angle_between(track.channels["q_world_from_sensor"], truth)) < 1e-9


def test_gaps_and_edges_are_invalid_and_nan_not_invented():
    t = np.r_[np.arange(0, 1, 0.01), np.arange(1.5, 2, 0.01)]               # 0.5 s dropout
    _q, gyr = _sensor(t, 1.0)
    grid = frame_grid(-0.1, 2.2, 10.0)
    track = align({"s": (t, {"gyr": gyr})}, grid, max_gap_s=0.05).sensors["s"]
    inside = ((grid >= 0) & (grid <= t[99])) | ((grid >= 1.5) & (grid <= t[-1]))
    np.testing.assert_array_equal(track.valid, inside)
    assert np.all(np.isnan(track.channels["gyr"][~track.valid]))
    assert np.all(np.isfinite(track.channels["gyr"][track.valid]))


def test_online_aligner_emits_each_frame_once_and_matches_the_batch():
    t = 100.0 + np.arange(0, 3, 1 / 100)
    q, gyr = _sensor(t, 0.5)
    aligner = TimelineAligner(["s"], AlignmentSettings(rate_hz=25.0, delay_s=0.05))
    emitted = []
    for start in range(0, len(t), 7):
        sl = slice(start, start + 7)
        n = len(t[sl])
        aligner.add_blocks([SampleBlock("x", "s", np.arange(start, start + n), t[sl], t[sl], t[sl],
                                        gyr=gyr[sl], q_world_from_sensor=q[sl])])
        frames = aligner.frames(now_s=t[sl][-1])
        if frames is not None:
            emitted.append(frames)
    times = np.concatenate([f.t_s for f in emitted])
    assert np.all(np.diff(times) > 0)
    np.testing.assert_allclose(np.diff(times), 1 / 25.0)
    gyr_online = np.concatenate([f.sensors["s"].channels["gyr"] for f in emitted])
    batch = align({"s": (t, {"gyr": gyr})}, times).sensors["s"]
    np.testing.assert_allclose(gyr_online, batch.channels["gyr"])
    assert times[-1] == pytest.approx(t[-1] - 0.05, abs=1 / 25.0)
