"""Our joint-angle code against Xsens's own joint angles, on the sample MVNX file.

    .venv/bin/python bench/bench_mvnx_angles.py [FILE.mvnx]

From the file's segment orientations (Xsens MVN's biomechanical model) our ISB Z-X'-Y'' code
(:func:`mimucap.core.skeleton.joint_angles_deg`) computes every joint's angles; the table compares
them per joint and axis with the ``jointAngle`` / ``jointAngleErgo`` values Xsens stored for the
same two segments (:data:`mimucap.io.mvnx.XSENS_JOINTS`), as max |difference| and RMS in degrees:

* ``our frames``: our segment frames (forearm and hand at zero in the N-pose, palms towards the
  thighs). Where the definitions match (lumbar, neck, shoulders, elbow flexion and adduction) the
  numbers agree to the file's rounding; the elbow's axial rotation differs by Xsens's 90° forearm
  offset, and the wrist's flexion and deviation are taken about other forearm axes.
* ``anatomical forearms``: the forearm and hand frames turned to Xsens's (palms forward at zero,
  :func:`mimucap.io.mvnx.anatomical_forearms`): then every joint agrees to rounding.
* ``through the pipeline``: the file imported as a session (sensor orientations and Xsens's
  body calibration) and reviewed (:func:`mimucap.session.recorded.review.load_review`), anatomical
  forearms: what is left is MVN's segments not sitting rigidly on their sensors.

Signs: Xsens's X of the arm joints is abduction, ours adduction; the table compares after that
flip (the only convention difference besides the forearm's zero).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from mimucap.core import skeleton
from mimucap.io.mvnx import XSENS_JOINTS, anatomical_forearms, read_mvnx, session_from_mvnx, xsens_angles_as_ours
from mimucap.io.session import write_session

DEFAULT = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "body" / "mvnx_sample" / "test_mocap.mvnx"
AXES = ("flexion", "adduction", "rotation")


def ours_per_joint(model, q_world_from_segment) -> dict[str, np.ndarray]:
    angles = skeleton.joint_angles_deg(model, q_world_from_segment)
    return {j: np.column_stack([angles[f"{j}_{a}_deg"] for a in AXES]) for j in XSENS_JOINTS
            if all(f"{j}_{a}_deg" in angles for a in AXES)}


def table(title: str, ours: dict[str, np.ndarray], recording) -> None:
    print(f"\n{title}: max |ours - Xsens| / RMS, degrees")
    print(f"{'joint':<12}" + "".join(f"{a:>22}" for a in AXES) + "   Xsens angle")
    for joint, values in ours.items():
        theirs = xsens_angles_as_ours(recording, joint)
        if theirs is None:
            continue
        n = min(len(values), len(theirs))
        diff = (values[:n] - theirs[:n] + 180.0) % 360.0 - 180.0
        cells = "".join(f"{np.abs(diff[:, k]).max():>12.4f} / {np.sqrt(np.mean(diff[:, k] ** 2)):>7.4f}" for k in range(3))
        kind, label, _sign = XSENS_JOINTS[joint]
        print(f"{joint:<12}{cells}   {'jointAngleErgo' if kind == 'ergo' else 'jointAngle'} {label}")


def main(argv: list[str]) -> int:
    path = Path(argv[0]) if argv else DEFAULT
    recording = read_mvnx(path)
    print(f"{path.name}: MVNX {recording.version}, {recording.configuration}, {recording.frame_rate_hz:g} Hz, "
          f"{len(recording.t_s)} frames, {len(recording.segments)} segments, {len(recording.sensors)} sensors")
    model = skeleton.load_model("fifteen_segment")
    segments = recording.q_world_from_segment()
    table("our frames", ours_per_joint(model, segments), recording)
    table("anatomical forearms", ours_per_joint(model, anatomical_forearms(segments)), recording)
    from mimucap.session.recorded.review import load_review

    with tempfile.TemporaryDirectory() as folder:
        session_path = Path(folder) / "imported.h5"
        write_session(session_path, session_from_mvnx(recording))
        data = load_review(session_path)
    print(f"\n(pipeline pose source: {data.pose_source})")
    table("through the pipeline, anatomical forearms", ours_per_joint(data.model, anatomical_forearms(data.q_world_from_segment)),
          recording)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
