"""Disturbance handling on simulated suits (``mimucap.core.simulate``): a magnetic episode is
rejected and never tilts the estimate; strong linear acceleration does not tilt it either."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.core.fusion.ekf import fuse
from mimucap.core.fusion.evaluation import error_angles_rad
from mimucap.core.fusion.params import DEFAULT_FUSION_PARAMS
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import simulate_session
from mimucap.core.simulate.magnetic_field import MagneticDisturbance

EPISODE_S = (25.0, 40.0)
#: Every field sample accepted at full weight: no gate, no heading noise from the field's quality.
NO_GATE = replace(DEFAULT_FUSION_PARAMS, mag_norm_tol=100.0, mag_dip_tol_rad=4.0,
                  heading_field_error_gain=0.0)


def rms_deg(x: np.ndarray) -> float:
    return float(np.degrees(np.sqrt(np.nanmean(x ** 2))))


def simulated(disturbed: bool):
    """The demo scenario (standing, walking, turning, ...) for three sensors, 60 s at 100 Hz,
    magnetometers calibrated with their true hard/soft iron; returns per sensor
    ``(t, gyr, acc, mag_uT, q_true)``."""
    episodes = (MagneticDisturbance((30.0, 0.0, -15.0), *EPISODE_S),) if disturbed else ()
    result = simulate_session(SimulationConfig(scenario="demo", duration_s=60.0, n_sensors=3,
                                               rate_hz=100.0, seed=3, disturbances=episodes))
    streams = {}
    for sensor_id, samples in result.samples.items():
        parameters = result.parameters[sensor_id]
        mag = np.linalg.solve(parameters.mag_A, (samples.mag_uT - parameters.mag_b_uT).T).T
        index = np.searchsorted(result.truth.t_s, samples.t_s)
        streams[sensor_id] = (samples.t_s, samples.gyr, samples.acc, mag,
                              result.truth.q_world_from_sensor[sensor_id][index])
    return streams


@pytest.fixture(scope="module")
def clean():
    return simulated(False)


@pytest.fixture(scope="module")
def disturbed():
    return simulated(True)


def test_walking_and_turning_errors(clean):
    for sensor_id, (t, gyr, acc, mag, q_true) in clean.items():
        result = fuse(t, gyr, acc, mag)
        _, heading, incl = error_angles_rad(result.q_world_from_sensor, q_true)
        settled = t > 5.0
        assert rms_deg(heading[settled]) < 2.5, sensor_id
        assert rms_deg(incl[settled]) < 1.5, sensor_id


def test_magnetic_episode_is_rejected(disturbed):
    for sensor_id, (t, gyr, acc, mag, q_true) in disturbed.items():
        episode = (t > EPISODE_S[0] + 1.0) & (t < EPISODE_S[1] - 1.0)
        gated = fuse(t, gyr, acc, mag)
        open_gate = fuse(t, gyr, acc, mag, params=NO_GATE)
        _, heading, _ = error_angles_rad(gated.q_world_from_sensor, q_true)
        _, heading_open, _ = error_angles_rad(open_gate.q_world_from_sensor, q_true)
        assert gated.flag_masks()["mag_rejected"][episode].mean() > 0.95, sensor_id
        assert not gated.flag_masks()["mag_rejected"][(t > 5) & (t < EPISODE_S[0] - 1)].any()
        assert rms_deg(heading[episode]) < 3.0, sensor_id
        # without rejection the same episode pulls the heading far off: the test is not empty
        assert rms_deg(heading_open[episode]) > 10.0, sensor_id


def test_field_quality_weighs_accepted_disturbed_samples(disturbed):
    """With the gate open, the heading noise that grows with the field's distance from its
    reference still keeps a disturbance from pulling the heading as far as full weight does."""
    for sensor_id, (t, gyr, acc, mag, q_true) in disturbed.items():
        episode = (t > EPISODE_S[0] + 1.0) & (t < EPISODE_S[1] - 1.0)
        weighted = fuse(t, gyr, acc, mag, params=replace(NO_GATE, heading_field_error_gain=2.0))
        full = fuse(t, gyr, acc, mag, params=NO_GATE)
        _, heading_weighted, _ = error_angles_rad(weighted.q_world_from_sensor, q_true)
        _, heading_full, _ = error_angles_rad(full.q_world_from_sensor, q_true)
        assert rms_deg(heading_weighted[episode]) < 0.5 * rms_deg(heading_full[episode]), sensor_id


def test_magnetometer_never_tilts(disturbed, clean):
    """Heading-only magnetometer update: even an accepted disturbance leaves the tilt alone."""
    for sensor_id, (t, gyr, acc, mag, q_true) in disturbed.items():
        open_gate = fuse(t, gyr, acc, mag, params=NO_GATE)
        reference = fuse(t, gyr, acc, clean[sensor_id][3], params=NO_GATE)
        _, _, incl_open = error_angles_rad(open_gate.q_world_from_sensor, q_true)
        _, _, incl_ref = error_angles_rad(reference.q_world_from_sensor, q_true)
        episode = (t > EPISODE_S[0]) & (t < EPISODE_S[1])
        assert rms_deg(incl_open[episode]) < rms_deg(incl_ref[episode]) + 0.5, sensor_id


def test_new_steady_field_is_adopted(recording_factory):
    """A permanent change (the subject moved to another room) is accepted after
    ``mag_new_field_s`` of a steady new field instead of locking the magnetometer out."""
    rec = recording_factory(duration_s=60.0, seed=5)
    mag = rec.mag.copy()
    changed = rec.t_s > 10.0
    # the new place: 30 % weaker field, dip 15° steeper (beyond the tolerances), same north
    new_field = rot.rotate(rot.from_axis_angle([1, 0, 0], -np.radians(15.0)), [0.0, 20.0, -40.0]) * 0.7
    mag[changed] = rot.rotate(rot.conjugate(rec.q_true[changed]), new_field)
    mag[changed] += np.random.default_rng(0).normal(0, 0.2, mag[changed].shape)
    result = fuse(rec.t_s, rec.gyr, rec.acc, mag)
    rejected = result.flag_masks()["mag_rejected"]
    settle = DEFAULT_FUSION_PARAMS.mag_new_field_s
    assert rejected[(rec.t_s > 10.5) & (rec.t_s < 10.0 + settle - 1.0)].mean() > 0.9
    assert not rejected[rec.t_s > 10.0 + settle + 2.0].any()
    assert result.counters[0]["mag_new_reference"] == 1


def test_strong_linear_acceleration_does_not_tilt(recording_factory):
    """Horizontal shaking of ±6 m/s² (1.3 Hz) for 20 s: the low-passed world-frame specific
    force keeps the tilt within a degree."""
    rec = recording_factory(duration_s=30.0, seed=6)
    shake = np.zeros((rec.t_s.size, 3))
    active = (rec.t_s > 5) & (rec.t_s < 25)
    shake[active, 0] = 6.0 * np.sin(2 * np.pi * 1.3 * rec.t_s[active])
    shake[active, 1] = 4.0 * np.cos(2 * np.pi * 0.9 * rec.t_s[active])
    acc = rec.acc + rot.rotate(rot.conjugate(rec.q_true), shake)
    result = fuse(rec.t_s, rec.gyr, acc, rec.mag)
    _, _, incl = error_angles_rad(result.q_world_from_sensor, rec.q_true)
    assert rms_deg(incl[active]) < 1.0
    naive = fuse(rec.t_s, rec.gyr, acc, rec.mag,
                 params=replace(DEFAULT_FUSION_PARAMS, acc_lowpass_tau_s=0.005))
    _, _, incl_naive = error_angles_rad(naive.q_world_from_sensor, rec.q_true)
    assert rms_deg(incl_naive[active]) > 2.0 * rms_deg(incl[active])


def test_resting_next_to_a_magnet_does_not_adopt_its_field(recording_factory):
    """A still sensor beside a magnet sees a steady but local field: without rotation it is
    never taken as the new reference, however long it lasts."""
    rec = recording_factory(duration_s=60.0, still_s=61.0, seed=9)
    mag = rec.mag.copy()
    near = (rec.t_s > 5.0) & (rec.t_s < 55.0)
    mag[near] += rot.rotate(rot.conjugate(rec.q_true[near]), [15.0, 0.0, 10.0])
    result = fuse(rec.t_s, rec.gyr, rec.acc, mag)
    rejected = result.flag_masks()["mag_rejected"]
    assert rejected[(rec.t_s > 5.5) & (rec.t_s < 55.0)].all()
    assert result.counters[0]["mag_new_reference"] == 0
    assert not rejected[rec.t_s > 57.0].any()


def test_accelerometer_noise_model():
    from mimucap.core.fusion.disturbance import acc_noise_var
    from mimucap.core.fusion.params import pack_params

    g = DEFAULT_FUSION_PARAMS.gravity_m_s2
    plain = pack_params(DEFAULT_FUSION_PARAMS)
    weighted = pack_params(replace(DEFAULT_FUSION_PARAMS, acc_deviation_gain=2.0,
                                   acc_rate_gain_m_s2_per_rad_s=1.0))
    base = acc_noise_var(plain, g, g, 0.0)
    assert base == pytest.approx((DEFAULT_FUSION_PARAMS.acc_noise_m_s2 / g) ** 2)
    # acceleration the low-pass has not averaged out (|‖a_lp‖ − g| = 2 m/s²) and fast turning
    assert acc_noise_var(weighted, g, g + 2.0, 0.0) == pytest.approx(base + (4.0 / g) ** 2)
    assert acc_noise_var(weighted, g, g, 3.0 ** 2) == pytest.approx(base + (3.0 / g) ** 2)
    # a knock far beyond the rejection threshold is not used at all
    assert acc_noise_var(plain, g + DEFAULT_FUSION_PARAMS.acc_reject_m_s2 + 1.0, g, 0.0) < 0.0
