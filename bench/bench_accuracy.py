"""End-to-end accuracy of the joint angles on the simulated suit, per joint, live and reprocessed.

Each run is a whole guided session on the simulated suit with its default sensor errors (noise,
gyro bias, hard and soft iron): the magnetometer turns, the N/T-pose body calibration, then the
scenario's movement, recorded. The recording is processed *as seen live* and *reprocessed*
(:func:`mimucap.session.recorded.review.load_review`), and every joint angle is compared with the
simulator's truth (:mod:`mimucap.session.angle_accuracy`). Scenarios: walk, squat, demo, each
without and with a magnetic disturbance episode (a 40 µT local field near the subject for 6 s).

Run: ``.venv/bin/python bench/bench_accuracy.py [--seconds 30] [--scenarios walk,squat,demo] [--seed 3]``.
Prints the RMS error (deg) per joint angle column, the flexion summary, and per joint the RMS
angle between the estimated and the true joint rotation ``R_prox_from_dist``: independent of
the angle sequence, it tells a real error from the trade between the first and third angle of
Z-X'-Y'' near its singularity (a shoulder abducted to about 90°, as in the demo's T-pose).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from mimucap.core import rotation as rot
from mimucap.core.pipeline.instants import orientation_at
from mimucap.core.pipeline.settings import RESULT_LIVE, RESULT_REPROCESSED
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.magnetic_field import MagneticDisturbance
from mimucap.io.calibration_store import CalibrationStore
from mimucap.session.angle_accuracy import FLEXION_COLUMNS, angle_errors
from mimucap.session.sources.feeds import SimulatorFeed
from mimucap.session.procedures.guided_session import SteppedClock, run_guided_session
from mimucap.session.live.live_session import LiveSession
from mimucap.session.recorded.review import load_review

#: The disturbance episode: a local field (world, µT) from this many seconds into the recording.
DISTURBANCE_FIELD_UT = (40.0, -25.0, 10.0)
DISTURBANCE_SPAN_S = (8.0, 14.0)
CLOCK_START_S = 100.0


def run_case(scenario: str, seconds: float, seed: int, folder: Path,
             disturbance_at_s: float | None = None) -> dict:
    """One guided session; ``disturbance_at_s`` (simulated time) starts the disturbance episode."""
    clock = SteppedClock(CLOCK_START_S)
    disturbances = ()
    if disturbance_at_s is not None:
        span = DISTURBANCE_SPAN_S[1] - DISTURBANCE_SPAN_S[0]
        disturbances = (MagneticDisturbance(DISTURBANCE_FIELD_UT, start_s=disturbance_at_s,
                                            end_s=disturbance_at_s + span, ramp_s=1.0),)
    config = SimulationConfig(scenario=scenario, seed=seed, disturbances=disturbances)
    feed = SimulatorFeed(config, clock=clock)
    live = LiveSession(feed, scenario, model_name=config.model_name, height_m=config.height_m, clock=clock)
    live.start()
    tag = f"{scenario}-{'disturbed' if disturbances else 'clean'}"
    store = CalibrationStore(folder / f"store-{tag}")
    path = folder / f"{tag}.h5"
    started = time.perf_counter()
    outcome = run_guided_session(live, clock, path, seconds, store)
    elapsed = time.perf_counter() - started
    results, rotations = {}, {}
    for result in (RESULT_LIVE, RESULT_REPROCESSED):
        data = load_review(path, result=result)
        truth = data.truth
        results[result] = angle_errors(data.t_s, data.angles_deg, truth.t_s, truth.joint_angles_deg,
                                       span_s=(1.0, data.end_s))
        rotations[result] = joint_rotation_errors(data, (1.0, data.end_s))
    failed = sorted(s for s, v in outcome.mag_verdicts.items() if v == "fail")
    return {"errors": results, "rotations": rotations, "body_verdict": outcome.body_calibration.quality.verdict,
            "mag_failed": failed, "elapsed_s": elapsed, "recording_sim_s": outcome.recording_started_s - CLOCK_START_S}


def joint_rotation_errors(data, span_s: tuple[float, float]) -> dict[str, float]:
    """Joint → RMS (deg) over ``span_s`` of the angle between the estimated and the true
    ``q_prox_from_dist`` (the truth's segment orientations at the estimate's instants, as the
    pipeline forms a pose: :func:`mimucap.core.pipeline.instants.orientation_at`)."""
    truth = data.truth
    keep = (data.t_s >= span_s[0]) & (data.t_s <= span_s[1])
    t = data.t_s[keep]

    def true_at(segment: str) -> np.ndarray:
        return orientation_at(t, np.asarray(truth.t_s, dtype=np.float64),
                              np.asarray(truth.q_world_from_segment[segment], dtype=np.float64))

    found = {}
    for joint in data.model.joints:
        if joint.proximal not in truth.q_world_from_segment or joint.distal not in truth.q_world_from_segment:
            continue
        estimate = rot.multiply(rot.conjugate(data.q_world_from_segment[joint.proximal][keep]),
                                data.q_world_from_segment[joint.distal][keep])
        true = rot.multiply(rot.conjugate(true_at(joint.proximal)), true_at(joint.distal))
        angle = np.degrees(rot.angle_between(estimate, true))
        angle = angle[np.isfinite(angle)]
        if angle.size:
            found[joint.name] = float(np.sqrt(np.mean(angle ** 2)))
    return found


def report(label: str, case: dict) -> None:
    print(f"== {label}: body calibration {case['body_verdict']}, failed magnetometers "
          f"{', '.join(case['mag_failed']) or 'none'}; {case['elapsed_s']:.1f} s to run")
    live, smooth = case["errors"][RESULT_LIVE], case["errors"][RESULT_REPROCESSED]
    print(f"   {'joint angle':28s} {'live RMS °':>10s} {'reprocessed RMS °':>18s}")
    for column in smooth:
        print(f"   {column:28s} {live[column].rms_deg:10.2f} {smooth[column].rms_deg:18.2f}")
    rot_live, rot_smooth = case["rotations"][RESULT_LIVE], case["rotations"][RESULT_REPROCESSED]
    print("   joint rotation error RMS ° (live/reprocessed; any angle sequence): "
          + ", ".join(f"{joint} {rot_live[joint]:.2f}/{rot_smooth[joint]:.2f}" for joint in rot_smooth))
    for name, errors in (("live", live), ("reprocessed", smooth)):
        flex = [errors[c].rms_deg for c in FLEXION_COLUMNS if c in errors]
        print(f"   {name}: hip/knee/elbow flexion RMS mean {np.mean(flex):.2f}°, worst {np.max(flex):.2f}°; "
              f"worst column {max(e.rms_deg for e in errors.values()):.2f}°")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--scenarios", default="walk,squat,demo")
    parser.add_argument("--seed", type=int, default=3)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for scenario in args.scenarios.split(","):
            clean = run_case(scenario, args.seconds, args.seed, folder)
            report(f"{scenario}, {args.seconds:g} s recorded", clean)
            # The same session (same seed: the calibrations take the same time) with the episode
            # inside the recording.
            start = clean["recording_sim_s"] + DISTURBANCE_SPAN_S[0]
            disturbed = run_case(scenario, args.seconds, args.seed, folder, disturbance_at_s=start)
            report(f"{scenario} with a {np.linalg.norm(DISTURBANCE_FIELD_UT):.0f} µT disturbance "
                   f"{DISTURBANCE_SPAN_S[0]:g}-{DISTURBANCE_SPAN_S[1]:g} s into the recording", disturbed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
