"""Gait events that hold across sensor placements and sample rates: the gaitmap walk (real foot
IMUs, optical reference) as other sensors would have recorded it, the raw samples resampled
(102.4 and 100 Hz) and turned on the foot (20-45° about the mediolateral axis, 10-20° about the
vertical, both signs), analysed without knowing the mounting; figures per variant in
``bench/bench_gait.py`` and the README."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from mimucap.core import rotation as rot
from mimucap.core.analysis.sagittal import axes_from_data
from mimucap.io.gaitmap import read_foot_imu_csv
from mimucap.session.recorded.gait_validation import (
    GAITMAP_RATE_HZ,
    GAITMAP_VARIANTS,
    ImuVariant,
    compare,
    gaitmap_variant_analysis,
    imu_variant,
    straight_reference,
)

GAITMAP = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "gait" / "gaitmap_example"


@lru_cache(maxsize=None)
def analysed(variant: ImuVariant):
    return gaitmap_variant_analysis(GAITMAP, variant)


@pytest.mark.parametrize("variant", GAITMAP_VARIANTS, ids=lambda v: v.name)
def test_every_variant_finds_the_strides_their_contacts_and_lengths(variant):
    gait, reference = analysed(variant)
    straight = straight_reference(reference)
    figures = compare(gait.strides, straight).summary()
    assert figures["n_reference"] == 55
    assert figures["missed"] == 0 and figures["extra"] == 0
    # The initial contact is the heel strike's impact in (nearly) every swing.
    impacts = sum(int(e.ic_at_impact.sum()) for e in gait.events.values())
    assert impacts >= 0.9 * sum(len(e) for e in gait.events.values())
    assert figures["ic_median_ms"] <= 20.0
    assert figures["fc_median_ms"] <= 30.0
    assert figures["length_mae_cm"] <= 5.0


@pytest.mark.parametrize("variant", [v for v in GAITMAP_VARIANTS if v.turn_ml_deg or v.turn_vertical_deg],
                         ids=lambda v: v.name)
def test_turning_the_sensor_on_the_foot_changes_no_event(variant):
    """The mounting is found in the samples: a turned sensor gives the events of an untouched
    one recorded at the same rate, to well under a sample."""
    gait, _ = analysed(variant)
    untouched, _ = analysed(ImuVariant("untouched", rate_hz=variant.rate_hz))
    for side, events in gait.events.items():
        np.testing.assert_allclose(events.t_ic_s, untouched.events[side].t_ic_s, atol=1e-3)
        np.testing.assert_allclose(events.t_fc_s, untouched.events[side].t_fc_s, atol=1e-3)


def test_the_axes_found_turn_with_the_sensor():
    """The axes found in a turned sensor's samples are the untouched sensor's axes turned alike.
    They are the foot's functional axes: its rotation in gait is about the ankle's oblique axis,
    about 25° from the dataset's foot-frame y axis here, which the events do not mind."""
    feet = read_foot_imu_csv(GAITMAP / "imu_sample.csv", GAITMAP_RATE_HZ, "deg/s")
    variant = ImuVariant("turned", turn_ml_deg=-35.0, turn_vertical_deg=15.0)
    q_turned_from_sensor = rot.conjugate(rot.multiply(rot.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.radians(15.0)),
                                                      rot.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.radians(-35.0))))
    for imu in feet.values():
        untouched = axes_from_data(imu.acc, imu.gyr, GAITMAP_RATE_HZ)
        turned = imu_variant(imu, GAITMAP_RATE_HZ, variant)
        found = axes_from_data(turned.acc, turned.gyr, GAITMAP_RATE_HZ)
        for axis, before in ((found.mediolateral, untouched.mediolateral), (found.anterior, untouched.anterior)):
            expected = rot.rotate(q_turned_from_sensor, before)
            assert np.degrees(np.arccos(np.clip(axis @ expected, -1.0, 1.0))) < 0.5
        # Foot frame: y to the left, so the flexion axis (to the right) is near -y.
        assert untouched.mediolateral @ np.array([0.0, -1.0, 0.0]) > np.cos(np.radians(30.0))
        assert untouched.anterior @ np.array([1.0, 0.0, 0.0]) > np.cos(np.radians(30.0))


def test_resampling_keeps_the_recording_and_refuses_an_odd_ratio():
    feet = read_foot_imu_csv(GAITMAP / "imu_sample.csv", GAITMAP_RATE_HZ, "deg/s")
    imu = feet["left"]
    resampled = imu_variant(imu, GAITMAP_RATE_HZ, ImuVariant("100 Hz", rate_hz=100.0))
    assert resampled.t_s[-1] == pytest.approx(imu.t_s[-1], abs=0.02)
    # Band-limited resampling keeps the slow content: the mean over the walk is unchanged.
    np.testing.assert_allclose(resampled.acc.mean(axis=0), imu.acc.mean(axis=0), atol=0.05)
    with pytest.raises(ValueError, match="cannot resample"):
        imu_variant(imu, GAITMAP_RATE_HZ, ImuVariant("odd", rate_hz=77.7))
