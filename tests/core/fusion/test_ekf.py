"""The online error-state EKF: accuracy on synthetic truth, bias at rest, block = batch,
bad samples skipped, gaps and variable intervals, several sensors at once."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.core.fusion.ekf import ALGORITHMS, FusionResult, OrientationEKF, fuse, update_together
from mimucap.core.fusion.offline import fuse_offline
from mimucap.core.fusion.evaluation import error_angles_rad
from mimucap.core.fusion.params import DEFAULT_FUSION_PARAMS, FusionParams
from mimucap.core.fusion.state import FLAG_UNINITIALISED


def rms_deg(x: np.ndarray) -> float:
    return float(np.degrees(np.sqrt(np.nanmean(x ** 2))))


def test_tracks_synthetic_motion(recording):
    result = fuse(recording.t_s, recording.gyr, recording.acc, recording.mag)
    total, heading, incl = error_angles_rad(result.q_world_from_sensor, recording.q_true)
    settled = slice(500, None)  # after 5 s
    assert rms_deg(incl[settled]) < 0.5
    assert rms_deg(heading[settled]) < 1.0
    assert np.all(np.isfinite(result.q_world_from_sensor))
    assert np.allclose(np.linalg.norm(result.q_world_from_sensor, axis=1), 1.0)


def test_initial_alignment_from_first_sample(recording):
    result = fuse(recording.t_s[:1], recording.gyr[:1], recording.acc[:1], recording.mag[:1])
    assert np.degrees(rot.angle_between(result.q_world_from_sensor[0], recording.q_true[0])) < 1.5


def test_gyro_bias_converges_at_rest(recording_factory):
    rec = recording_factory(duration_s=12.0, still_s=12.5, bias_dps=(0.8, -0.5, 0.3), seed=4)
    result = fuse(rec.t_s, rec.gyr, rec.acc, rec.mag)
    masks = result.flag_masks()
    # rest is declared after rest_time_s (1.5 s) of stillness and then held
    assert not masks["rest"][:100].any()
    assert masks["rest"][300:].all()
    error_dps = np.degrees(np.abs(result.bias_rad_s[-1] - rec.bias))
    assert np.all(error_dps < 0.03), error_dps


def test_block_updates_equal_one_batch(recording):
    batch = fuse(recording.t_s, recording.gyr, recording.acc, recording.mag)
    ekf = OrientationEKF()
    cuts = [0, 1, 2, 17, 250, 251, 900, len(recording.t_s)]
    parts = [ekf.update_batch(recording.t_s[a:b], recording.gyr[a:b], recording.acc[a:b],
                              recording.mag[a:b]) for a, b in zip(cuts[:-1], cuts[1:])]
    q_blocks = np.concatenate([p.q_world_from_sensor for p in parts])
    assert np.array_equal(q_blocks, batch.q_world_from_sensor)
    assert np.array_equal(np.concatenate([p.flags for p in parts]), batch.flags)
    assert ekf.counters() == batch.counters[0]
    # each block's counters are those at its end, not the filter's later ones
    assert [p.counters[0]["samples"] for p in parts] == cuts[1:]
    assert len(parts[0].counters) == 1 and parts[0].counters[:] == [parts[0].counters[0]]


def test_per_sample_update_equals_batch(recording):
    n = 300
    batch = fuse(recording.t_s[:n], recording.gyr[:n], recording.acc[:n], recording.mag[:n])
    ekf = OrientationEKF()
    q = np.array([ekf.update(recording.t_s[k], recording.gyr[k], recording.acc[k], recording.mag[k])
                  for k in range(n)])
    assert np.array_equal(q, batch.q_world_from_sensor)


def test_several_sensors_at_once_equal_separate_runs(recording_factory):
    recs = [recording_factory(duration_s=5.0, seed=s) for s in range(3)]
    together = fuse(recs[0].t_s, np.stack([r.gyr for r in recs]), np.stack([r.acc for r in recs]),
                    np.stack([r.mag for r in recs]))
    assert together.q_world_from_sensor.shape == (3, recs[0].t_s.size, 4)
    for s, rec in enumerate(recs):
        alone = fuse(rec.t_s, rec.gyr, rec.acc, rec.mag)
        assert np.array_equal(together.q_world_from_sensor[s], alone.q_world_from_sensor)


def test_filters_fed_together_equal_their_own_calls_block_after_block(recording_factory):
    from mimucap.core.fusion.ekf import update_together

    recs = [recording_factory(duration_s=3.0, seed=s) for s in range(4)]
    alone = [OrientationEKF() for _ in recs]
    together = [OrientationEKF() for _ in recs]
    together[1].update_batch(recs[1].t_s[:5], recs[1].gyr[:5], recs[1].acc[:5], recs[1].mag[:5])
    alone[1].update_batch(recs[1].t_s[:5], recs[1].gyr[:5], recs[1].acc[:5], recs[1].mag[:5])  # one ahead
    for a, b in ((5, 6), (6, 9), (9, 140), (140, 301)):
        t = np.stack([r.t_s[a:b] for r in recs])
        result = update_together(together, t, np.stack([r.gyr[a:b] for r in recs]),
                                 np.stack([r.acc[a:b] for r in recs]), np.stack([r.mag[a:b] for r in recs]))
        for s, (ekf, rec) in enumerate(zip(alone, recs)):
            own = ekf.update_batch(rec.t_s[a:b], rec.gyr[a:b], rec.acc[a:b], rec.mag[a:b])
            assert np.array_equal(result.q_world_from_sensor[s], own.q_world_from_sensor)
            assert np.array_equal(result.flags[s], own.flags)
            assert result.counters[s] == own.counters[0]
    for mine, theirs in zip(together, alone):
        assert np.array_equal(mine.state.cov, theirs.state.cov) and np.array_equal(mine.state.aux, theirs.state.aux)
    with pytest.raises(ValueError, match="same"):
        update_together([OrientationEKF(), OrientationEKF(use_mag=False)], t[:2], np.zeros((2, t.shape[1], 3)))


def test_bad_samples_are_skipped_and_counted(recording):
    gyr, acc, mag, t = (recording.gyr.copy(), recording.acc.copy(), recording.mag.copy(),
                        recording.t_s.copy())
    gyr[100] = np.nan
    gyr[200] = [100.0, 0.0, 0.0]  # beyond the gyro range (rad/s)
    t[300] = t[299]  # repeated time stamp
    acc[400] = [np.inf, 0.0, 0.0]
    acc[401] = 0.0
    mag[500] = np.nan
    mag[501] = [1e5, 0.0, 0.0]  # beyond the magnetometer range
    result = fuse(t, gyr, acc, mag)
    masks = result.flag_masks()
    assert np.flatnonzero(masks["skipped"]).tolist() == [100, 200, 300]
    assert np.flatnonzero(masks["acc_missing"]).tolist() == [400, 401]
    assert np.flatnonzero(masks["mag_missing"]).tolist() == [500, 501]
    counters = result.counters[0]
    assert (counters["skipped"], counters["acc_missing"], counters["mag_missing"]) == (3, 2, 2)
    assert np.all(np.isfinite(result.q_world_from_sensor))
    assert np.all(np.isfinite(result.bias_rad_s))
    clean = fuse(recording.t_s, recording.gyr, recording.acc, recording.mag)
    diff = rot.angle_between(result.q_world_from_sensor[-1], clean.q_world_from_sensor[-1])
    assert np.degrees(diff) < 0.2


def test_waits_for_a_valid_accelerometer_sample(recording):
    acc = recording.acc.copy()
    acc[:5] = np.nan
    result = fuse(recording.t_s, recording.gyr, acc, recording.mag)
    assert np.isnan(result.q_world_from_sensor[:5]).all()
    assert (result.flags[:5] & FLAG_UNINITIALISED).all()
    assert np.isfinite(result.q_world_from_sensor[5:]).all()


def test_variable_intervals_and_gaps(recording_factory):
    rec = recording_factory(duration_s=30.0, rate_hz=200.0, seed=2)
    rng = np.random.default_rng(7)
    keep = rng.random(rec.t_s.size) > 0.3  # 30 % of the samples lost: irregular intervals
    keep[2000:2400] = False  # a 2 s gap during motion
    keep[0] = True
    idx = np.flatnonzero(keep)
    # gyro samples after a loss are the mean rate over their own interval only: rebuild them
    # as the mean of the lost samples' rates (what a device integrating between sends would give)
    cum = np.concatenate([[0.0], np.cumsum(np.diff(rec.t_s))])
    gyr = np.empty((idx.size, 3))
    gyr[0] = rec.gyr[0]
    for j in range(1, idx.size):
        gyr[j] = rec.gyr[idx[j - 1] + 1: idx[j] + 1].mean(axis=0)
    result = fuse(cum[idx], gyr, rec.acc[idx], rec.mag[idx])
    total, heading, incl = error_angles_rad(result.q_world_from_sensor, rec.q_true[idx])
    t = cum[idx]
    before = (t > 5) & (t < 10)
    after = t > 22  # 10 s after the gap
    assert result.counters[0]["skipped"] == 0
    assert rms_deg(incl[before]) < 0.6 and rms_deg(heading[before]) < 1.2
    assert rms_deg(incl[after]) < 1.0 and rms_deg(heading[after]) < 2.0


def test_without_magnetometer_tilt_is_still_right(recording):
    result = fuse(recording.t_s, recording.gyr, recording.acc, None)
    _, _, incl = error_angles_rad(result.q_world_from_sensor, recording.q_true)
    assert rms_deg(incl[500:]) < 0.6
    assert result.counters[0]["mag_missing"] == 0
    no_mag = fuse(recording.t_s, recording.gyr, recording.acc, recording.mag, use_mag=False)
    assert np.array_equal(no_mag.q_world_from_sensor, result.q_world_from_sensor)


def test_gyro_only_algorithm_integrates_from_the_alignment(recording_factory):
    rec = recording_factory(duration_s=5.0, bias_dps=(0, 0, 0), gyr_noise_dps=0.0, seed=3)
    result = fuse(rec.t_s, rec.gyr, rec.acc, rec.mag, algorithm="taylor3")
    total, _, _ = error_angles_rad(result.q_world_from_sensor, rec.q_true)
    assert np.degrees(np.max(total)) < 1.0
    assert (result.flags & 0b0111).sum() == 0  # no rest, no rejection flags: nothing corrects


def test_settings_are_validated():
    with pytest.raises(ValueError, match="unknown propagation"):
        FusionParams(propagation="euler")
    with pytest.raises(ValueError, match="acc_noise_m_s2"):
        replace(DEFAULT_FUSION_PARAMS, acc_noise_m_s2=-1.0)
    with pytest.raises(ValueError, match="unknown algorithm"):
        OrientationEKF(algorithm="kalman")
    with pytest.raises(ValueError, match="acc: expected shape"):
        fuse(np.arange(3.0), np.zeros((3, 3)), np.zeros((4, 3)))
    with pytest.raises(TypeError):
        FusionParams(acc_nosie_m_s2=1.0)  # a typo fails loudly
    with pytest.raises(ValueError, match="smoother_mag_ref_tau_s must be > 0"):
        replace(DEFAULT_FUSION_PARAMS, smoother_mag_ref_tau_s=0.0)


def test_smoother_pass_changes_the_magnetometer_weighting_and_shares_the_state(recording):
    params = replace(DEFAULT_FUSION_PARAMS, smoother_heading_field_error_gain=7.0, smoother_mag_ref_tau_s=99.0,
                     smoother_mag_new_field_s=0.0)
    smoother = params.smoother_pass()
    assert (smoother.heading_field_error_gain, smoother.mag_ref_tau_s, smoother.mag_new_field_s) == (7.0, 99.0, np.inf)
    assert replace(smoother, heading_field_error_gain=params.heading_field_error_gain,
                   mag_ref_tau_s=params.mag_ref_tau_s, mag_new_field_s=params.mag_new_field_s) == params
    assert replace(params, smoother_mag_new_field_s=30.0).smoother_pass().mag_new_field_s == 30.0
    ekf = OrientationEKF(params)
    feeding = ekf.smoother_pass()
    assert feeding.params == smoother and feeding.state is ekf.state
    half = len(recording.t_s) // 2
    first = feeding.update_batch(recording.t_s[:half], recording.gyr[:half], recording.acc[:half],
                                 recording.mag[:half])
    assert ekf.counters()["samples"] == half
    whole = fuse(recording.t_s[:half], recording.gyr[:half], recording.acc[:half], recording.mag[:half],
                 params=smoother)
    assert np.array_equal(first.q_world_from_sensor, whole.q_world_from_sensor)
    assert np.array_equal(ekf.state.q_world_from_sensor[0], whole.q_world_from_sensor[-1])


def test_declination_turns_the_heading_to_true_north(recording_factory):
    """Magnetic north 10° east of true north: with the declination set, the estimate is in the
    true-north ENU frame; without it, in the magnetic frame (10° of heading off)."""
    rec = recording_factory(duration_s=10.0, seed=8)
    declination = np.radians(10.0)
    # field of the synthetic recordings, turned so that its horizontal part points 10° east
    q_true_from_magnetic = rot.from_axis_angle([0, 0, 1], -declination)
    field_true = rot.rotate(q_true_from_magnetic, [0.0, 20.0, -40.0])
    mag = rot.rotate(rot.conjugate(rec.q_true), field_true)
    with_decl = fuse(rec.t_s, rec.gyr, rec.acc, mag,
                     params=replace(DEFAULT_FUSION_PARAMS, declination_rad=declination))
    without = fuse(rec.t_s, rec.gyr, rec.acc, mag)
    _, heading, _ = error_angles_rad(with_decl.q_world_from_sensor, rec.q_true)
    _, heading_mag, _ = error_angles_rad(without.q_world_from_sensor, rec.q_true)
    assert rms_deg(heading) < 1.0
    assert abs(rms_deg(heading_mag) - 10.0) < 1.0
    with pytest.raises(ValueError, match="declination"):
        replace(DEFAULT_FUSION_PARAMS, declination_rad=4.0)


def test_per_sensor_time_stamps(recording_factory):
    recs = [recording_factory(duration_s=3.0, seed=s) for s in range(2)]
    t = np.stack([recs[0].t_s, recs[1].t_s + 0.004])  # the second unit samples 4 ms later
    result = fuse(t, np.stack([r.gyr for r in recs]), np.stack([r.acc for r in recs]),
                  np.stack([r.mag for r in recs]))
    alone = fuse(t[1], recs[1].gyr, recs[1].acc, recs[1].mag)
    assert np.array_equal(result.q_world_from_sensor[1], alone.q_world_from_sensor)
    with pytest.raises(ValueError, match="t_s: expected shape"):
        fuse(t[:, :-1], np.stack([r.gyr for r in recs]))


def test_state_getters_report_initialisation_attitude_uncertainty_and_learned_field(recording):
    ekf = OrientationEKF(n_sensors=1)
    assert not ekf.state.initialised(0) and ekf.state.magnetic_reference(0) is None
    ekf.update_batch(recording.t_s, recording.gyr, recording.acc, recording.mag)
    state = ekf.state
    assert state.initialised(0)
    std = state.attitude_std_rad(0)
    assert std.shape == (3,) and np.all(np.isfinite(std)) and np.all(std > 0.0) and np.all(std < np.radians(5.0))
    norm_uT, dip_rad = state.magnetic_reference(0)
    # the recordings' field (conftest): 20 µT north, 40 µT down
    assert norm_uT == pytest.approx(np.hypot(20.0, 40.0), rel=0.05)
    assert dip_rad == pytest.approx(np.arctan2(40.0, 20.0), abs=np.radians(3.0))  # positive downwards



def test_a_new_magnetometer_calibration_keeps_tilt_and_bias_and_learns_the_heading_anew(recording_factory):
    rec = recording_factory(duration_s=30.0, bias_dps=(1.5, -1.0, 0.8), seed=5)
    # Before the calibration: a hard-iron offset nobody corrected (the heading it gives is
    # wrong by tens of degrees, by an amount that changes as the sensor turns).
    raw = rec.mag + np.array([25.0, -15.0, 10.0])
    split = 1500
    ekf = OrientationEKF()
    ekf.update_batch(rec.t_s[:split], rec.gyr[:split], rec.acc[:split], raw[:split])
    q_before, bias_before = ekf.state.q_world_from_sensor.copy(), ekf.state.bias_rad_s.copy()
    _, heading_before, _ = error_angles_rad(q_before[0], rec.q_true[split - 1])
    assert np.degrees(abs(heading_before)) > 10.0
    ekf.magnetometer_changed()
    # the estimates stay; their uncertainty is the initial one, the heading's unknown
    assert np.array_equal(ekf.state.q_world_from_sensor, q_before)
    assert np.array_equal(ekf.state.bias_rad_s, bias_before)
    assert ekf.state.magnetic_reference(0) is None
    std = ekf.state.attitude_std_rad(0)
    assert std[:2] == pytest.approx([DEFAULT_FUSION_PARAMS.init_tilt_std_rad] * 2)
    assert std[2] == pytest.approx(np.pi / np.sqrt(3.0))
    after = ekf.update_batch(rec.t_s[split:], rec.gyr[split:], rec.acc[split:], rec.mag[split:])
    _, heading, incl = error_angles_rad(after.q_world_from_sensor, rec.q_true[split:])
    assert not after.flag_masks()["mag_rejected"].any()  # the new field's reference is learned anew
    assert rms_deg(heading[200:]) < 1.0                   # within 2 s of the calibration
    assert rms_deg(incl) < 1.0
    # the bias learned before is kept (not restarted from zero)
    assert np.degrees(np.abs(after.bias_rad_s[0] - rec.bias)).max() < 0.3


def test_a_new_magnetometer_calibration_leaves_a_filter_without_orientation_as_it_is():
    ekf = OrientationEKF()
    before = ekf.state.copy()
    ekf.magnetometer_changed()
    for name in ("q_world_from_sensor", "bias_rad_s", "cov", "aux"):
        assert np.array_equal(getattr(ekf.state, name), getattr(before, name))


def _unusable_rows(recording):
    """The recording with NaN, infinite, zero and out-of-range accelerometer and magnetometer
    rows in every phase of the filter, and the rows that must be counted for each channel."""
    gyr, acc, mag, t = (recording.gyr.copy(), recording.acc.copy(), recording.mag.copy(),
                        recording.t_s.copy())
    acc[0:3] = np.nan                                   # before the first orientation
    gyr[50], acc[50], mag[50] = np.nan, [np.inf, 0, 0], np.nan   # with a skipped gyro sample
    acc[300:310] = np.nan
    mag[400:405] = [0.0, -np.inf, 1.0]
    acc[500] = 0.0
    mag[600] = [1e5, 0.0, 0.0]
    t[700], mag[700] = t[699], np.nan                   # with a repeated time stamp
    acc_rows = [0, 1, 2, 50, *range(300, 310), 500]
    mag_rows = [50, *range(400, 405), 600, 700]
    return (t, gyr, acc, mag), acc_rows, mag_rows


@pytest.mark.parametrize("algorithm", sorted(ALGORITHMS))
def test_unusable_acc_and_mag_rows_are_counted_with_their_own_reason(recording, algorithm):
    """NaN/infinite/zero/out-of-range rows are refused and counted once, as ``acc_missing`` /
    ``mag_missing`` (not as disturbance rejections, whose flags the live view shows as
    "disturbed"), in every phase of the filter; every counter equals its flag's count."""
    inputs, acc_rows, mag_rows = _unusable_rows(recording)
    results = {"batch": fuse(*inputs, algorithm=algorithm),
               "offline": fuse_offline(*inputs, algorithm=algorithm)}
    ekf = OrientationEKF(algorithm=algorithm)
    cuts = [0, 2, 3, 50, 51, 305, 700, 701, len(inputs[0])]
    parts = [ekf.update_batch(*(x[a:b] for x in inputs)) for a, b in zip(cuts[:-1], cuts[1:])]
    results["blocks"] = FusionResult(np.concatenate([p.q_world_from_sensor for p in parts]),
                                     np.concatenate([p.bias_rad_s for p in parts]),
                                     np.concatenate([p.flags for p in parts]), parts[-1].counters)
    first, second = OrientationEKF(algorithm=algorithm), OrientationEKF(algorithm=algorithm)
    together = update_together([first, second], *(np.stack([x, x]) for x in inputs))
    results["together"] = FusionResult(together.q_world_from_sensor[1], together.bias_rad_s[1],
                                       together.flags[1], together.counters[1:])
    correcting = ALGORITHMS[algorithm][1]
    for name, result in results.items():
        masks = result.flag_masks()
        counters = result.counters[0]
        assert np.flatnonzero(masks["acc_missing"]).tolist() == acc_rows, name
        assert np.flatnonzero(masks["mag_missing"]).tolist() == mag_rows, name
        assert not (masks["acc_rejected"][acc_rows].any() or masks["mag_rejected"][mag_rows].any()), name
        for reason in ("skipped", "rest", "acc_rejected", "mag_rejected", "acc_missing", "mag_missing"):
            assert counters[reason] == masks[reason].sum(), (name, reason)
        assert (counters["acc_missing"], counters["mag_missing"], counters["skipped"]) == (15, 8, 2), name
        assert np.isfinite(result.q_world_from_sensor[3:]).all(), name
        if correcting:
            diff = rot.angle_between(result.q_world_from_sensor[-1], recording.q_true[-1])
            assert np.degrees(diff) < 3.0, name


def test_attitude_uncertainty_grows_with_the_angle_turned():
    """Without corrections the attitude variance grows by ``(σ_g² + k²·‖ω‖²)·dt`` a sample:
    white noise with the time, the scale-factor noise with the rate (a turn at 2 rad/s
    ends more uncertain than the same time at rest)."""
    params = replace(DEFAULT_FUSION_PARAMS, gyr_noise_rad_s_sqrt_hz=0.002, gyr_scale_noise_sqrt_s=0.001,
                     init_bias_std_rad_s=1e-9, bias_walk_rad_s_sqrt_s=0.0)  # no bias uncertainty
    dt, n = 0.01, 201
    t = np.arange(n) * dt
    variances = {}
    for rate in (0.0, 2.0):
        gyr = np.zeros((n, 3))
        gyr[:, 2] = rate
        ekf = OrientationEKF(params, algorithm="ekf-taylor3", use_mag=False)
        ekf.update_batch(t, gyr)  # no accelerometer: starts at the identity, nothing corrects
        variances[rate] = ekf.state.attitude_std_rad()[0] ** 2
    init = DEFAULT_FUSION_PARAMS.init_tilt_std_rad ** 2
    duration = t[-1]
    assert variances[0.0] - init == pytest.approx(params.gyr_noise_rad_s_sqrt_hz ** 2 * duration, rel=1e-3)
    expected_extra = params.gyr_scale_noise_sqrt_s ** 2 * 2.0 ** 2 * duration
    assert variances[2.0] - variances[0.0] == pytest.approx(expected_extra, rel=1e-3)


@pytest.mark.parametrize("field_world_uT", [(0.0, 15.4, -42.3), (12.0, -9.0, -38.0), (-5.0, 20.0, 30.0)])
def test_heading_tilt_jacobian_is_the_tilt_compensated_headings_derivative(field_world_uT):
    """The heading measured from a field the estimate sees turned back by a small tilt error,
    ``m_w = exp(−δθ)·m``, moves by ``h_x·δθ_x + h_y·δθ_y``: central differences agree, and a
    field pointing north with a dip of 70° gives ``h_y = tan 70°`` about the north axis."""
    from mimucap.core.fusion.kernels import heading_tilt_jacobian

    field = np.array(field_world_uT)

    def heading(tilt_rad):
        seen = rot.rotate(rot.from_rotvec(-np.asarray(tilt_rad)), field)
        return np.arctan2(seen[0], seen[1])

    step = 1e-6
    numeric = [(heading(step * axis) - heading(-step * axis)) / (2 * step) for axis in np.eye(3)[:2]]
    assert heading_tilt_jacobian(*field) == pytest.approx(numeric, rel=1e-6, abs=1e-9)
    dip = np.radians(70.0)
    north = 45.0 * np.array([0.0, np.cos(dip), -np.sin(dip)])
    assert heading_tilt_jacobian(*north) == pytest.approx((0.0, np.tan(dip)), abs=1e-12)


def test_a_tilt_error_the_accelerometer_corrects_takes_its_heading_error_with_it():
    """A sensor at rest, field dip 70°, aligned from a first accelerometer sample knocked by 5°
    about the north axis: the tilt-compensated heading starts 5°·tan 70° = 13.7° off. The
    accelerometer corrects the tilt within a fraction of a second; the heading error the tilt
    caused goes with it (the measurement row's tilt terms correlate the two): within 0.4° after
    2 s (0.6° when the heading measurement ignores the tilt, converging with the heading's own
    time constant)."""
    rate_hz, n = 100.0, 501
    t = np.arange(n) / rate_hz
    dip = np.radians(70.0)
    field = 45.0 * np.array([0.0, np.cos(dip), -np.sin(dip)])
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    acc[0] = rot.rotate(rot.from_rotvec([0.0, np.radians(5.0), 0.0]), acc[0])
    result = fuse(t, np.zeros((n, 3)), acc, np.tile(field, (n, 1)))
    _total, heading, _tilt = error_angles_rad(result.q_world_from_sensor, rot.identity((n,)))
    heading_error = np.degrees(heading)
    assert heading_error[0] == pytest.approx(5.0 * np.tan(dip), abs=0.3)
    assert heading_error[int(2 * rate_hz)] < 0.4
