"""The functional body calibration (standing still, then walking; no T-pose) against the truth
and against OpenSense.

1. **Simulated demo, every seed.** The command-line route of the README with
   ``bodycal --method functional``: ``simulate --scenario demo --duration 90 --seed K`` →
   ``magcal fit --save`` (a store of its own per seed) → ``bodycal --method functional`` (windows
   from the markers: the N-pose before the first walk, and that walk; the T-pose unused) →
   ``angles --calibration CAL.json``, reprocessed and ``--live``. Every knee and hip column is
   compared with the simulator's truth stored in the session over the walking phases (from 1 s
   after each "walk" marker to the next marker), as ``tests/cli/test_functional_route.py`` does;
   no command reads the truth. For comparison, the same session with ``--hinge-from rates``
   (Seel et al.'s gyroscope constraint) and with today's N-pose/T-pose calibration; and each
   segment's sensor-to-segment rotation against the true mounting.
2. **OpenSense walk** (``$MIMUCAP_TEST_DATA/body/opensense_example``, when present and OpenSim
   4.6 is installed): OpenSense's own ``IMUPlacer`` (base ``pelvis_imu``, heading axis ``z``, as
   the example's ``myIMUPlacer_Setup.xml``) and ``IMUInverseKinematicsTool`` on the Xsens
   exports (written as an OpenSense table by MimuCap's reader, in a subprocess), against
   ``bodycal --method functional`` (still window and movement found in the recording) →
   ``angles``. OpenSim's ``hip_flexion`` is the first (z) rotation of the femur from the pelvis
   and ``knee_angle`` the Rajagopal knee's one coordinate, both zero in the calibration pose
   and positive in flexion, as our hip and knee flexion; no offset is removed. RMS difference,
   Pearson r and mean difference per column, over the whole recording and over the example's
   IK range (7.25-15 s); the same for our heading-mode calibration (first row, pelvis sensor's
   z forward, what OpenSense's placer assumes) as a reference.

Run: ``.venv/bin/python bench/bench_functional_calibration.py [--seeds 0-3] [--no-opensense]``.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from mimucap.cli import main
from mimucap.core import phase_markers
from mimucap.core import rotation as rot
from mimucap.io.angles_export import read_angles_csv, read_angles_mot
from mimucap.io.session import read_session
from mimucap.session.angle_accuracy import pooled_rms_deg

COLUMNS = tuple(f"{joint}_{side}_{axis}_deg" for joint in ("hip", "knee") for side in ("l", "r")
                for axis in ("flexion", "adduction", "rotation"))
REPO = Path(__file__).resolve().parents[1]
#: (label, bodycal options) of the calibrations compared on each simulated session.
METHODS = (("functional", ["--method", "functional"]),
           ("functional, --hinge-from rates", ["--method", "functional", "--hinge-from", "rates"]),
           ("N-pose/T-pose", []))
OPENSENSE_PAIRS = (("knee_r_flexion_deg", "knee_angle_r"), ("knee_l_flexion_deg", "knee_angle_l"),
                   ("hip_r_flexion_deg", "hip_flexion_r"), ("hip_l_flexion_deg", "hip_flexion_l"))
OPENSENSE_MAPPING = ("pelvis_imu=pelvis,torso_imu=thorax,femur_r_imu=thigh_r,femur_l_imu=thigh_l,"
                     "tibia_r_imu=shank_r,tibia_l_imu=shank_l,calcn_r_imu=foot_r,calcn_l_imu=foot_l")


def quiet(argv: list[str]) -> int:
    with contextlib.redirect_stdout(io.StringIO()):
        return main(argv)


def simulated_seed(folder: Path, seed: int) -> dict:
    """RMS error per column (reprocessed, live) and mounting error per segment, per method."""
    session = folder / "demo.h5"
    os.environ["MIMUCAP_DATA_DIR"] = str(folder / "data")
    assert quiet(["simulate", "--scenario", "demo", "--duration", "90", "--seed", str(seed), "--out", str(session)]) == 0
    assert quiet(["magcal", "fit", str(session), "--save"]) == 0
    recorded = read_session(session)
    results = {}
    for label, options in METHODS:
        calibration = folder / "CAL.json"
        assert quiet(["bodycal", str(session), *options, "--accept-poor", "--out", str(calibration)]) == 0
        document = json.loads(calibration.read_text())
        entry = {"verdict": document["verdict"], "problems": document["quality"]["problems"], "mounting": {
            segment: float(np.degrees(rot.angle_between(
                value["q_segment_from_sensor"], recorded.truth.sensors[value["sensor"]].q_segment_from_sensor)))
            for segment, value in document["segments"].items()}}
        for kind, extra in (("reprocessed", []), ("live", ["--live"])):
            out = folder / "angles.csv"
            assert quiet(["angles", str(session), "--calibration", str(calibration), "--accept-poor",
                          "--out", str(out)] + extra) == 0
            table = read_angles_csv(out)
            walks = [(start + 1.0, stop) for start, stop in
                     phase_markers.phase_windows(recorded.markers, phase_markers.WALK, float(table.t_s[-1]))]
            entry[kind] = pooled_rms_deg(table.t_s, table.angles_deg, recorded.truth.t_s,
                                         recorded.truth.joint_angles_deg, walks, COLUMNS)
        results[label] = entry
    return results


def print_simulated(by_seed: dict[int, dict]) -> None:
    seeds = list(by_seed)
    for label, _options in METHODS:
        print(f"\n== {label}: RMS error (deg) while walking, reprocessed / live")
        print(f"{'column':24s}" + "".join(f"{'seed ' + str(seed):>16s}" for seed in seeds) + f"{'worst':>9s}")
        for column in COLUMNS:
            cells = [(by_seed[s][label]["reprocessed"][column], by_seed[s][label]["live"][column]) for s in seeds]
            worst = max(c[0] for c in cells)
            limit = 2.0 if column.endswith("flexion_deg") else 4.0
            mark = "" if worst <= limit else f"  over {limit:g}"
            print(f"{column:24s}" + "".join(f"{r:>9.2f} / {v:<4.1f}" for r, v in cells) + f"{worst:>9.2f}{mark}")
        for seed in seeds:
            entry = by_seed[seed][label]
            mounting = ", ".join(f"{segment} {value:.1f}" for segment, value in entry["mounting"].items())
            print(f"  seed {seed}: verdict {entry['verdict']}{'; ' if entry['problems'] else ''}"
                  f"{'; '.join(entry['problems'])}\n    sensor-to-segment rotation off by (deg): {mounting}")


def opensense(folder: Path, data: Path) -> None:
    from mimucap.io.opensense import write_orientation_sto
    from mimucap.io.orientation_inputs import read_quaternion_table

    imu = data / "IMUData"
    names = ["--sensor-names", str(data / "myIMUMappings.xml")]
    table = read_quaternion_table(imu, sensor_names=data / "myIMUMappings.xml")
    sto = write_orientation_sto(folder / "walk.sto", table.t_s, table.q_world_from_sensor)
    run = subprocess.run([sys.executable, str(REPO / "tests" / "io" / "opensense_runner.py"),
                          str(data / "Rajagopal_2015.osim"), str(sto), str(folder / "ik"), "--heading-axis", "z"],
                         capture_output=True, text=True, timeout=3600)
    if run.returncode != 0:
        print(f"OpenSense failed: {run.stderr[-2000:]}")
        return
    ik = read_angles_mot(folder / "ik" / "ik_walk.mot")
    calibration, angles = folder / "CAL.json", folder / "angles.csv"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main(["bodycal", str(imu), *names, "--mapping", OPENSENSE_MAPPING, "--method", "functional",
                     "--out", str(calibration)])
    print(printed.getvalue().rstrip())
    assert code == 0
    assert quiet(["angles", str(imu), *names, "--calibration", str(calibration), "--out", str(angles)]) == 0
    ours = {"functional": read_angles_csv(angles)}
    heading = folder / "HEADING.json"
    assert quiet(["bodycal", str(imu), *names, "--mapping", OPENSENSE_MAPPING, "--heading-from", "pelvis_imu:z",
                  "--out", str(heading)]) == 0
    assert quiet(["angles", str(imu), *names, "--calibration", str(heading), "--out", str(angles)]) == 0
    ours["heading mode (pelvis_imu:z, first row)"] = read_angles_csv(angles)
    for method, table in ours.items():
        print(f"\n== OpenSense walk: our {method} calibration vs OpenSense's IMUPlacer + IMU IK")
        for label, (start, stop) in (("whole recording", (0.0, np.inf)),
                                     ("the example's IK range 7.25-15 s", (7.25, 15.0))):
            keep = (ik.t_s >= start) & (ik.t_s <= stop)
            print(f"  {label} ({int(keep.sum())} rows):")
            for column, theirs in OPENSENSE_PAIRS:
                a = np.interp(ik.t_s[keep], table.t_s, table.angles_deg[column])
                b = ik.angles_deg[theirs][keep]
                print(f"    {column:20s} vs {theirs:14s} RMS {np.sqrt(np.mean((a - b) ** 2)):5.2f}°  "
                      f"r {np.corrcoef(a, b)[0, 1]:.4f}  mean difference {np.mean(a - b):+5.2f}°")


def parse_seeds(text: str) -> list[int]:
    if "-" in text:
        first, last = (int(v) for v in text.split("-"))
        return list(range(first, last + 1))
    return [int(v) for v in text.split(",")]


def main_bench() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0-3", help="seeds of the simulated demo: 0-3 or 0,2,5")
    parser.add_argument("--no-opensense", action="store_true", help="leave out the OpenSense comparison")
    args = parser.parse_args()
    by_seed = {}
    for seed in parse_seeds(args.seeds):
        with tempfile.TemporaryDirectory() as folder:
            by_seed[seed] = simulated_seed(Path(folder), seed)
        print(f"seed {seed} done", flush=True)
    print_simulated(by_seed)
    if args.no_opensense:
        return
    data = Path(os.environ.get("MIMUCAP_TEST_DATA", REPO / "../shared/data")) / "body" / "opensense_example"
    if importlib.util.find_spec("opensim") is None:
        print("\nOpenSense comparison skipped: opensim (OpenSim 4.6) is not installed")
        return
    if not data.is_dir():
        print(f"\nOpenSense comparison skipped: {data} not found")
        return
    with tempfile.TemporaryDirectory() as folder:
        opensense(Path(folder), data)


if __name__ == "__main__":
    main_bench()
