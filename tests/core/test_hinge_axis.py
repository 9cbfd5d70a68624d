"""Hinge axes from two segments' movement: both estimators recover known axes, signs, angles."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core import hinge_axis as ha
from mimucap.core import rotation as rot

EX, EY, EZ = np.eye(3)


def deg(a, b):
    """Angle (deg) between two directions, whatever their signs."""
    return np.degrees(np.arccos(min(1.0, abs(float(np.dot(a, b)) / np.linalg.norm(a) / np.linalg.norm(b)))))


def hinge_motion(seed=1, n=800, secondary_deg=0.0):
    """Two sensors on segments joined by a hinge about segment z: the proximal segment tumbles
    (about every axis), the distal one turns about the hinge by a flexion of 0..70°. With
    ``secondary_deg`` the distal segment also turns about its long axis (y) in step with the
    flexion, as a knee does. Returns the orientations and the true axes in each sensor frame."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 100.0
    q_world_from_prox = rot.from_rotvec(np.column_stack((0.4 * np.sin(1.3 * t), 0.8 * np.sin(0.7 * t + 1.0),
                                                         0.3 * np.sin(2.1 * t))))
    flexion = np.radians(35.0 * (1.0 - np.cos(2 * np.pi * t / 1.1)))
    q_prox_from_dist = rot.multiply(rot.from_axis_angle(EZ, -flexion),
                                    rot.from_axis_angle(EY, np.radians(secondary_deg) * np.sin(2 * np.pi * t / 1.1)))
    q_world_from_dist = rot.multiply(q_world_from_prox, q_prox_from_dist)
    m1, m2 = rot.normalize(rng.normal(size=4)), rot.normalize(rng.normal(size=4))  # q_segment_from_sensor
    q1, q2 = rot.multiply(q_world_from_prox, m1), rot.multiply(q_world_from_dist, m2)
    j1, j2 = rot.rotate(rot.conjugate(m1), EZ), rot.rotate(rot.conjugate(m2), EZ)
    return t, q1, q2, j1, j2, flexion


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_both_estimators_recover_the_axes_of_a_hinge(seed):
    t, q1, q2, j1, j2, _ = hinge_motion(seed)
    a1, a2, offset = ha.fit_hinge_from_orientations(q1, q2)
    assert deg(a1, j1) < 1e-6 and deg(a2, j2) < 1e-6 and abs(offset) < 1e-9
    # the same direction in the world at every instant (the singular vectors come signed)
    assert np.all(np.sum(rot.rotate(q1, a1) * rot.rotate(q2, a2), axis=1) > 0.999999)
    index, w1 = ha.angular_rates(t, q1)
    _, w2 = ha.angular_rates(t, q2)
    assert index.shape == (t.size - 1,)
    b1, b2 = ha.fit_hinge_from_rates(w1, w2)
    assert deg(b1, j1) < 0.01 and deg(b2, j2) < 0.01


def test_secondary_rotation_in_step_with_flexion_pulls_the_rate_constraint_not_the_orientation_one():
    """The distal segment also turns ±5° about its long axis in step with the flexion (as a knee
    does): the orientation estimator stays within 0.5° in both sensors; Seel et al.'s rate
    constraint keeps the distal axis but tilts the proximal one by several degrees (the thigh's
    on the simulated walk, hinge_axis module docstring)."""
    t, q1, q2, j1, j2, _ = hinge_motion(4, secondary_deg=5.0)
    a1, a2, _ = ha.fit_hinge_from_orientations(q1, q2)
    assert deg(a1, j1) < 0.5 and deg(a2, j2) < 0.5
    _, w1 = ha.angular_rates(t, q1)
    _, w2 = ha.angular_rates(t, q2)
    b1, b2 = ha.fit_hinge_from_rates(w1, w2)
    assert deg(b2, j2) < 0.5 and deg(b1, j1) > 5.0


@pytest.mark.parametrize(("offset_deg", "up"), [(7.0, EZ), (-40.0, EZ), (25.0, EY)])
def test_a_heading_disagreement_between_the_sensors_is_found_and_left_out(offset_deg, up):
    """The second sensor's heading is off by a constant turn about the world's up (its own
    magnetometer, its own filter): the axes are found as if it were not, and the turn with them."""
    _, q1, q2, j1, j2, _ = hinge_motion(7)
    turned = rot.multiply(rot.from_axis_angle(up, np.radians(offset_deg)), q2)
    a1, a2, offset = ha.fit_hinge_from_orientations(q1, turned, up)
    assert deg(a1, j1) < 1e-6 and deg(a2, j2) < 1e-6
    assert np.degrees(offset) == pytest.approx(-offset_deg, abs=1e-6)
    world1, world2 = rot.rotate(q1, j1), rot.rotate(turned, j2)
    assert np.degrees(ha.heading_offset_rad(world1, world2, up)) == pytest.approx(-offset_deg, abs=1e-6)


def test_angular_rates_of_a_steady_turn():
    t = np.arange(50) * 0.01
    q = rot.from_axis_angle(EX, 2.0 * t)
    index, rates = ha.angular_rates(t, q)
    np.testing.assert_allclose(rates, np.tile([2.0, 0.0, 0.0], (49, 1)), atol=1e-9)
    q[10] = np.nan
    index, rates = ha.angular_rates(t, q)
    assert 9 not in index and 10 not in index and rates.shape == (47, 3)


def test_consistent_signs_and_the_hinge_angle():
    _, q1, q2, j1, j2, flexion = hinge_motion(5)
    turned, residual = ha.consistent_signs(j1, -j2, q1, q2)
    np.testing.assert_allclose(turned, j2, atol=1e-12)
    assert residual < 1e-6
    reference = rot.multiply(rot.conjugate(q1[0]), q2[0])
    angle = ha.hinge_angle_rad(j1, q1, q2, reference)
    # the distal segment turns by -flexion about +z (a knee bending backwards)
    np.testing.assert_allclose(angle, -(flexion - flexion[0]), atol=1e-9)


def test_bad_input_is_refused():
    t, q1, q2, *_ = hinge_motion(6, n=100)
    with pytest.raises(ValueError, match="at least 20 samples"):
        ha.fit_hinge_from_orientations(q1[:10], q2[:10])
    with pytest.raises(ValueError, match="same instants"):
        ha.fit_hinge_from_orientations(q1, q2[:50])
    with pytest.raises(ValueError, match="did not move"):
        ha.fit_hinge_from_rates(np.zeros((30, 3)), np.zeros((30, 3)))
    with pytest.raises(ValueError, match="non-finite"):
        ha.fit_hinge_from_rates(np.full((30, 3), np.nan), np.zeros((30, 3)))
    with pytest.raises(ValueError, match=r"\(N,\) times and \(N, 4\)"):
        ha.angular_rates(t, q1[:5])
