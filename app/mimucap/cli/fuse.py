"""``mimucap fuse``: orientation of every sample of a recording from its raw IMU channels.

``mimucap fuse INPUT [--algorithm ekf-taylor3|ekf-rk4|taylor3|rk4] [--offline] [--no-mag]
[--sensor ID] --out OUT.{csv,h5,npy}``

INPUT is a BROAD-style HDF5 trial (``imu_gyr``, ``imu_acc``, ``imu_mag`` unless ``--no-mag``,
attribute ``sampling_rate``) or a MimuCap session (:func:`mimucap.io.session.read_session`). A session
gives one output per sensor with a gyroscope, named ``OUT_<sensor id>.<ext>``, or only the
sensor chosen with ``--sensor`` (written to OUT itself); its magnetometer samples are calibrated
first as the processing path does (the session's calibrations, else the stored ones, or
``--mag-calibration FILE``).

Output: one row per input sample, ``q_world_from_sensor`` (world ENU, scalar first; NaN rows
before the first valid accelerometer sample). CSV: header ``t_s,qw,qx,qy,qz``; HDF5: dataset
``q_world_from_sensor`` (N, 4) plus ``t_s`` (N,) and ``flags`` (N,) uint8 (bits of
:mod:`mimucap.core.fusion.state`); ``.npy``: the (N, 4) array.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from mimucap.cli import check_output_path, refuse_to_overwrite_input
from mimucap.core.fusion.algorithms import ALGORITHMS

if TYPE_CHECKING:
    import numpy as np

    from mimucap.core.fusion.ekf import FusionResult

OUTPUT_SUFFIXES = (".csv", ".h5", ".hdf5", ".npy")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "fuse", help="orientation (q_world_from_sensor) from gyro, accelerometer, magnetometer",
        description="Estimate q_world_from_sensor (ENU, scalar first) for every sample of a "
                    "BROAD HDF5 trial or a MimuCap session.",
    )
    parser.add_argument("input", type=Path, help="BROAD trial (.hdf5) or MimuCap session (.h5)")
    parser.add_argument("--algorithm", choices=sorted(ALGORITHMS), default="ekf-taylor3",
                        help="EKF with taylor3/rk4 propagation, or gyro-only integration")
    parser.add_argument("--offline", action="store_true",
                        help="forward EKF plus RTS smoother over the whole recording")
    parser.add_argument("--no-mag", action="store_true", help="ignore the magnetometer")
    parser.add_argument("--sensor", help="session input: fuse only this sensor id")
    parser.add_argument("--mag-calibration", action="append", metavar="FILE", default=None,
                        help="session input: magnetometer calibration JSON to apply (repeatable; default: the "
                             "session's, then the user's stored ones)")
    parser.add_argument("--out", type=Path, required=True, help="output .csv, .h5 or .npy")
    parser.set_defaults(func=run)


def _inputs(path: Path, sensor: str | None, no_mag: bool,
            mag_files: list[str] | None = None) -> list[tuple[str | None, np.ndarray, np.ndarray,
                                                              np.ndarray | None, np.ndarray | None]]:
    """``(sensor id or None, t_s, gyr, acc, mag)`` for each stream to fuse; a session's
    magnetometer samples come calibrated, as the processing path calibrates them (the session's
    own calibrations, the stored ones, or ``mag_files``; :mod:`mimucap.cli.session_input`)."""
    from mimucap.cli.session_input import magnetometer_calibrations, warn_about_magnetometers
    from mimucap.io.broad import is_broad_file, read_broad
    from mimucap.io.session import read_session

    if not path.is_file():
        raise OSError(f"{path}: no such file")
    if is_broad_file(path):
        if sensor is not None:
            raise ValueError(f"{path}: a BROAD trial has one sensor; --sensor does not apply")
        trial = read_broad(path, require_mag=False)
        if trial.mag_uT is None and not no_mag:
            raise ValueError(f"{path}: BROAD trial without 'imu_mag' (magnetometer, µT): "
                             "fuse it without the magnetometer with --no-mag")
        if mag_files:
            raise ValueError(f"{path}: --mag-calibration applies to MimuCap sessions (sensor ids), not to a BROAD trial")
        return [(None, trial.t_s, trial.gyr_rad_s, trial.acc_m_s2, trial.mag_uT)]
    session = read_session(path)
    calibrations = {}
    if not no_mag:
        mags = magnetometer_calibrations(session, mag_files)
        for line in mags.lines():
            print(f"  {line}")
        warn_about_magnetometers("fuse", session, mags)
        calibrations = mags.magnetometer
    streams = session.sensors
    if sensor is not None:
        if sensor not in streams:
            raise ValueError(f"{path}: no sensor {sensor!r} (sensors: {', '.join(sorted(streams)) or 'none'})")
        streams = {sensor: streams[sensor]}
    chosen = []
    for sensor_id, stream in streams.items():
        if stream.gyr is None:
            if sensor is not None:
                raise ValueError(f"{path}: sensor {sensor_id} has no gyroscope channel")
            continue
        mag = stream.mag_uT
        if mag is not None and sensor_id in calibrations:
            mag = calibrations[sensor_id].apply(mag, sensor_id)
        chosen.append((sensor_id, stream.t_s, stream.gyr, stream.acc, mag))
    if not chosen:
        raise ValueError(f"{path}: no sensor with a gyroscope channel to fuse")
    return chosen


def _output_path(out: Path, sensor_id: str | None, several: bool) -> Path:
    if sensor_id is None or not several:
        return out
    return out.with_name(f"{out.stem}_{sensor_id}{out.suffix}")


def write_orientation(path: Path, t_s: np.ndarray, result: FusionResult) -> None:
    """Write ``q_world_from_sensor`` as CSV, HDF5 or .npy (chosen by the suffix of ``path``)."""
    import h5py
    import numpy as np

    from mimucap.core.fusion.state import FLAG_NAMES

    q = result.q_world_from_sensor
    suffix = path.suffix.lower()
    if suffix == ".csv":
        table = np.column_stack((t_s, q))
        np.savetxt(path, table, delimiter=",", header="t_s,qw,qx,qy,qz", comments="",
                   fmt=["%.6f", "%.9f", "%.9f", "%.9f", "%.9f"])
    elif suffix in (".h5", ".hdf5"):
        with h5py.File(path, "w") as handle:
            dataset = handle.create_dataset("q_world_from_sensor", data=q)
            dataset.attrs["description"] = "q_world_from_sensor, world ENU, scalar first [w, x, y, z]"
            handle.create_dataset("t_s", data=t_s).attrs["unit"] = "s"
            flags = handle.create_dataset("flags", data=result.flags)
            flags.attrs["bits"] = ", ".join(f"{name}={bit}" for name, bit in FLAG_NAMES.items())
    elif suffix == ".npy":
        np.save(path, q)
    else:
        raise ValueError(f"{path}: output must end in {', '.join(OUTPUT_SUFFIXES)}")


def _sensor_label(sensor_id: str | None) -> str:
    """``"sensor S03: "`` heading a line about one sensor of several (``""`` for a single one)."""
    return f"sensor {sensor_id}: " if sensor_id is not None else ""


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from mimucap.core.fusion.ekf import fuse

    if args.out.suffix.lower() not in OUTPUT_SUFFIXES:
        raise ValueError(f"{args.out}: output must end in {', '.join(OUTPUT_SUFFIXES)}")
    check_output_path(args.out)
    refuse_to_overwrite_input(args.out, args.input)  # also when per-sensor names derive from it: a slip
    inputs = _inputs(args.input, args.sensor, args.no_mag, args.mag_calibration)
    estimator = fuse
    if args.offline:
        from mimucap.core.fusion.offline import fuse_offline as estimator
    several = len(inputs) > 1
    for sensor_id, *_ in inputs:  # every file to write, before any is written
        refuse_to_overwrite_input(_output_path(args.out, sensor_id, several), args.input)
    results = []
    for sensor_id, t_s, gyr, acc, mag in inputs:  # every sensor fused, and checked, before any file is written
        name = f"{args.input}: {_sensor_label(sensor_id)}"
        if len(t_s) == 0:
            raise ValueError(f"{name}no samples (0 rows): nothing to fuse")
        result = estimator(t_s, gyr, acc, None if args.no_mag else mag,
                           algorithm=args.algorithm, use_mag=not args.no_mag)
        q = result.q_world_from_sensor
        # an initialised filter stays so: a finite last row answers at once for hours of samples
        if not (np.isfinite(q[-1]).all() or np.isfinite(q).all(axis=-1).any()):
            raise ValueError(f"{name}fusion gave no orientation: no valid accelerometer sample among "
                             f"{len(t_s)} (all missing, NaN or zero); nothing was written")
        results.append((sensor_id, np.asarray(t_s, dtype=np.float64), result))
    for sensor_id, t_s, result in results:
        path = _output_path(args.out, sensor_id, several)
        write_orientation(path, t_s, result)
        counts = result.counters[0]
        print(f"{_sensor_label(sensor_id)}{counts['samples']} samples -> {path} (skipped {counts['skipped']}, "
              f"rest {counts['rest']}, magnetometer rejected {counts['mag_rejected']} and missing or invalid "
              f"{counts['mag_missing']}, accelerometer rejected {counts['acc_rejected']} and missing or invalid "
              f"{counts['acc_missing']})", file=sys.stdout)
    return 0
