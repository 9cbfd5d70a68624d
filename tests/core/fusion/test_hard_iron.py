"""The hard-iron offset learned during a recording (:mod:`mimucap.core.fusion.hard_iron`): a
magnet fixed to a tumbling sensor is found, removed and flagged; a field that changes in the
world, or no change at all, never gives an offset; block-wise feeding equals one batch."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.core.fusion.ekf import OrientationEKF, fuse
from mimucap.core.fusion.evaluation import error_angles_rad
from mimucap.core.fusion.params import DEFAULT_FUSION_PARAMS, FusionParams
from mimucap.core.simulate.hand_held import calibration_motion

#: The magnet: its field at the sensor (µT, sensor frame) and when it is fixed to the sensor.
MAGNET_UT = np.array([20.0, -15.0, 20.0])
ATTACHED_S = 15.0
TRACKING_OFF = replace(DEFAULT_FUSION_PARAMS, mag_offset_tau_s=0.0)
#: Every field sample used as it is: no tracking, no gate, no heading noise from the field's quality.
OPEN_GATE = replace(TRACKING_OFF, mag_norm_tol=100.0, mag_dip_tol_rad=4.0, heading_field_error_gain=0.0)


def rms_deg(x: np.ndarray) -> float:
    return float(np.degrees(np.sqrt(np.mean(x ** 2))))


@pytest.fixture(scope="module", params=[1, 2], ids=["seed1", "seed2"])
def tumbling(request):
    """A hand-held sensor tumbling for 50 s at 100 Hz, its magnetometer calibrated (no hard or
    soft iron of its own); from :data:`ATTACHED_S` on a magnet adds :data:`MAGNET_UT`."""
    motion = calibration_motion("tumble", turns=5, seed=request.param, mag_A=np.eye(3),
                                mag_b_uT=np.zeros(3))
    mag = motion.mag_uT.copy()
    mag[motion.t_s >= ATTACHED_S] += MAGNET_UT
    return motion, mag


def test_an_attached_magnet_is_learned_removed_and_flagged(tumbling):
    motion, mag = tumbling
    t = motion.t_s
    ekf = OrientationEKF()
    result = ekf.update_batch(t, motion.gyr, motion.acc, mag)
    flagged = result.flag_masks()["mag_offset"]
    assert not flagged[t < ATTACHED_S].any()
    learned = t[flagged][0]
    assert learned < ATTACHED_S + 15.0
    assert flagged[t > learned].all()
    assert np.linalg.norm(ekf.state.magnetic_offset() - MAGNET_UT) < 0.5
    counters = ekf.counters()
    assert counters["mag_new_offset"] == 1 and counters["mag_offset"] == flagged.sum()
    # with the offset removed the field passes the checks again and holds the heading as well
    # as the same field without the magnet does
    after = t > learned + 1.0
    assert result.flag_masks()["mag_rejected"][after].mean() < 0.1
    _, heading, _ = error_angles_rad(result.q_world_from_sensor, motion.q_world_from_sensor)
    _, heading_clean, _ = error_angles_rad(fuse(t, motion.gyr, motion.acc, motion.mag_uT).q_world_from_sensor,
                                           motion.q_world_from_sensor)
    assert rms_deg(heading[after]) < rms_deg(heading_clean[after]) + 0.2
    # without the tracking the magnet's field is rejected throughout and nothing is flagged;
    # were it used as it is, it would turn the heading off: the test is not empty
    off = fuse(t, motion.gyr, motion.acc, mag, params=TRACKING_OFF)
    assert off.flag_masks()["mag_rejected"][after].mean() > 0.95
    assert not off.flag_masks()["mag_offset"].any()
    _, heading_open, _ = error_angles_rad(fuse(t, motion.gyr, motion.acc, mag, params=OPEN_GATE).q_world_from_sensor,
                                          motion.q_world_from_sensor)
    # the magnet matters: left in, it leaves the heading clearly worse (1.9-3x on the seeds here)
    assert rms_deg(heading_open[after]) > 1.5 * rms_deg(heading[after])

def test_no_offset_without_a_magnet(tumbling):
    motion, _ = tumbling
    ekf = OrientationEKF()
    result = ekf.update_batch(motion.t_s, motion.gyr, motion.acc, motion.mag_uT)
    assert not result.flag_masks()["mag_offset"].any()
    assert ekf.state.magnetic_offset() is None
    assert ekf.counters()["mag_new_offset"] == 0


def test_a_field_that_changes_in_the_world_is_no_offset(tumbling):
    """A uniform change of the field (the sensor carried to another place) is fixed in the
    world, not in the sensor: it does not fit a constant sensor-frame offset. It is rejected,
    and, as it stays homogeneous while the sensor turns, becomes the new reference; never an
    offset."""
    motion, _ = tumbling
    t = motion.t_s
    rotated = rot.rotate(rot.conjugate(motion.q_world_from_sensor), np.array([20.0, -10.0, 15.0]))
    mag = motion.mag_uT + np.where((t >= ATTACHED_S)[:, None], rotated, 0.0)
    result = fuse(t, motion.gyr, motion.acc, mag)
    assert not result.flag_masks()["mag_offset"].any()
    assert result.flag_masks()["mag_rejected"][(t > ATTACHED_S + 1.0) & (t < ATTACHED_S + 15.0)].all()
    assert result.counters[0]["mag_new_reference"] == 1


def test_blocks_equal_one_batch_while_an_offset_is_learned(tumbling):
    motion, mag = tumbling
    t = motion.t_s
    batch_ekf = OrientationEKF()
    batch = batch_ekf.update_batch(t, motion.gyr, motion.acc, mag)
    ekf = OrientationEKF()
    cuts = [0, 7, 1500, 1501, 2900, len(t)]
    parts = [ekf.update_batch(t[a:b], motion.gyr[a:b], motion.acc[a:b], mag[a:b])
             for a, b in zip(cuts[:-1], cuts[1:])]
    assert np.array_equal(np.concatenate([p.q_world_from_sensor for p in parts]), batch.q_world_from_sensor)
    assert np.array_equal(np.concatenate([p.flags for p in parts]), batch.flags)
    assert np.array_equal(ekf.state.aux, batch_ekf.state.aux)


def test_a_new_calibration_forgets_the_offset(tumbling):
    motion, mag = tumbling
    ekf = OrientationEKF()
    ekf.update_batch(motion.t_s, motion.gyr, motion.acc, mag)
    assert ekf.state.magnetic_offset() is not None
    ekf.magnetometer_changed()
    assert ekf.state.magnetic_offset() is None
    assert ekf.counters()["mag_new_offset"] == 1  # the counts stay


def test_offset_settings_are_validated():
    for name in ("mag_offset_fit_uT", "mag_offset_std_uT"):
        with pytest.raises(ValueError, match=name):
            FusionParams(**{name: 0.0})
    with pytest.raises(ValueError, match="mag_offset_tau_s"):
        FusionParams(mag_offset_tau_s=-1.0)

