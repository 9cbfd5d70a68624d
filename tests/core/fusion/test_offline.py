"""Offline smoother: uses the whole recording, so it must be more accurate than the forward
filter against the ground truth, and reach back in time (bias, heading after a disturbance)."""

from __future__ import annotations

import numpy as np

from mimucap.core.fusion.ekf import fuse
from mimucap.core.fusion.evaluation import error_angles_rad
from mimucap.core.fusion.offline import fuse_offline


def rms_deg(x: np.ndarray) -> float:
    return float(np.degrees(np.sqrt(np.nanmean(x ** 2))))


def test_smoother_beats_forward_filter(recording):
    forward = fuse(recording.t_s, recording.gyr, recording.acc, recording.mag)
    smooth = fuse_offline(recording.t_s, recording.gyr, recording.acc, recording.mag)
    total_f, _, _ = error_angles_rad(forward.q_world_from_sensor, recording.q_true)
    total_s, _, _ = error_angles_rad(smooth.q_world_from_sensor, recording.q_true)
    assert rms_deg(total_s) < 0.7 * rms_deg(total_f)
    assert np.array_equal(smooth.flags, forward.flags)


def test_smoother_bias_reaches_back_to_the_start(recording):
    smooth = fuse_offline(recording.t_s, recording.gyr, recording.acc, recording.mag)
    forward = fuse(recording.t_s, recording.gyr, recording.acc, recording.mag)
    err_smooth = np.abs(smooth.bias_rad_s[10] - recording.bias).max()
    err_forward = np.abs(forward.bias_rad_s[10] - recording.bias).max()
    assert err_smooth < 0.5 * err_forward


def test_smoother_several_sensors_and_uninitialised_rows(recording_factory):
    recs = [recording_factory(duration_s=4.0, seed=s) for s in range(2)]
    acc = np.stack([r.acc for r in recs])
    acc[1, :3] = np.nan
    result = fuse_offline(recs[0].t_s, np.stack([r.gyr for r in recs]), acc,
                          np.stack([r.mag for r in recs]))
    assert np.isnan(result.q_world_from_sensor[1, :3]).all()
    assert np.isfinite(result.q_world_from_sensor[1, 3:]).all()
    alone = fuse_offline(recs[0].t_s, recs[0].gyr, recs[0].acc, recs[0].mag)
    assert np.array_equal(alone.q_world_from_sensor, result.q_world_from_sensor[0])
