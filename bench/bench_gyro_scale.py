"""The gyroscope's scale factors estimated from the magnetometer turns, against the simulator's.

For each seed: ``mimucap simulate --scenario demo`` (its marked magnetometer turns, every unit
with the default sensor errors: 1 % per-axis gyroscope scale error), then, per sensor, what
``magcal fit`` does (:func:`mimucap.cli.magcal.session_turn_recordings` and
:func:`mimucap.core.magcal.calibrate.calibrate` with the gyroscope's samples), compared with the
true scale matrix ``S`` the simulator stored (``ω_raw = S ω + b``): the error of the correction is
``C · S − I``. Printed per seed: the sensors whose estimate is applied, the largest |error| of a
scale factor (diagonal) and of a cross-axis term, the largest standard error the fit reports, and
the largest true scale error (what the correction removes), all in percent.

Run: ``.venv/bin/python bench/bench_gyro_scale.py [--seeds 0-7] [--duration 27]``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import tempfile
from pathlib import Path

import numpy as np

from mimucap.cli import main
from mimucap.cli.magcal import session_turn_recordings
from mimucap.core.magcal.calibrate import calibrate
from mimucap.io.session import read_session


def seeds_of(text: str) -> list[int]:
    if "-" in text:
        first, last = (int(v) for v in text.split("-"))
        return list(range(first, last + 1))
    return [int(v) for v in text.split(",")]


def run(seed: int, duration_s: float, folder: Path) -> tuple[int, int, float, float, float, float]:
    session = folder / "demo.h5"
    with contextlib.redirect_stdout(io.StringIO()):
        if main(["simulate", "--scenario", "demo", "--duration", f"{duration_s:g}", "--seed", str(seed),
                 "--out", str(session)]) != 0:
            raise RuntimeError("mimucap simulate failed")
    truth = read_session(session).truth
    recordings, _windows = session_turn_recordings(session, None)
    applied, diagonal, cross, std, true_error = 0, 0.0, 0.0, 0.0, 0.0
    for sensor_id, recording in recordings.items():
        result = calibrate(recording.mag, sensor_id, t_s=recording.t_s, gyr_raw_rad_s=recording.imu.gyr)
        scale = np.asarray(truth.sensors[sensor_id].parameters["gyr_scale"])
        error = result.gyro.estimated @ scale - np.eye(3)
        applied += int(result.gyro.applied)
        diagonal = max(diagonal, float(np.abs(np.diag(error)).max()))
        cross = max(cross, float(np.abs(error - np.diag(np.diag(error))).max()))
        std = max(std, float(result.gyro.std.max()))
        true_error = max(true_error, float(np.abs(np.diag(scale) - 1.0).max()))
    return applied, len(recordings), 100 * diagonal, 100 * cross, 100 * std, 100 * true_error


def main_() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="0-7", help="seeds, e.g. 0-7 or 3,5")
    parser.add_argument("--duration", type=float, default=27.0, help="demo length (s; its turns take the first 26 s)")
    args = parser.parse_args()
    print("seed | applied | worst scale-factor error % | worst cross-axis error % | largest standard error % | "
          "largest true scale error %")
    rows = []
    for seed in seeds_of(args.seeds):
        with tempfile.TemporaryDirectory() as scratch:
            row = run(seed, args.duration, Path(scratch))
        rows.append(row)
        print(f"{seed:4d} | {row[0]:2d}/{row[1]:2d} | {row[2]:.3f} | {row[3]:.3f} | {row[4]:.3f} | {row[5]:.2f}", flush=True)
    figures = np.array([r[2:] for r in rows])
    print(f"over {len(rows)} seeds: applied {sum(r[0] for r in rows)}/{sum(r[1] for r in rows)}, scale factors within "
          f"{figures[:, 0].max():.3f} %, cross-axis terms within {figures[:, 1].max():.3f} %, standard errors up to "
          f"{figures[:, 2].max():.3f} % (true scale errors up to {figures[:, 3].max():.2f} %)")


if __name__ == "__main__":
    main_()
