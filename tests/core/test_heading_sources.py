"""Headings from the body: the field the body shares, the knee's hinge axis, the choice per
sensor and instant (core/fusion/uniform_field.py, core/joint_coupling.py, core/heading_sources.py),
and against the simulator's truth on the command-line route in a disturbed field and a clinic room."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core import rotation
from mimucap.core.pipeline import doubt_reasons as doubt
from mimucap.core.fusion.uniform_field import deviation_spread_uT, relative_azimuths
from mimucap.core.heading_sources import (
    SHARED_DEVIATION_UT, SOURCE_HELD, SOURCE_JOINT, SOURCE_SHARED_FIELD, HeadingCoupling, Hinge, own_field_weight,
    relieved, turned_about_vertical,
)
from mimucap.core.joint_coupling import hinge_errors, hinge_statistics

RNG = np.random.default_rng(11)
#: A segment standing upright (ISB: y up, z horizontal).
UPRIGHT = rotation.from_axis_angle([1.0, 0.0, 0.0], np.pi / 2)


def random_orientations(count: int) -> np.ndarray:
    return rotation.normalize(RNG.normal(size=(count, 4)))


def field_seen(q_world_from_sensor: np.ndarray, field_world_uT: np.ndarray) -> np.ndarray:
    return rotation.rotate(rotation.conjugate(q_world_from_sensor), field_world_uT)


def test_a_uniform_field_that_is_not_the_calibrated_one_gives_the_relative_headings():
    q_true = random_orientations(6)
    errors = np.radians([4.0, -7.0, 0.0, 12.0, -3.0, 1.0])
    q_estimated = turned_about_vertical(q_true, errors)
    field = np.array([30.0, 5.0, -60.0])  # a disturbed field: neither the earth's magnitude nor its dip
    found, weight = relative_azimuths(q_estimated, field_seen(q_true, field))
    assert np.all(weight > 0)
    relative = errors - np.angle(np.mean(np.exp(1j * errors)))
    np.testing.assert_allclose(found, relative, atol=1e-9)


def test_a_sensor_in_a_field_of_its_own_gets_no_weight():
    q = random_orientations(5)
    fields = np.tile([0.0, 20.0, -45.0], (5, 1))
    fields[4] = [0.0, 20.0, -25.0]  # near a steel floor: another dip
    _found, weight = relative_azimuths(q, np.stack([field_seen(q[i], fields[i]) for i in range(5)]))
    assert weight[4] == 0 and np.all(weight[:4] > 0)


def test_too_few_agreeing_sensors_give_nothing():
    q = random_orientations(2)
    _found, weight = relative_azimuths(q, field_seen(q, np.array([0.0, 20.0, -45.0])))
    assert np.all(weight == 0)


def test_the_hinge_axis_tells_a_drift_about_the_vertical_from_an_error_about_the_segment():
    count = 40
    lean = np.radians(30.0) * np.sin(np.linspace(0.0, 6.0, count))  # a shank swinging in walking
    thigh = turned_about_vertical(rotation.multiply(UPRIGHT, rotation.from_axis_angle([0.0, 0.0, 1.0], 0.5 * lean)),
                                  np.full(count, 0.4))
    shank = rotation.multiply(thigh, rotation.from_axis_angle([0.0, 0.0, 1.0], -np.abs(lean)))
    drift, mounting = np.radians(6.0), np.radians(-9.0)
    wrong = turned_about_vertical(rotation.multiply(shank, rotation.from_axis_angle([0.0, 1.0, 0.0], mounting)), drift)
    epsilon, delta = hinge_errors(hinge_statistics(thigh, wrong).mean(axis=0))
    corrected = turned_about_vertical(rotation.multiply(wrong, rotation.from_axis_angle([0.0, 1.0, 0.0], epsilon)),
                                      delta)
    assert np.degrees(rotation.angle_between(corrected, shank)).max() < 1.5  # to first order
    upright = np.stack([UPRIGHT] * 3)
    assert np.all(hinge_statistics(upright, np.full((3, 4), np.nan)) == 0)


def walking_pair(count: int, t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A thigh and shank (sensor = segment) walking about with a flexing knee."""
    heading = 0.3 * np.sin(0.2 * t_s)
    thigh = turned_about_vertical(rotation.multiply(UPRIGHT, rotation.from_axis_angle([0.0, 0.0, 1.0],
                                                                                      0.4 * np.sin(6.0 * t_s))), heading)
    shank = rotation.multiply(thigh, rotation.from_axis_angle([0.0, 0.0, 1.0], -0.6 * (1 + np.sin(6.0 * t_s))))
    return thigh, shank


def coupling_of_pair(mode: str = "coupled") -> HeadingCoupling:
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    return HeadingCoupling(["T", "S"], [Hinge("knee_r", "T", "S", identity, identity)], mode)


def test_a_drifting_shank_is_held_by_its_knee_and_marked_so():
    t = np.arange(0.0, 30.0, 0.01)
    thigh, shank = walking_pair(len(t), t)
    drift = np.radians(1.0) * t  # 1°/s of gyroscope drift, magnetometer unusable
    q = np.stack([thigh, turned_about_vertical(shank, drift)], axis=1)
    for both_ways, limit_deg in ((True, 0.5), (False, 2.5)):
        corrected, source = coupling_of_pair("no-magnetometer").run(t, q, None, both_ways)
        late = (t > 5.0) & (t < 25.0)  # the average starts and ends on one side
        error = rotation.angle_between(corrected[late, 1], shank[late])
        assert np.degrees(error).max() < limit_deg
        assert np.all(source[:, 1] == SOURCE_JOINT)


def test_the_live_steps_give_the_causal_series():
    t = np.arange(0.0, 5.0, 0.02)
    thigh, shank = walking_pair(len(t), t)
    q = np.stack([thigh, turned_about_vertical(shank, 0.2 * t)], axis=1)
    series, _source = coupling_of_pair().run(t, q, None, both_ways=False)
    live = coupling_of_pair()
    stepped = np.stack([live.step(float(t[k]), q[k], None)[0] for k in range(len(t))])
    np.testing.assert_allclose(stepped, series, atol=1e-12)


def test_sensors_in_a_shared_field_are_turned_back_and_one_in_its_own_is_held():
    t = np.arange(0.0, 20.0, 0.05)
    count = 4
    q_true = np.stack([turned_about_vertical(random_orientations(1)[0], 0.1 * np.sin(t + i)) for i in range(count)],
                      axis=1)
    drift = np.array([0.0, 0.5, -0.8, 0.3])[None, :] * np.radians(t)[:, None]
    q_estimated = turned_about_vertical(q_true, drift)
    field = np.array([25.0, 10.0, -55.0])
    mag = field_seen(q_true, field)
    mag[t > 10.0, 3] = field_seen(q_true[t > 10.0, 3], np.array([25.0, 10.0, -20.0]))
    coupling = HeadingCoupling([f"S{i}" for i in range(count)], [])
    corrected, source = coupling.run(t, q_estimated, mag, both_ways=True)
    middle = (t > 3.0) & (t < 9.0)
    relative = [rotation.angle_between(rotation.multiply(rotation.conjugate(corrected[middle, 0]), corrected[middle, i]),
                                       rotation.multiply(rotation.conjugate(q_true[middle, 0]), q_true[middle, i]))
                for i in range(1, count)]
    assert np.degrees(np.max(relative)) < 1.0  # the mean the errors refer to shifts when sensor 3 leaves it
    assert np.all(source[middle] == SOURCE_SHARED_FIELD)
    assert np.all(source[t > 12.0, 3] == SOURCE_HELD)


def test_a_sensor_moving_through_a_field_of_its_own_is_not_turned_with_it():
    """Sensor 3 walks through a field that turns about the vertical as it deviates in dip (a
    floor's field, of the same size in every direction); its filter's heading is right. Its
    relative errors count with the inverse of their variance: it is barely turned with the
    field, while a sensor whose filter drifts in the shared field is still followed."""
    t = np.arange(0.0, 60.0, 0.02)
    count = 5
    q_true = np.stack([turned_about_vertical(random_orientations(1)[0], 0.1 * np.sin(0.5 * t + i))
                       for i in range(count)], axis=1)
    field = np.array([0.0, 25.0, -42.0])
    mag = field_seen(q_true, field)
    phase = 2.0 * np.pi * t / 4.0  # a few metres of the walkway in four seconds
    local = field + 4.0 * np.stack([-np.sin(phase), np.zeros_like(t), np.cos(phase)], axis=1)  # 4 µT
    mag[:, 3] = field_seen(q_true[:, 3], local)
    later = t > 20.0

    def relative_error_deg(corrected: np.ndarray, i: int) -> float:  # sensor i's heading relative to sensor 1's
        return float(np.degrees(np.max(rotation.angle_between(
            rotation.multiply(rotation.conjugate(corrected[later, 1]), corrected[later, i]),
            rotation.multiply(rotation.conjugate(q_true[later, 1]), q_true[later, i])))))

    sensors = [f"S{i}" for i in range(count)]
    corrected, _source = HeadingCoupling(sensors, []).run(t, q_true, mag, both_ways=False)
    assert relative_error_deg(corrected, 3) < 1.5  # with every instant counted alike: 2.8°
    drifting = q_true.copy()
    drifting[:, 0] = turned_about_vertical(q_true[:, 0], np.radians(0.5) * t)  # 0.5 °/s
    corrected, _source = HeadingCoupling(sensors, []).run(t, drifting, mag, both_ways=False)
    assert relative_error_deg(corrected, 0) < 1.5  # of the drift's 10° to 30°


def test_a_coupled_sensor_is_not_doubtful_for_its_magnetometer_alone():
    reasons = np.array([doubt.MAG_REJECTED | doubt.LOST_SAMPLES, doubt.FIELD_MISMATCH, doubt.MAG_REJECTED],
                       dtype=doubt.DOUBT_DTYPE)
    sources = np.array([SOURCE_JOINT, SOURCE_SHARED_FIELD, SOURCE_HELD], dtype=np.uint8)
    np.testing.assert_array_equal(relieved(reasons, sources), [doubt.LOST_SAMPLES, 0, doubt.MAG_REJECTED])


def test_an_unknown_mode_is_refused():
    with pytest.raises(ValueError, match="heading mode"):
        coupling_of_pair("compass")


def test_sensors_off_the_body_say_nothing_of_the_hinge_and_the_correction_fades_in():
    """Thigh and shank sensors held together off the body (their magnetometers calibrated), then
    strapped on and walking with the shank's heading 3° off (its own magnetometer): no instant
    of the first part counts, and the shank is never turned further from the truth than its
    magnetometer left it, nor by a jump, where the hinge's evidence begins."""
    t = np.arange(0.0, 20.0, 0.01)
    thigh, shank = walking_pair(len(t), t)
    off = t < 8.0
    held = rotation.multiply(thigh[off], rotation.from_axis_angle([1.0, 0.0, 0.0], np.radians(100.0)))
    shank_true = shank.copy()
    shank_true[off] = held
    measured = turned_about_vertical(shank_true, np.full(len(t), np.radians(3.0)))
    q = np.stack([thigh, measured], axis=1)
    for both_ways in (True, False):
        corrected, source = coupling_of_pair().run(t, q, None, both_ways)
        error = np.degrees(rotation.angle_between(corrected[:, 1], shank_true))
        on = ~off
        assert error[on].max() <= 3.0 + 1e-6, both_ways
        assert error[t > 12.0].max() < 0.5, both_ways
        turn = np.degrees(rotation.angle_between(corrected[:, 1], measured))
        assert np.abs(np.diff(turn)).max() < 0.2, both_ways  # fades in, never jumps
        assert np.all(source[t < 7.0, 1] != SOURCE_JOINT) and np.all(source[t > 12.0, 1] == SOURCE_JOINT)


def test_a_stored_state_continues_whatever_order_the_sensors_come_in():
    """A recording lists its sensors in the order they arrived, the live view in its own: the
    coupling continues from the live one's state all the same."""
    from mimucap.core import skeleton
    from mimucap.core.pipeline.instants import SensorsAtInstants
    from mimucap.core.pipeline.segments import SegmentStage

    t = np.arange(0.0, 8.0, 0.05)
    segments = {"S1": "pelvis", "S2": "thorax", "S3": "thigh_l", "S4": "thigh_r"}
    q_true = np.stack([turned_about_vertical(random_orientations(1)[0], 0.1 * np.sin(t + i)) for i in range(4)], axis=1)
    q = turned_about_vertical(q_true, np.array([0.0, 0.4, -0.6, 0.2])[None, :] * np.radians(t)[:, None])
    mag = field_seen(q_true, np.array([25.0, 10.0, -55.0]))
    stage = SegmentStage(skeleton.load_model("ten_segment"), None, segments)

    def instants(rows: slice, order: list[int]) -> SensorsAtInstants:
        return SensorsAtInstants(t[rows], {f"S{i + 1}": q[rows, i] for i in order}, mag_uT={f"S{i + 1}": mag[rows, i] for i in order})

    live = HeadingCoupling([], [])
    live.couple(instants(slice(0, 80), [0, 1, 2, 3]), stage)
    expected = live.couple(instants(slice(80, None), [0, 1, 2, 3]), stage)
    before = HeadingCoupling([], [])  # the same instants, the sensors in another order
    before.couple(instants(slice(0, 80), [2, 0, 3, 1]), stage)
    replay = HeadingCoupling([], [])
    replay.restore(before.state_to_dict())
    found = replay.couple(instants(slice(80, None), [3, 1, 0, 2]), stage)
    for sid, value in expected.q_world_from_sensor.items():
        np.testing.assert_allclose(found.q_world_from_sensor[sid], value, atol=1e-12)


def test_the_spread_of_a_field_that_varies_over_a_sensors_path_counts_only_while_it_moves():
    """Four sensors in one field; the fourth walks through a field whose horizontal and vertical
    parts swing by 3 µT (a floor's field at the thighs): its spread is 3/√2 µT in each component,
    the others' none. A still stretch in which its field sits 20 µT off counts for nothing."""
    steps = 400
    phase = np.linspace(0.0, 8.0 * np.pi, steps, endpoint=False)
    q = np.broadcast_to(random_orientations(4), (steps, 4, 4)).copy()
    field = np.broadcast_to(np.array([0.0, 25.0, -43.0]), (steps, 4, 3)).copy()
    field[:, 3, 1] += 3.0 * np.sin(phase)
    field[:, 3, 2] += 3.0 * np.cos(phase)
    moving = np.ones((steps, 4), bool)
    still = np.zeros((50, 4, 3))
    still[:, :] = [0.0, 25.0, -43.0]
    still[:, 3, 1] += 20.0
    q = np.concatenate([q, q[:50]])
    field = np.concatenate([field, still])
    moving = np.concatenate([moving, np.zeros((50, 4), bool)])
    mag = field_seen(q, field)
    mag[:10, 1] = np.nan  # a sensor without a field for a while counts over the rest
    spread = deviation_spread_uT(q, mag, moving)
    np.testing.assert_allclose(spread, [0.0, 0.0, 0.0, 3.0], atol=1e-6)
    assert np.isnan(deviation_spread_uT(q, mag, np.zeros_like(moving))).all()


def test_a_sensors_own_field_weighs_with_the_inverse_of_its_variance_beyond_a_shared_fields():
    assert own_field_weight(0.3 * SHARED_DEVIATION_UT) == 1.0
    assert own_field_weight(float("nan")) == 1.0
    assert own_field_weight(2.0 * SHARED_DEVIATION_UT) == pytest.approx(0.25)
    assert own_field_weight(5.0 * SHARED_DEVIATION_UT) == pytest.approx(0.04)
