"""A recording's *as seen live* result with the headings from the body reproduces the live
plots: the heading coupling (core/heading_sources.py) averages over time, so the live view
steps it over every instant (not only those a plot refresh shows) and the recording stores its
state at the start, from which the replay continues."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core import skeleton
from mimucap.core.bodycal import BodyCalibration, CalibrationQuality
from mimucap.core.heading_sources import HeadingCoupling, coupling_state_from_dict
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.pipeline.settings import RESULT_LIVE
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.sensor_errors import SensorErrorModel
from mimucap.session.live.live_session import LiveSession
from mimucap.session.recorded.review import load_review
from mimucap.session.recorded.stored_processing import COUPLING_STATE_KEY, PIPELINE_KEY
from mimucap.session.sources.feeds import SimulatorFeed

JOINTS = ("hip_l", "hip_r", "knee_l", "knee_r")
#: The GUI's pump period (s): about two sensor samples per step, so a plot refresh skips instants.
STEP_S = 0.016


@pytest.fixture(scope="module")
def live_and_replayed(tmp_path_factory):
    """A live session in the clinic room (the floor's field turns the shanks' headings, which
    the coupling corrects), its plots' joint angles over a recording, and the recording's
    *as seen live* review."""
    now = [50.0]
    clock = lambda: now[0]  # noqa: E731
    # gyroscope biases and noise, magnetometers without iron errors: an identity calibration fits them
    errors = SensorErrorModel(mag_hard_iron_uT=0.0, mag_soft_iron_scale=0.0, mag_soft_iron_cross=0.0)
    config = SimulationConfig(scenario="walk", room="clinic", seed=3, errors=errors)
    session = LiveSession(SimulatorFeed(config, clock=clock), clock=clock)
    session.start()

    def run(seconds: float) -> None:
        for _ in range(int(round(seconds / STEP_S))):
            now[0] += STEP_S
            session.step()

    run(0.2)
    field_uT = float(np.linalg.norm(config.earth_field.field_world_uT()))
    for sid in session.sensor_ids:
        session.apply_mag_calibration(MagCalibration(sid, np.zeros(3), np.eye(3), field_uT), save=False)
    mounting = session.feed.simulator.mounting  # a body calibration as exact as the wizard's at best
    session.apply_body_calibration(BodyCalibration(
        q_world_from_body=skeleton.q_world_from_body_facing(0.0), up_world=np.array([0.0, 0.0, 1.0]),
        sensors={m.segment: sid for sid, m in mounting.items()},
        q_segment_from_sensor={m.segment: m.q_segment_from_sensor for m in mounting.values()},
        quality=CalibrationQuality("known mounting", ())))
    run(6.0)  # the coupling's averages are well away from where a fresh one would start
    folder = tmp_path_factory.mktemp("live_heading")
    session.start_recording(folder / "walk.h5")
    offset = session.recording_started_s
    run(8.0)
    shown = {joint: session.joint_series(joint, 30.0) for joint in JOINTS}
    result = session.stop_recording()
    session.stop()
    return session, shown, offset, load_review(result.session_path, result=RESULT_LIVE)


def test_the_live_view_uses_the_heading_coupling(live_and_replayed):
    session = live_and_replayed[0]
    assert isinstance(session.processing.pipeline.coupling, HeadingCoupling)
    assert session.processing.pipeline.coupling.hinges  # both knees


def test_as_seen_live_is_what_the_live_plots_showed(live_and_replayed):
    _session, shown, offset, as_live = live_and_replayed
    compared = 0
    for joint, (t_live, angles_live) in shown.items():
        t_rec = t_live - offset
        inside = (t_rec >= as_live.t_s[0]) & (t_rec <= as_live.t_s[-1])
        index = np.searchsorted(as_live.t_s, t_rec[inside] - 1e-6)
        np.testing.assert_allclose(as_live.t_s[index], t_rec[inside], atol=1e-6)
        for k, axis in enumerate(("flexion", "adduction", "rotation")):
            column = f"{joint}_{axis}_deg"
            diff = np.abs(as_live.angles_deg[column][index] - angles_live[inside, k])
            assert np.max(diff) < 0.1, (column, float(np.max(diff)))
        compared += int(np.count_nonzero(inside))
    assert compared > 4 * 300


def test_the_recording_stores_where_the_coupling_stood_and_refuses_a_malformed_state(live_and_replayed):
    as_live = live_and_replayed[3]
    stored = as_live.session.metadata[PIPELINE_KEY][COUPLING_STATE_KEY]
    assert stored["t_s"] < 0.0  # just before the recording's first instant, on its clock
    assert [hinge[0] for hinge in stored["hinges"]] == ["knee_l", "knee_r"]
    broken = dict(stored, field=[[1.0, 2.0]])
    with pytest.raises(ValueError, match="walk.h5: live heading coupling state: its averages are malformed"):
        coupling_state_from_dict(broken, "walk.h5: live heading coupling state")
