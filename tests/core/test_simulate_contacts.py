"""The simulator's foot-contact truth (evaluation only): a foot marked on the ground moves
slowly (its ankle turns about the heel and the toe as the foot rolls), a foot in the air swings
fast; stance is 62 % of a stride."""

from __future__ import annotations

import numpy as np

from mimucap.core import skeleton
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import simulate_session


def test_walking_contacts_match_the_feet_motion():
    result = simulate_session(SimulationConfig(scenario="walk", duration_s=12.0, n_sensors=10, errors="ideal"))
    truth = result.truth
    t = truth.t_s
    steady = t > 3.0  # after the 1 s N-pose and the 1 s blend into walking
    model = skeleton.load_model(result.model_name)
    fk = skeleton.forward_kinematics(model, truth.q_world_from_segment, result.height_m, truth.root_position_m)
    for column, segment in ((0, "shank_l"), (1, "shank_r")):
        on = truth.foot_contact[:, column] > 0.5
        assert abs(np.mean(on[steady]) - 0.62) < 0.03
        ankle = fk[segment].distal_m[:, :2]
        speed = np.linalg.norm(np.gradient(ankle, t, axis=0), axis=1)
        stance, swing = np.median(speed[steady & on]), np.median(speed[steady & ~on])
        assert stance < 0.3 and swing > 1.5 and swing > 8 * stance
    # The two feet are on the ground together only in double support (about 2 × 12 %).
    both = np.all(truth.foot_contact[steady] > 0.5, axis=1)
    assert abs(np.mean(both) - 0.24) < 0.03
