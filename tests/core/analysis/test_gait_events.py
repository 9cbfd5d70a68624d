"""Gait events, strides and parameters on synthetic signals with known contacts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mimucap.core.analysis.gait_events import EventSettings, detect_swing_events
from mimucap.core.analysis.gait_parameters import gait_parameters, symmetry_index
from mimucap.core.analysis.sagittal import dominant_axis, sagittal_rate_calibrated
from mimucap.core.analysis.strides import Stride, bouts_and_turns, classify, pair_strides
from mimucap.core import rotation as rot

RATE = 200.0


def foot_like_rate(ics, fcs, t):
    """A foot's sagittal rate: a push-off dip (minimum at each FC), a swing hump from just
    after FC to its IC (zero crossing there, positive before), a heel-rocker dip after IC."""
    rate = np.zeros_like(t)
    for fc, ic in zip(fcs, ics):
        rate -= 6.0 * np.exp(-((t - fc) / 0.04) ** 2)
        swing = (t > fc + 0.05) & (t < ic)
        x = (t[swing] - fc - 0.05) / (ic - fc - 0.05)
        rate[swing] += 5.0 * np.sin(np.pi * x) ** 0.7
        rate -= 3.0 * np.exp(-((t - ic - 0.06) / 0.03) ** 2) * (t > ic)
    return rate


def test_foot_events_are_found_at_their_instants():
    t = np.arange(0, 12, 1 / RATE)
    period = 1.1
    ics = 1.5 + period * np.arange(1, 9)
    fcs = ics - 0.42
    events = detect_swing_events(t, foot_like_rate(ics, fcs, t), "foot")
    assert len(events) == len(ics)
    np.testing.assert_allclose(events.t_ic_s, ics, atol=0.006)
    np.testing.assert_allclose(events.t_fc_s, fcs, atol=0.006)


def test_quiet_standing_and_small_sway_give_no_swing():
    t = np.arange(0, 10, 1 / RATE)
    rng = np.random.default_rng(1)
    rate = 0.3 * np.sin(2 * np.pi * 0.4 * t) + rng.normal(scale=0.05, size=t.size)
    assert len(detect_swing_events(t, rate, "foot")) == 0


def test_dropped_samples_do_not_shift_the_events():
    t = np.arange(0, 8, 1 / RATE)
    ics = np.array([2.0, 3.1, 4.2, 5.3, 6.4])
    fcs = ics - 0.42
    rate = foot_like_rate(ics, fcs, t)
    keep = np.random.default_rng(3).random(t.size) > 0.1
    events = detect_swing_events(t[keep], rate[keep], "foot")
    np.testing.assert_allclose(events.t_ic_s, ics, atol=0.01)


@pytest.mark.parametrize("bad, message", [
    (lambda t, r: (t[::-1], r), "do not increase"),
    (lambda t, r: (t, np.where(np.arange(r.size) == 5, np.nan, r)), "NaN"),
    (lambda t, r: (t, r[:-1]), "rate samples"),
])
def test_bad_input_is_refused_with_a_clear_message(bad, message):
    t = np.arange(0, 2, 1 / RATE)
    args = bad(t, np.zeros_like(t))
    with pytest.raises(ValueError, match=message):
        detect_swing_events(*args, "shank")
    with pytest.raises(ValueError, match="placement"):
        detect_swing_events(t, np.zeros_like(t), "wrist")
    with pytest.raises(ValueError, match="positive"):
        EventSettings(min_swing_peak_rad_s=-1.0)


def test_calibrated_sagittal_rate_is_the_segment_z_rate():
    q_segment_from_sensor = rot.from_axis_angle(np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8]), 1.1)
    omega_segment = np.zeros((50, 3))
    omega_segment[:, 2] = np.linspace(-3, 3, 50)
    omega_sensor = rot.rotate(rot.conjugate(q_segment_from_sensor), omega_segment)
    np.testing.assert_allclose(sagittal_rate_calibrated(omega_sensor, q_segment_from_sensor), omega_segment[:, 2], atol=1e-12)


def test_dominant_axis_finds_the_flexion_axis_and_the_swing_sign():
    t = np.arange(0, 10, 1 / RATE)
    ics = 1.0 + 1.1 * np.arange(1, 8)
    rate = foot_like_rate(ics, ics - 0.42, t)
    axis_in_sensor = np.array([0.6, 0.0, -0.8])
    gyr = rate[:, None] * axis_in_sensor + np.random.default_rng(2).normal(scale=0.05, size=(t.size, 3))
    found = dominant_axis(gyr)
    assert found @ axis_in_sensor > 0.99


def strides_of(ics, fcs, side):
    return pair_strides(side, np.asarray(ics), np.asarray(fcs))


def test_parameters_of_a_regular_symmetric_gait():
    # Right IC every 1.0 s, left half a cycle later, stance 60 %, double support 2 × 10 %.
    right_ic = np.arange(0.0, 8.0, 1.0)
    left_ic = right_ic + 0.5
    strides = strides_of(right_ic, right_ic - 0.4, "right") + strides_of(left_ic, left_ic - 0.4, "left")
    strides = [s.__class__(**{**s.__dict__, "stride_length_m": 1.3}) for s in strides]
    strides = classify(strides)
    p = gait_parameters(strides)
    assert p.get("stride_time", "both").mean == pytest.approx(1.0)
    assert p.get("cadence", "both").mean == pytest.approx(120.0)
    assert p.get("step_time", "left").mean == pytest.approx(0.5)
    assert p.get("stance", "right").mean == pytest.approx(60.0)
    assert p.get("double_support", "right").mean == pytest.approx(20.0)
    assert p.get("gait_speed", "both").mean == pytest.approx(1.3)
    assert p.get("stride_time", "both").cv_percent == pytest.approx(0.0, abs=1e-9)
    assert p.symmetry_percent["stride_time"] == pytest.approx(0.0)
    assert symmetry_index(1.0, 1.2) == pytest.approx(100 * 0.2 / 1.1)


def test_refused_strides_say_why_and_turns_and_bouts_are_found():
    ics = [0.0, 1.0, 2.0, 3.0, 4.0, 7.5, 8.5, 9.5]
    strides = strides_of(ics, [i - 0.4 for i in ics], "right")
    turned = {2: 120.0}
    strides = [Stride(s.side, s.ic_s, s.fc_s, s.next_ic_s, 1.2, turned.get(k, 2.0)) for k, s in enumerate(strides)]
    strides = classify(strides)
    reasons = {round(s.ic_s, 1): s.refused_because for s in strides}
    assert "turning" in reasons[2.0] and "+120" in reasons[2.0]
    assert "not one stride" in reasons[4.0]
    assert "ends the walk" in reasons[3.0]
    assert "ends the walk" in reasons[8.5]
    assert reasons[0.0] == "" and reasons[7.5] == ""
    numbered, bouts, turns = bouts_and_turns(strides)
    assert [(b.start_s, b.end_s) for b in bouts] == [(0.0, 4.0), (7.5, 9.5)]
    assert len(turns) == 1 and turns[0].angle_deg == pytest.approx(120.0)
    assert math.isnan(gait_parameters(strides).get("stride_time", "left").mean)


def test_turns_are_found_in_a_continuous_heading_and_stride_sway_is_not_one():
    from mimucap.core.analysis.turns import find_turns

    t = np.arange(0, 30, 0.01)
    sway = np.radians(5.0) * np.sin(2 * np.pi * t / 1.1)  # the pelvis's rotation within each stride
    turn = np.pi * np.clip((t - 12.0) / 2.5, 0.0, 1.0)     # 180° to the left over 2.5 s
    found = find_turns(t, sway + turn)
    assert len(found) == 1
    assert found[0].angle_deg == pytest.approx(180.0, abs=12.0)
    assert 11.0 < found[0].start_s < 12.5 and 14.5 < found[0].end_s < 16.0
    assert find_turns(t, sway) == []
    # A stride mostly inside the turn is refused as turning.
    strides = classify([Stride("left", 12.5, 13.1, 13.6, 1.0, 10.0), Stride("left", 13.6, 14.2, 14.7, 1.0, 10.0),
                        Stride("left", 14.7, 15.3, 15.8, 1.0, 10.0)], turns=found)
    assert "inside the turn" in strides[0].refused_because


# -- the heel strike's impact ----------------------------------------------------------------
def impact_acceleration(t, impacts, size=60.0):
    """A smooth swing-like sagittal acceleration (N, 2) m/s² (antero-posterior, vertical) with
    an impact at each of ``impacts``: the vertical acceleration jumps by ``size`` within 2 ms
    and decays over 10 ms, the antero-posterior one by half of it, backwards."""
    acc = np.stack((15.0 * np.sin(2 * np.pi * t / 1.1), 9.81 + 8.0 * np.cos(2 * np.pi * t / 1.1)), axis=-1)
    for t0 in impacts:
        after = t - t0
        shape = np.where(after >= 0, np.clip(after / 0.002, 0, 1) * np.exp(-np.clip(after - 0.002, 0, None) / 0.01), 0.0)
        acc += size * shape[:, None] * np.array([-0.5, 1.0])
    return acc


@pytest.mark.parametrize("rate", [100.0, 102.4, 204.8, 1000.0])
def test_the_impact_is_timed_within_a_sample_at_any_rate(rate):
    from mimucap.core.analysis.heel_strike import impact_time

    t = np.arange(0, 3, 1 / rate)
    onset = 1.2345
    acc = impact_acceleration(t, [onset])
    found = impact_time(t, acc, int(1.0 * rate), int(1.5 * rate), rate, 2 * 9.81, 0.01)
    tolerance = 1.0 / rate + 0.001   # a sample interval, and half of the impact's rise
    assert abs(found - onset) <= tolerance
    # A later, larger impact in the window (the forefoot landing) does not move it.
    acc_two = impact_acceleration(t, [onset]) + impact_acceleration(t, [onset + 0.08], size=200.0) - impact_acceleration(t, [])
    assert abs(impact_time(t, acc_two, int(1.0 * rate), int(1.5 * rate), rate, 2 * 9.81, 0.01) - onset) <= tolerance
    # Smooth limb movement alone is no impact.
    assert math.isnan(impact_time(t, impact_acceleration(t, []), int(1.0 * rate), int(1.5 * rate), rate, 2 * 9.81, 0.01))


def test_initial_contact_is_the_impact_where_the_acceleration_shows_one():
    t = np.arange(0, 12, 1 / RATE)
    ics = 1.5 + 1.1 * np.arange(1, 9)
    fcs = ics - 0.42
    rate = foot_like_rate(ics, fcs, t)
    strikes = ics + 0.06   # the heel lands after the foot's highest pitch (a flat approach)
    events = detect_swing_events(t, rate, "foot", sagittal_acc=impact_acceleration(t, strikes))
    np.testing.assert_allclose(events.t_ic_s, strikes, atol=1.0 / RATE)
    assert events.ic_at_impact.all()
    np.testing.assert_allclose(events.t_fc_s, fcs, atol=0.006)
    # Without an impact the end of the forward rotation stays the contact.
    smooth = detect_swing_events(t, rate, "foot", sagittal_acc=impact_acceleration(t, []))
    np.testing.assert_allclose(smooth.t_ic_s, ics, atol=0.006)
    assert not smooth.ic_at_impact.any()
    with pytest.raises(ValueError, match="sagittal acceleration"):
        detect_swing_events(t, rate, "foot", sagittal_acc=np.zeros((t.size, 3)))


def test_sagittal_axes_are_found_in_the_samples_of_a_turned_sensor():
    """A foot sensor turned by an unknown mounting: the flexion axis is the dominant rotation,
    the vertical is gravity while the foot is quietest, the anterior axis completes them."""
    from mimucap.core.analysis.sagittal import axes_calibrated, axes_from_data

    t = np.arange(0, 10, 1 / RATE)
    ics = 1.0 + 1.1 * np.arange(1, 8)
    rate = foot_like_rate(ics, ics - 0.42, t)
    # Foot frame: x anterior, y up, z right (ISB); the foot pitches about z. At rest the
    # accelerometer reads gravity alone, in motion also the swing's acceleration.
    moving = np.abs(rate) > 0.05
    acc_foot = np.stack((6.0 * np.sin(2 * np.pi * t / 1.1) * moving, 9.81 + 4.0 * np.cos(2 * np.pi * t / 0.55) * moving,
                         np.zeros_like(t)), axis=-1)
    gyr_foot = np.stack((np.zeros_like(t), np.zeros_like(t), rate), axis=-1)
    q_foot_from_sensor = rot.from_axis_angle(np.array([0.2, 0.9, -0.4]) / np.linalg.norm([0.2, 0.9, -0.4]), 2.2)
    q_sensor_from_foot = rot.conjugate(q_foot_from_sensor)
    acc, gyr = rot.rotate(q_sensor_from_foot, acc_foot), rot.rotate(q_sensor_from_foot, gyr_foot)
    found = axes_from_data(acc, gyr, RATE)
    known = axes_calibrated(q_foot_from_sensor)
    assert found.mediolateral @ known.mediolateral > np.cos(np.radians(2.0))
    assert found.anterior @ known.anterior > np.cos(np.radians(5.0))
    np.testing.assert_allclose(known.rate(gyr), rate, atol=1e-9)
    np.testing.assert_allclose(known.acceleration(acc), acc_foot[:, :2], atol=1e-9)
    with pytest.raises(ValueError, match="gravity is missing"):
        axes_from_data(np.zeros_like(acc), gyr, RATE)
