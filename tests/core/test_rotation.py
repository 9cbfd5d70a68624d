"""Rotation core: property tests against identities and against scipy's ``Rotation``."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from mimucap.core import rotation as rot

FINITE = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
QUATS = arrays(np.float64, (5, 4), elements=FINITE).filter(
    lambda a: np.all(np.linalg.norm(a, axis=-1) > 1e-3)
).map(rot.normalize)
VECS = arrays(np.float64, (5, 3), elements=st.floats(-10, 10, allow_nan=False))
ANGLES = arrays(np.float64, (5, 3), elements=st.floats(-3.0, 3.0, allow_nan=False))


def scipy_rotation(q: np.ndarray) -> Rotation:
    return Rotation.from_quat(q[..., [1, 2, 3, 0]])  # scipy is scalar-last


@given(QUATS, QUATS)
def test_multiply_agrees_with_scipy_composition(q1, q2):
    expected = (scipy_rotation(q1) * scipy_rotation(q2)).as_matrix()
    np.testing.assert_allclose(rot.to_matrix(rot.multiply(q1, q2)), expected, atol=1e-12)


@given(QUATS, VECS)
def test_rotate_agrees_with_scipy_and_matrix(q, v):
    np.testing.assert_allclose(rot.rotate(q, v), scipy_rotation(q).apply(v), atol=1e-10)
    np.testing.assert_allclose(rot.rotate(q, v), np.einsum("nij,nj->ni", rot.to_matrix(q), v), atol=1e-10)


@given(QUATS)
def test_matrix_round_trip(q):
    assert np.all(rot.angle_between(rot.from_matrix(rot.to_matrix(q)), q) < 1e-7)
    assert np.all(rot.angle_between(rot.from_matrix(scipy_rotation(q).as_matrix()), q) < 1e-7)
    assert np.all(rot.from_matrix(rot.to_matrix(q))[:, 0] >= 0.0)


@given(QUATS)
def test_inverse_and_identity(q):
    np.testing.assert_allclose(rot.canonical(rot.multiply(q, rot.inverse(q))), rot.identity((5,)), atol=1e-12)
    np.testing.assert_allclose(rot.multiply(rot.identity(), q), q, atol=1e-15)
    np.testing.assert_allclose(rot.conjugate(rot.conjugate(q)), q)


@given(QUATS, QUATS, QUATS)
def test_composition_is_associative_and_frames_chain(q_ab, q_bc, v_seed):
    q_ac = rot.multiply(q_ab, q_bc)
    v_c = v_seed[:, 1:]
    np.testing.assert_allclose(rot.rotate(q_ac, v_c), rot.rotate(q_ab, rot.rotate(q_bc, v_c)), atol=1e-12)


@given(QUATS)
def test_rotvec_round_trip_and_scipy(q):
    rv = rot.to_rotvec(q)
    away_from_pi = np.linalg.norm(rv, axis=-1) < np.pi - 1e-6  # at π, ±axis are both right
    np.testing.assert_allclose(rv[away_from_pi], scipy_rotation(q).as_rotvec()[away_from_pi], atol=1e-9)
    assert np.all(rot.angle_between(rot.from_rotvec(rv), q) < 1e-7)


def test_rotvec_small_angles_are_accurate():
    rv = np.array([[1e-12, 0, 0], [0, 3e-9, 0], [1e-5, -2e-5, 3e-5]])
    expected = Rotation.from_rotvec(rv).as_quat()[:, [3, 0, 1, 2]]
    np.testing.assert_allclose(rot.from_rotvec(rv), expected, rtol=1e-14, atol=1e-20)
    np.testing.assert_allclose(rot.to_rotvec(expected), rv, rtol=1e-10, atol=1e-22)


@given(QUATS)
def test_axis_angle_round_trip(q):
    axis, angle = rot.to_axis_angle(q)
    assert np.all((angle >= 0) & (angle <= np.pi + 1e-12))
    assert np.all(rot.angle_between(rot.from_axis_angle(axis, angle), q) < 1e-7)


@pytest.mark.parametrize("sequence", rot.EULER_SEQUENCES)
@given(q=QUATS)
def test_euler_round_trip_and_scipy(sequence, q):
    angles = rot.to_euler(q, sequence)
    assert np.all(rot.angle_between(rot.from_euler(angles, sequence), q) < 1e-7)
    np.testing.assert_allclose(rot.to_matrix(rot.from_euler(angles, sequence)), rot.euler_matrix(angles, sequence), atol=1e-12)
    with warnings.catch_warnings():  # scipy warns at its own gimbal lock; we compare elsewhere
        warnings.simplefilter("ignore", UserWarning)
        reference = scipy_rotation(q).as_euler(sequence)  # uppercase: intrinsic in scipy
    difference = np.angle(np.exp(1j * (angles - reference)))
    regular = np.abs(np.cos(angles[:, 1]) if sequence != "YXY" else np.sin(angles[:, 1])) > 1e-3
    np.testing.assert_allclose(difference[regular], 0.0, atol=1e-8)


@pytest.mark.parametrize("sequence", rot.EULER_SEQUENCES)
@given(angles=ANGLES)
def test_euler_from_angles_agrees_with_scipy(sequence, angles):
    expected = Rotation.from_euler(sequence, angles).as_matrix()
    np.testing.assert_allclose(rot.to_matrix(rot.from_euler(angles, sequence)), expected, atol=1e-12)


@pytest.mark.parametrize(
    ("sequence", "middle"),
    [("ZXY", np.pi / 2), ("ZXY", -np.pi / 2), ("XZY", np.pi / 2), ("XZY", -np.pi / 2), ("YXY", 0.0), ("YXY", np.pi)],
)
def test_euler_singular_cases_reconstruct_the_rotation(sequence, middle):
    rng = np.random.default_rng(3)
    first, third = rng.uniform(-1.2, 1.2, size=(2, 50))
    angles_in = np.stack((first, np.full(50, middle), third), axis=-1)
    q = rot.from_euler(angles_in, sequence)
    angles = rot.to_euler(q, sequence)
    assert np.all(rot.angle_between(rot.from_euler(angles, sequence), q) < 1e-6)
    np.testing.assert_allclose(angles[:, 2], 0.0)
    assert np.all(np.isfinite(angles))


def test_euler_rejects_unknown_sequence():
    with pytest.raises(ValueError, match="unsupported Euler sequence"):
        rot.to_euler(rot.identity(), "ZYZ")


@given(QUATS, QUATS, st.floats(0.0, 1.0))
def test_slerp_endpoints_and_constant_speed(q0, q1, t):
    np.testing.assert_allclose(rot.angle_between(rot.slerp(q0, q1, 0.0), q0), 0.0, atol=1e-7)
    assert np.all(rot.angle_between(rot.slerp(q0, q1, 1.0), q1) < 1e-6)
    total = rot.angle_between(q0, q1)
    np.testing.assert_allclose(rot.angle_between(q0, rot.slerp(q0, q1, t)), t * total, atol=1e-6)


@given(QUATS, QUATS)
def test_angle_between_is_sign_invariant_and_matches_scipy(q1, q2):
    expected = (scipy_rotation(q1).inv() * scipy_rotation(q2)).magnitude()
    np.testing.assert_allclose(rot.angle_between(q1, q2), expected, atol=1e-7)
    np.testing.assert_allclose(rot.angle_between(q1, -q2), expected, atol=1e-7)


def test_average_is_sign_robust_and_recovers_the_mean():
    rng = np.random.default_rng(7)
    mean = rot.normalize(rng.normal(size=4))
    noise = rot.from_rotvec(rng.normal(scale=0.02, size=(400, 3)))
    samples = rot.multiply(mean, noise)
    samples[::2] *= -1.0  # half the samples with the opposite sign
    assert rot.angle_between(rot.average(samples), mean) < np.radians(0.3)
    weights = np.zeros(400)
    weights[5] = 1.0
    assert rot.angle_between(rot.average(samples, weights), samples[5]) < 1e-9


def test_average_over_leading_axes():
    rng = np.random.default_rng(8)
    q = rot.normalize(rng.normal(size=(3, 10, 4)))
    mean = rot.average(q)
    assert mean.shape == (3, 4)
    for k in range(3):
        assert rot.angle_between(mean[k], rot.average(q[k])) < 1e-12


def test_bad_shapes_and_zero_quaternions_are_refused():
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 4\)"):
        rot.multiply(np.zeros(3), rot.identity())
    with pytest.raises(ValueError, match="zero or non-finite"):
        rot.normalize(np.zeros(4))
    with pytest.raises(ValueError, match="zero vector"):
        rot.from_axis_angle(np.zeros(3), 1.0)


def test_heading_of_a_frames_x_axis_on_the_ground():
    # ENU: the identity's x axis points east (90° clockwise from north); turned +90° about Up
    # it points north, -90° south; pitched -90° about y it points up and has no heading.
    q = np.stack([rot.identity(), rot.from_axis_angle([0, 0, 1], np.pi / 2),
                  rot.from_axis_angle([0, 0, 1], -np.pi / 2), rot.from_axis_angle([0, 1, 0], -np.pi / 2)])
    heading = rot.heading_rad(q)
    np.testing.assert_allclose(heading[[0, 1, 3]], [-np.pi / 2, 0.0, 0.0], atol=1e-12)
    assert abs(heading[2]) == pytest.approx(np.pi)  # south: +π or -π as rounding has it
    # Pitching the axis up or down does not change its heading.
    pitched = rot.multiply(rot.from_axis_angle([0, 0, 1], 0.3), rot.from_axis_angle([0, 1, 0], 0.8))
    assert float(rot.heading_rad(pitched)) == pytest.approx(0.3 - np.pi / 2)
