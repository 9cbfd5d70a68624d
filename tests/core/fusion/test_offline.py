"""Offline smoother: uses the whole recording, so it must be more accurate than the forward
filter against the ground truth, and reach back in time (bias, heading after a disturbance)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mimucap.core import rotation as rot
from mimucap.core.fusion.ekf import fuse
from mimucap.core.fusion.evaluation import error_angles_rad
from mimucap.core.fusion.offline import fuse_offline
from mimucap.core.fusion.params import DEFAULT_FUSION_PARAMS


def rms_deg(x: np.ndarray) -> float:
    return float(np.degrees(np.sqrt(np.nanmean(x ** 2))))


def test_smoother_beats_forward_filter(recording):
    forward = fuse(recording.t_s, recording.gyr, recording.acc, recording.mag)
    smooth = fuse_offline(recording.t_s, recording.gyr, recording.acc, recording.mag)
    total_f, _, _ = error_angles_rad(forward.q_world_from_sensor, recording.q_true)
    total_s, _, _ = error_angles_rad(smooth.q_world_from_sensor, recording.q_true)
    assert rms_deg(total_s) < 0.7 * rms_deg(total_f)
    # the flags are those of the smoother's forward pass
    assert np.array_equal(smooth.flags, fuse(recording.t_s, recording.gyr, recording.acc, recording.mag,
                                             params=DEFAULT_FUSION_PARAMS.smoother_pass()).flags)


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


def test_smoother_weighs_a_lasting_foreign_field_down(recording_factory):
    """For 30 s a foreign field (3 µT east, 2 µT up in the world: the norm 4 % and the dip 1.4°
    off, within the gate) turns the measured heading by 8.5°. Each sample's heading error is
    then the same for seconds: the smoother's own weighting (``smoother_pass``) keeps the
    heading within a few degrees, where the online settings let the smoother follow the field
    as closely as the forward filter does."""
    rec = recording_factory(duration_s=90.0, seed=1)
    t = rec.t_s
    weight = np.clip((t - 30.0) / 2.0, 0.0, 1.0) * np.clip((60.0 - t) / 2.0, 0.0, 1.0)
    mag = rec.mag + rot.rotate(rot.conjugate(rec.q_true), np.outer(weight, [3.0, 0.0, 2.0]))
    online = DEFAULT_FUSION_PARAMS
    as_online = replace(online, smoother_heading_field_error_gain=online.heading_field_error_gain,
                        smoother_mag_ref_tau_s=online.mag_ref_tau_s)
    episode = (t > 30.0) & (t < 60.0)

    def heading_rms_deg(result) -> float:
        return rms_deg(error_angles_rad(result.q_world_from_sensor, rec.q_true)[1][episode])

    smoothed = heading_rms_deg(fuse_offline(t, rec.gyr, rec.acc, mag))
    smoothed_as_online = heading_rms_deg(fuse_offline(t, rec.gyr, rec.acc, mag, params=as_online))
    forward = heading_rms_deg(fuse(t, rec.gyr, rec.acc, mag))
    assert smoothed < 2.5
    assert smoothed < 0.5 * smoothed_as_online
    assert smoothed < 0.5 * forward


def test_smoother_bridges_a_field_that_changed_for_good_with_the_gyroscope(recording_factory):
    """From 30 s to the end the field changes by (30, −20, 10) µT (world ENU: the field of issue
    34's uniform disturbance), turning its horizontal part by 90°. The online filter adopts it
    as a new reference after 20 s (``mag_new_field_s``) and its heading follows it; the
    smoother's pass never does (``smoother_mag_new_field_s`` 0) and keeps the heading."""
    rec = recording_factory(duration_s=90.0, seed=1)
    t = rec.t_s
    mag = rec.mag + rot.rotate(rot.conjugate(rec.q_true), np.outer(t >= 30.0, [30.0, -20.0, 10.0]))
    after = t > 31.0

    def heading_rms_deg(result) -> float:
        return rms_deg(error_angles_rad(result.q_world_from_sensor, rec.q_true)[1][after])

    forward = fuse(t, rec.gyr, rec.acc, mag)
    adopting = fuse_offline(t, rec.gyr, rec.acc, mag,
                            params=replace(DEFAULT_FUSION_PARAMS, smoother_mag_new_field_s=20.0))
    smoothed = fuse_offline(t, rec.gyr, rec.acc, mag)
    assert forward.counters[0]["mag_new_reference"] == 1 and heading_rms_deg(forward) > 30.0
    assert adopting.counters[0]["mag_new_reference"] == 1 and heading_rms_deg(adopting) > 30.0
    assert smoothed.counters[0]["mag_new_reference"] == 0
    assert heading_rms_deg(smoothed) < 1.0
