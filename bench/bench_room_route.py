"""The command-line route in each simulated room: knee and hip angles against the truth while walking.

For each room (``--rooms clean,clinic,treadmill``) and for the uniform disturbance of issue 34
(``--disturbance 30,-20,10,34,90``), the README's route runs on a simulated demo session:
``simulate --scenario demo --duration 90 --seed 3 [--room R]`` → ``magcal fit --save`` →
``bodycal --out CAL.json`` → ``angles --calibration CAL.json``, reprocessed and ``--live``.
Every knee and hip column is compared with the simulator's truth stored in the session over the
walking phases (from 1 s after each "walk" marker to the next marker), as
``tests/cli/test_session_route.py`` does; no command reads the truth.

The magnetometer turns happen in the room too, at the start position (the world origin) with
the units at hand height: ``magcal fit`` calibrates in the field there. The room's field at the
turned units is printed.

Run: ``.venv/bin/python bench/bench_room_route.py [--rooms clean,clinic] [--seed 3]
[--duration 90] [--no-disturbance] [--heading coupled|magnetometer|no-magnetometer]``. Prints,
per room, the field deviation the units saw and a table of RMS errors (deg) per column, reprocessed and live.
On the treadmill the magnetometers cannot be calibrated in the room's field: run it with
``--heading no-magnetometer`` (the body calibration without magnetometers too, taken as it is).
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

import numpy as np

from mimucap.cli import main
from mimucap.core import phase_markers
from mimucap.core.heading_modes import MODE_NO_MAGNETOMETER
from mimucap.io.angles_export import read_angles_csv
from mimucap.io.session import read_session
from mimucap.session.angle_accuracy import pooled_rms_deg

COLUMNS = tuple(f"{joint}_{side}_{axis}_deg" for joint in ("hip", "knee") for side in ("l", "r")
                for axis in ("flexion", "adduction", "rotation"))
#: The uniform field change of issue 34 (µT, world ENU, from 34 s to the end).
UNIFORM_DISTURBANCE = "30,-20,10,34,90"


def field_summary(session_path: Path) -> str:
    """How far from the earth field each unit's field was (µT): while walking and during the turns."""
    recorded = read_session(session_path)
    truth = recorded.truth
    end = float(truth.t_s[-1])
    walking = np.zeros(truth.t_s.shape, bool)
    for start, stop in phase_markers.phase_windows(recorded.markers, phase_markers.WALK, end):
        walking |= (truth.t_s >= start + 1.0) & (truth.t_s < stop)
    turning = np.zeros(truth.t_s.shape, bool)
    for start, stop in phase_markers.phase_windows(recorded.markers, phase_markers.MAG_TURNS, end):
        turning |= (truth.t_s >= start) & (truth.t_s < stop)
    parts = []
    for sensor_id, sensor in sorted(truth.sensors.items()):
        deviation = np.linalg.norm(sensor.field_world_uT - truth.field_world_uT, axis=1)
        parts.append(f"{sensor_id} ({sensor.segment}) walking mean {deviation[walking].mean():.1f} max "
                     f"{deviation[walking].max():.1f}, turns mean {deviation[turning].mean():.1f}")
    return "\n    ".join(parts)


def run_route(folder: Path, seed: int, duration_s: float, room: str, disturbance: str | None,
              heading: str | None = None) -> dict:
    """Simulate, calibrate and compute the angles; RMS error per column, reprocessed and live."""
    session = folder / "demo.h5"
    os.environ["MIMUCAP_DATA_DIR"] = str(folder / "data")
    command = ["simulate", "--scenario", "demo", "--duration", f"{duration_s:g}", "--seed", str(seed),
               "--room", room, "--out", str(session)]
    if disturbance:
        command += ["--disturbance", disturbance]
    assert main(command) == 0
    magnetometer_free = heading == MODE_NO_MAGNETOMETER
    # without magnetometers a room whose field fails their calibration (the treadmill) still runs
    assert main(["magcal", "fit", str(session), "--save"]) == 0 or magnetometer_free
    calibration = folder / "CAL.json"
    free = ["--heading", heading] if magnetometer_free else []
    status = main(["bodycal", str(session), "--out", str(calibration)] + free)
    assert status == 0 or (magnetometer_free and calibration.exists())
    recorded = read_session(session)
    results = {"fields": field_summary(session)}
    for kind, extra in (("reprocessed", []), ("live", ["--live"])):
        out = folder / f"angles_{kind}.csv"
        if heading:
            extra = extra + ["--heading", heading] + (["--accept-poor"] if magnetometer_free else [])
        assert main(["angles", str(session), "--calibration", str(calibration), "--out", str(out)] + extra) == 0
        table = read_angles_csv(out)
        walks = [(start + 1.0, stop) for start, stop in phase_markers.phase_windows(recorded.markers, phase_markers.WALK,
                                                                                   float(table.t_s[-1]))]
        results[kind] = pooled_rms_deg(table.t_s, table.angles_deg, recorded.truth.t_s,
                                       recorded.truth.joint_angles_deg, walks, COLUMNS)
    return results


def main_bench() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rooms", default="clean,clinic")
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--duration", type=float, default=90.0)
    parser.add_argument("--no-disturbance", action="store_true", help="leave out the uniform-disturbance run")
    parser.add_argument("--heading", default=None, help="angles --heading MODE (default: the session's setting)")
    args = parser.parse_args()
    runs = [(room, None) for room in args.rooms.split(",")]
    if not args.no_disturbance:
        runs.append(("clean", UNIFORM_DISTURBANCE))
    table = {}
    for room, disturbance in runs:
        label = room if disturbance is None else f"{room} + --disturbance {disturbance}"
        with tempfile.TemporaryDirectory() as folder:
            results = run_route(Path(folder), args.seed, args.duration, room, disturbance, args.heading)
        print(f"\n== {label}: field deviation from the earth field (µT)\n    {results['fields']}", flush=True)
        table[label] = results
    print("\nRMS error (deg) of the command-line route while walking, reprocessed / live")
    labels = list(table)
    print(f"{'column':28s}" + "".join(f"{label[:24]:>26s}" for label in labels))
    for column in COLUMNS:
        cells = "".join(f"{table[label]['reprocessed'][column]:>12.1f} / {table[label]['live'][column]:<11.1f}"
                        for label in labels)
        print(f"{column:28s}{cells}")


if __name__ == "__main__":
    main_bench()
