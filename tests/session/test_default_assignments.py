"""The assignments a session starts from carry one sensor per segment: the simulated suit of
every size on either skeleton (in process, in a worker, in a session file, in the live session),
and a recording made when two sensors could share a segment, which keeps the first."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.acquisition.simulated import SimulatedSourceConfig
from mimucap.core import skeleton
from mimucap.core.pipeline import one_sensor_per_segment, process_recording
from mimucap.core.simulate.config import MAX_SENSORS, SENSOR_PLACEMENTS, SimulationConfig, default_assignment
from mimucap.core.simulate.suit import SuitSimulator, simulate_session
from mimucap.io.session import session_from_simulation
from mimucap.session.feeds import SimulatorFeed
from mimucap.session.live import LiveSession

SUITS = [(n, model) for n in range(1, MAX_SENSORS + 1) for model in skeleton.MODEL_NAMES
         if model == "fifteen_segment" or n <= 10]


def one_to_one(assignment: dict[str, str]) -> bool:
    return len(set(assignment.values())) == len(assignment)


@pytest.mark.parametrize(("n", "model"), SUITS)
def test_every_simulated_suit_comes_with_one_sensor_per_segment(n, model):
    config = SimulationConfig(scenario="npose", n_sensors=n, model=model)
    worn = {sid: segment for sid, segment, _a, _b in SENSOR_PLACEMENTS[:n]}
    assignment = default_assignment(config.sensor_ids)
    assert one_to_one(assignment)
    # every segment a unit is worn on is driven, by the first unit worn there
    assert set(assignment.values()) == set(worn.values())
    for sid, segment in assignment.items():
        assert worn[sid] == segment and sid == next(s for s, seg in worn.items() if seg == segment)
    feed = SimulatorFeed(config)
    assert feed.sensor_segments() == assignment
    assert LiveSession(feed, model_name=config.model_name).sensor_segments == assignment
    if model == config.model_name:   # what a worker source gives (its model follows the size)
        assert SimulatedSourceConfig(n_sensors=n).sensor_segments() == assignment


def test_the_second_units_are_worn_but_drive_no_segment_in_a_session_file():
    result = simulate_session(SimulationConfig(scenario="npose", duration_s=0.5, n_sensors=17))
    session = session_from_simulation(result)
    segments = {sid: s.segment for sid, s in session.sensors.items()}
    assert segments["S16"] is None and segments["S17"] is None
    assert segments["S01"] == "pelvis" and segments["S02"] == "thorax"
    assert one_to_one({sid: seg for sid, seg in segments.items() if seg})
    # where they are worn stays known (the simulator's mounting and truth)
    assert result.mounting["S16"].segment == "thorax" and result.mounting["S17"].segment == "pelvis"
    assert session.truth.sensors["S17"].segment == "pelvis"


def test_a_recording_with_two_sensors_on_a_segment_keeps_the_first():
    """A session file from before: S17 recorded on the pelvis beside S01. The pose's pelvis is
    S01's (its own orientation), not the second unit's, which is mounted otherwise."""
    assert one_sensor_per_segment({"S01": "pelvis", "S02": "thorax", "S17": "pelvis", "S16": "thorax",
                                   "S03": None}) == {"S01": "pelvis", "S02": "thorax"}
    result = simulate_session(SimulationConfig(scenario="walk", duration_s=1.0, n_sensors=17, errors="ideal"))
    model = skeleton.load_model("fifteen_segment")
    segments = {sid: seg for sid, seg, _a, _b in SENSOR_PLACEMENTS}       # as older files stored it
    output = process_recording(result.samples, model, sensor_segments=segments)
    s01 = output.q_world_from_sensor["S01"]
    assert output.reference_sensor == "S01"
    np.testing.assert_allclose(output.q_world_from_segment["pelvis"], s01[:len(output.t_s)], atol=1e-12)


def test_the_suits_devices_follow_its_seed_and_error_model_not_its_room():
    from mimucap.core.simulate.magnetic_field import EarthField

    base = SimulationConfig(scenario="npose", seed=3)
    ids = base.device_ids()
    assert ids["S01"].startswith("sim:") and ids["S01"].endswith("/S01") and len(set(ids.values())) == 10
    assert SimulationConfig(scenario="walk", seed=3, earth_field=EarthField(85.0), drop_probability=0.1).device_ids() == ids
    assert SimulationConfig(scenario="npose", seed=4).device_ids()["S01"] != ids["S01"]
    assert SimulationConfig(scenario="npose", seed=3, errors="mpu9250").device_ids()["S01"] != ids["S01"]
    assert SuitSimulator(base).device_ids == ids
