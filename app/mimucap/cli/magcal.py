"""``mimucap magcal``: fit a magnetometer calibration from files, or run the protocol study.

``mimucap magcal fit FILE... [--format auto|csv|xsens|session] [--sensor ID]
[--unit uT|gauss|counts] [--scale-to-uT F] [--field-uT F] [--method ellipsoid|quadric]
[--json] [--save]`` fits the samples of all files together. Units: ``--unit`` overrides
what a file states (sunsided headers say gauss, sessions µT, Xsens exports are arbitrary
units, i.e. counts); a plain 3-column CSV without a stated unit is taken as µT. Counts need
``--scale-to-uT`` (µT per count) and all results are then in µT. With ``--json`` one JSON
object is printed with exactly the keys ``offset_uT``, ``soft_iron``, ``field_uT``,
``rms_residual_uT``, ``rms_residual_pct``, ``condition``, ``samples_used``,
``samples_rejected``, ``verdict``, ``reasons``, ``gyr_correction``, ``gyr_quality``. Where the
files carry the gyroscope's samples with the magnetometer's (a session, an Xsens export), the
gyroscope's scale factors are estimated from the same turns
(:mod:`mimucap.core.magcal.gyro_scale`) and stored with the calibration; a poorly determined
estimate is not applied, and the output says why. ``--save`` stores the calibration for the
sensor's device (see :mod:`mimucap.io.calibration_store`: the device the file names, a
session's recorded device or an Xsens export's device id; a file that names none stores it for
an unknown device, under the sensor id). A refused fit exits with status 1 and its
reason. A fit whose verdict is ``fail`` is printed but never saved (a calibration already
stored for the sensor is kept) and exits with status :data:`FAIL_EXIT_STATUS`, so that a
script can tell it from a usable fit.

A single MimuCap session file is fitted per sensor (every sensor with a magnetometer, or only
``--sensor``): each from its samples in the session's magnetometer-turn windows, which run from
a marker labelled "magnetometer turns" to the next marker (:mod:`mimucap.core.phase_markers`; all its
samples when no marker says so). One line per sensor gives its verdict; ``--json`` prints one
object per sensor and line, with a ``sensor`` key besides the keys above when there are
several; ``--save`` stores every usable fit. The exit status is 1 if a sensor's fit was
refused, else :data:`FAIL_EXIT_STATUS` if one failed its checks, else 0.

``mimucap magcal study [--trials N] [--seed K] [--folder DIR] [--plot OUT.png]`` prints the Tables 1–2
of Choe et al., "Study of calibration method of low-cost MEMS magnetometer"
(centre and radii RMSE against a reference fit, protocol durations). Without ``--folder`` the
trials are simulated (MPU-9250-like noise, 49.3 µT field). With ``--folder`` the trials are
real recordings: ``DIR/reference/`` holds the dense reference recording (all files fitted
together), and ``DIR/figure8-1/`` … ``DIR/single_axis-3/`` (any folder named
``<protocol>-<turns>``) hold one trial per file, or per sub-folder whose files are fitted
together. ``--plot`` also writes a PNG with the fitted ellipsoids per protocol
(:mod:`mimucap.cli.magcal_plot`, VTK off screen).
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING

from mimucap.cli import check_output_path
from mimucap.core.wording import plural
from mimucap.io.input_names import FORMATS, MAG_UNITS

if TYPE_CHECKING:
    import numpy as np

    from mimucap.core.magcal.study import StudyResult, Trial
    from mimucap.io.magdata import MagRecording

#: Exit status of a fit printed but failing its quality checks (1 is a fit refused outright).
FAIL_EXIT_STATUS = 3
JSON_KEYS = (
    "offset_uT", "soft_iron", "field_uT", "rms_residual_uT", "rms_residual_pct", "condition",
    "samples_used", "samples_rejected", "verdict", "reasons", "gyr_correction", "gyr_quality",
)
_PROTOCOL_FOLDER = re.compile(r"^[a-z0-9_]+-[0-9]+$")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``magcal`` with its ``fit`` and ``study`` sub-commands."""
    parser = subparsers.add_parser(
        "magcal", help="magnetometer calibration: fit files, run the protocol study",
        description="Magnetometer calibration (hard and soft iron).",
    )
    parser.set_defaults(func=lambda args: (parser.print_help(), 2)[1])
    actions = parser.add_subparsers(dest="magcal_command", metavar="ACTION")

    fit = actions.add_parser("fit", help="fit a calibration to the samples of one or more files")
    fit.add_argument("files", nargs="+", metavar="FILE",
                     help="CSV, Xsens export or session file (a session alone: every sensor, from its magnetometer turns)")
    _add_input_options(fit)
    fit.add_argument("--field-uT", type=float, default=None, metavar="F", help="known local field magnitude, µT")
    fit.add_argument("--method", choices=("ellipsoid", "quadric"), default="ellipsoid",
                     help="ellipsoid-specific fit (default) or the general quadric least squares")
    fit.add_argument("--json", action="store_true", help="print one JSON object")
    fit.add_argument("--save", action="store_true", help="store the calibration for the sensor")
    fit.set_defaults(func=run_fit)

    study = actions.add_parser(
        "study", help="compare rotation protocols (Choe et al., Tables 1-2)",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Fit repeated trials of each rotation protocol and print the RMSE of the fitted centre\n"
            "and radii against a reference fit, and each protocol's duration.\n\n"
            "Without --folder the trials are simulated (MPU-9250-like noise, 49.3 uT field).\n"
            "With --folder DIR they are real recordings:\n"
            "  DIR/reference/           the dense reference recording (all files fitted together)\n"
            "  DIR/<protocol>-<turns>/  e.g. figure8-3, single_axis-1: one trial per file, or per\n"
            "                           sub-folder whose files are fitted together"
        ),
    )
    study.add_argument("--trials", type=int, default=10, help="trials per protocol (simulated; default 10)")
    study.add_argument("--seed", type=int, default=0, help="random seed of the simulated sensor and trials")
    study.add_argument("--folder", type=Path, default=None, help="folder of real recordings (layout above)")
    study.add_argument("--plot", type=Path, default=None, metavar="PNG", help="also draw the fitted ellipsoids per protocol")
    _add_input_options(study)
    study.set_defaults(func=run_study)


def _add_input_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--format", choices=FORMATS, default="auto", help="input format (default: auto)")
    parser.add_argument("--sensor", default=None, metavar="ID", help="sensor id (selects a session's sensor)")
    parser.add_argument("--unit", choices=MAG_UNITS, default=None, help="unit of the samples (default: as the file states, else uT)")
    parser.add_argument("--scale-to-uT", type=float, default=None, metavar="F", help="µT per count for --unit counts")


def _samples_uT(recordings: list[MagRecording], args: argparse.Namespace) -> tuple[np.ndarray, np.ndarray | None]:
    import numpy as np

    from mimucap.io.magdata import to_microtesla

    mags, accs = [], []
    for recording in recordings:
        unit = args.unit or recording.unit or "uT"
        mags.append(to_microtesla(recording.mag, unit, args.scale_to_uT, recording.source))
        acc = recording.acc_at_mag_times()
        accs.append(acc if acc is not None else np.full((len(recording.mag), 3), np.nan))
    mag = np.vstack(mags)
    acc = np.vstack(accs)
    return mag, (acc if np.isfinite(acc).any() else None)


def _gyr_samples(recordings: list[MagRecording]) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The times (N,) s and raw gyroscope rates (N, 3) rad/s at the magnetometer's samples of
    ``recordings``, in order (a gyroscope sampled at other instants gives its mean rate over each
    magnetometer interval); (None, None) unless every recording has gyroscope samples in the
    magnetometer's frame."""
    import numpy as np

    from mimucap.core.magcal.gyro_scale import rates_at

    times, rates = [], []
    for recording in recordings:
        imu = recording.imu
        if imu is None or imu.gyr is None or recording.t_s is None or not recording.imu_in_mag_frame:
            return None, None
        times.append(recording.t_s)
        same = len(imu.t_s) == len(recording.t_s) and np.array_equal(imu.t_s, recording.t_s)
        rates.append(imu.gyr if same else rates_at(recording.t_s, imu.t_s, imu.gyr))
    return np.concatenate(times), np.vstack(rates)


def _sensor_id(recordings: list[MagRecording], requested: str | None) -> str:
    if requested is not None:
        return requested
    ids = sorted({r.sensor_id for r in recordings if r.sensor_id is not None})
    if len(ids) > 1:
        raise ValueError(f"the files hold several sensors ({', '.join(ids)}): choose one with --sensor")
    return ids[0] if ids else "unknown"


def _samples_origin(recordings: list[MagRecording], requested: str | None) -> str:
    """The files (and sensor) the fitted samples came from, to head an error message."""
    files = ", ".join(dict.fromkeys(r.source.split("#", 1)[0] for r in recordings))
    sensors = sorted({r.sensor_id for r in recordings if r.sensor_id is not None} | ({requested} - {None}))
    return files + (f": sensor {', '.join(sensors)}" if sensors else "")


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def _fit(recordings: list[MagRecording], sensor_id: str, args: argparse.Namespace, protocol: str):
    """The :class:`~mimucap.core.magcal.calibrate.CalibrationResult` of the samples of ``recordings``;
    a refused fit raises ``ValueError`` naming whose samples they were."""
    from mimucap.core.magcal.calibrate import calibrate
    from mimucap.core.magcal.fit import FitSettings

    mag, acc = _samples_uT(recordings, args)
    t_s, gyr = _gyr_samples(recordings)
    created = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    devices = {r.device_id for r in recordings}
    try:
        return calibrate(
            mag, sensor_id, acc=acc, settings=FitSettings(method=args.method, field_uT=args.field_uT),
            protocol=protocol, created_utc=created, device_id=devices.pop() if len(devices) == 1 else None,
            t_s=t_s, gyr_raw_rad_s=gyr,
        )
    except ValueError as error:  # e.g. too few samples: say whose samples
        raise ValueError(f"{_samples_origin(recordings, sensor_id)}: {error}") from None


def _summary(result) -> dict:
    """The JSON object of one fit (keys :data:`JSON_KEYS`)."""
    fit, quality = result.fit, result.quality
    return {
        "offset_uT": [float(v) for v in fit.offset_uT],
        "soft_iron": [[float(v) for v in row] for row in fit.soft_iron],
        "field_uT": float(fit.field_uT),
        "rms_residual_uT": quality.rms_residual_uT,
        "rms_residual_pct": quality.rms_residual_pct,
        "condition": _finite_or_none(quality.condition),
        "samples_used": fit.samples_used,
        "samples_rejected": fit.samples_rejected,
        "verdict": quality.verdict,
        "reasons": list(quality.reasons),
        "gyr_correction": [[float(v) for v in row] for row in result.calibration.gyr_correction],
        "gyr_quality": result.calibration.gyr_quality,
    }


def _save(result, args: argparse.Namespace) -> Path | None:
    """Store a usable fit when ``--save`` asks; a failed one is never stored (said on stderr)."""
    from mimucap.io.calibration_store import CalibrationStore

    if not args.save:
        return None
    if result.quality.verdict == "fail":
        print(f"mimucap magcal: the fit of sensor {result.calibration.sensor_id} failed its quality checks: "
              f"not saved (a calibration stored before is kept)", file=sys.stderr)
        return None
    return CalibrationStore().save(result.calibration)


def _print_detail(result, heading: str, saved: Path | None) -> None:
    from mimucap.core.device_identity import describe_device

    fit, quality = result.fit, result.quality
    print(heading)
    print(f"offset_uT      {_vector(fit.offset_uT)}")
    for index, row in enumerate(fit.soft_iron):
        print(f"{'soft_iron' if index == 0 else '':<14} {_vector(row, 4)}")
    print(f"field_uT       {fit.field_uT:.2f} ({'given' if fit.field_given else 'fitted mean radius'})")
    print(f"radii_uT       {_vector(fit.ellipsoid.radii)} (ratio {quality.radii_ratio:.3f})")
    print(f"rms residual   {quality.rms_residual_uT:.3f} µT ({quality.rms_residual_pct:.2f} %)")
    coverage = ", ".join(f"{a} {c:.0%}" for a, c in zip("xyz", quality.axis_coverage))
    print(f"coverage       condition {quality.condition:.1f}; azimuth {coverage}")
    if quality.dip_std_deg is not None:
        print(f"dip            {quality.dip_mean_deg:.1f}° ± {quality.dip_std_deg:.1f}°")
    print(
        f"samples        used {fit.samples_used}, rejected {fit.samples_rejected} "
        f"(NaN/inf {fit.samples_nonfinite}, outliers {fit.samples_outliers}), thinned {fit.samples_thinned}"
    )
    print(f"verdict        {quality.verdict}")
    for reason in quality.reasons:
        print(f"  - {reason}")
    print(f"gyroscope      {result.gyro.summary()}")
    print(f"device         {describe_device(result.calibration.device_id) if result.calibration.device_id else 'not known'}")
    if saved is not None:
        print(f"saved          {saved}")


def run_fit(args: argparse.Namespace) -> int:
    """Fit, print (text or JSON) and optionally save; returns the exit code."""
    from mimucap.io.magdata import detect_format, read_mag_files

    if len(args.files) == 1 and Path(args.files[0]).is_file() and (
            args.format == "session" or (args.format == "auto" and detect_format(args.files[0]) == "session")):
        return _run_session_fit(args)
    recordings = read_mag_files(args.files, args.format, args.sensor)
    sensor_id = _sensor_id(recordings, args.sensor)
    result = _fit(recordings, sensor_id, args, "file")
    saved = _save(result, args)
    status = FAIL_EXIT_STATUS if result.quality.verdict == "fail" else 0
    if args.json:
        print(json.dumps(_summary(result)))
        return status
    _print_detail(result, f"sensor {sensor_id}: {plural(len(recordings), 'file')}, {result.fit.samples_input} samples, "
                          f"method {result.fit.method}", saved)
    return status


def session_turn_recordings(path: Path, sensor: str | None) -> tuple[dict[str, MagRecording], list[tuple[float, float]]]:
    """Per sensor with a magnetometer (only ``sensor`` if given), its samples in the session's
    magnetometer-turn windows (markers "magnetometer turns", :mod:`mimucap.core.phase_markers`), and
    those windows (s); all its samples, and no window, when no marker marks turns. µT, sensor
    frame; the accelerometer samples come along for the dip figure."""
    import numpy as np

    from mimucap.core import phase_markers
    from mimucap.io.magdata import MagRecording
    from mimucap.io.session import read_session

    session = read_session(path, include_truth=False)
    devices = session.devices()
    # Just past the last sample, so that a window running to the end of the recording holds it.
    end_s = max((float(s.t_s[-1]) for s in session.sensors.values() if len(s)), default=0.0) + 1.0
    windows = phase_markers.phase_windows(session.markers, phase_markers.MAG_TURNS, end_s)
    if sensor is not None and sensor not in session.sensors:
        raise ValueError(f"{path}: no sensor {sensor} in this session (sensors: {', '.join(session.sensors) or 'none'})")
    recordings = {}
    for sid, stream in session.sensors.items():
        if sensor is not None and sid != sensor:
            continue
        if stream.mag_uT is None:
            if sensor is not None:
                raise ValueError(f"{path}: sensor {sid} has no magnetometer samples")
            continue
        t = np.asarray(stream.t_s, dtype=np.float64)
        keep = np.zeros(t.shape, dtype=bool) if windows else np.ones(t.shape, dtype=bool)
        for start_s, stop_s in windows:
            keep |= (t >= start_s) & (t < stop_s)
        picked = stream.rows(keep)   # one selection: the magnetometer rows and their companions
        recordings[sid] = MagRecording(
            source=f"{path}#{sid}", sensor_id=sid, mag=np.asarray(picked.mag_uT, dtype=np.float64), unit="uT",
            t_s=np.asarray(picked.t_s, dtype=np.float64), imu=picked, device_id=devices[sid].device_id)
    if not recordings:
        raise ValueError(f"{path}: no sensor with a magnetometer in this session "
                         f"(sensors: {', '.join(session.sensors) or 'none'})")
    return recordings, windows


def _run_session_fit(args: argparse.Namespace) -> int:
    """A session file: every sensor (or ``--sensor``) fitted on its own from the session's
    magnetometer turns; the exit status is 1 if a fit was refused, else
    :data:`FAIL_EXIT_STATUS` if one failed its checks, else 0. Usable fits are saved either way."""
    path = Path(args.files[0])
    recordings, windows = session_turn_recordings(path, args.sensor)
    where = (", ".join(f"{a:.1f}-{b:.1f} s" for a, b in windows)
             if windows else "all samples (no 'magnetometer turns' marker)")
    protocol = "single_axis" if windows else "file"
    results, refused = {}, {}
    for sid, recording in recordings.items():
        try:
            results[sid] = _fit([recording], sid, args, protocol)
        except ValueError as error:
            refused[sid] = str(error)
    saved = {sid: _save(result, args) for sid, result in results.items()}
    for sid, reason in refused.items():
        print(f"mimucap magcal: {reason}", file=sys.stderr)
    failed = [sid for sid, result in results.items() if result.quality.verdict == "fail"]
    status = 1 if refused else FAIL_EXIT_STATUS if failed else 0
    several = len(recordings) > 1
    if args.json:
        for sid, result in results.items():
            print(json.dumps({"sensor": sid, **_summary(result)} if several else _summary(result)))
        return status
    if not several:
        for sid, result in results.items():
            _print_detail(result, f"sensor {sid}: {path}, magnetometer turns: {where}, {result.fit.samples_input} "
                                  f"samples, method {result.fit.method}", saved[sid])
        return status
    print(f"{path}: {len(recordings)} sensors, magnetometer turns: {where}, method {args.method}")
    print(f"{'sensor':8s} {'samples':>7s}  {'offset_uT':26s} {'field_uT':>8s} {'rms_uT':>7s} {'condition':>9s}  "
          f"{'verdict':8s} saved")
    folders = {p.parent for p in saved.values() if p is not None}
    for sid in recordings:
        if sid in refused:
            print(f"{sid:8s} {len(recordings[sid].mag):7d}  refused: {refused[sid].split(': ')[-1]}")
            continue
        fit, quality = results[sid].fit, results[sid].quality
        print(f"{sid:8s} {fit.samples_input:7d}  {_vector(fit.offset_uT, 2):26s} {fit.field_uT:8.2f} "
              f"{quality.rms_residual_uT:7.3f} {quality.condition:9.1f}  {quality.verdict:8s} "
              f"{'yes' if saved[sid] is not None else '-'}")
        for reason in quality.reasons:
            print(f"  - {reason}")
        print(f"  gyroscope {results[sid].gyro.summary()}")
    devices = sorted({r.device_id.partition("/")[0] for r in recordings.values() if r.device_id})
    unknown = [sid for sid, r in recordings.items() if not r.device_id]
    if devices:
        print(f"devices        {', '.join(devices)}" + (f"; not known for {', '.join(unknown)}" if unknown else ""))
    elif unknown:
        print("devices        not known (the session does not say): stored under the sensor ids")
    for folder in sorted(folders):
        print(f"saved in {folder}")
    return status


def _vector(values, digits: int = 3) -> str:
    return "[" + ", ".join(f"{v:.{digits}f}" for v in values) + "]"


def _folder_trial(paths: list[Path], args: argparse.Namespace) -> Trial:
    from mimucap.core.magcal.study import Trial
    from mimucap.io.magdata import read_mag_files

    recordings = read_mag_files(paths, args.format, args.sensor)
    mag, _ = _samples_uT(recordings, args)
    durations = [float(r.t_s[-1] - r.t_s[0]) for r in recordings if r.t_s is not None and len(r.t_s) > 1]
    duration = float(sum(durations)) if len(durations) == len(recordings) else None
    return Trial(mag_uT=mag, duration_s=duration)


def _trial_paths(folder: Path) -> list[list[Path]]:
    entries = sorted(p for p in folder.iterdir() if not p.name.startswith("."))
    trials = []
    for entry in entries:
        if entry.is_dir() and not (entry / "mag_hmc5883l.csv.gz").is_file():
            files = sorted(p for p in entry.iterdir() if not p.name.startswith("."))
            if files:
                trials.append(files)
        else:
            trials.append([entry])
    return trials


def run_study(args: argparse.Namespace) -> int:
    """Run the protocol study (simulated or on a folder) and print the tables."""
    from mimucap.core.magcal import study as magcal_study

    if args.plot is not None:
        check_output_path(args.plot)  # before the study, which takes a while
    if args.folder is None:
        result = magcal_study.simulate_study(magcal_study.StudySettings(trials=args.trials, seed=args.seed))
    else:
        result = _folder_study(args)
    print(magcal_study.format_tables(result))
    if args.plot is not None:
        from mimucap.cli.magcal_plot import render_study_png

        print(f"figure: {render_study_png(result, args.plot)}")
    return 0


def _folder_study(args: argparse.Namespace) -> StudyResult:
    from mimucap.core.magcal.study import evaluate_protocols

    folder = args.folder
    if not folder.is_dir():
        raise FileNotFoundError(f"{folder}: no such folder")
    reference_dir = folder / "reference"
    if not reference_dir.is_dir():
        raise ValueError(f"{folder}: the study folder needs a 'reference' sub-folder with the dense recording")
    reference_files = [p for group in _trial_paths(reference_dir) for p in group]
    if not reference_files:
        raise ValueError(f"{reference_dir}: no recording in the reference folder")
    reference = _folder_trial(reference_files, args)
    trials: dict[str, list[Trial]] = {}
    for protocol_dir in sorted(p for p in folder.iterdir() if p.is_dir() and p.name != "reference"):
        if not _PROTOCOL_FOLDER.match(protocol_dir.name):
            raise ValueError(f"{protocol_dir}: protocol folders are named <protocol>-<turns>, e.g. figure8-3")
        groups = _trial_paths(protocol_dir)
        if not groups:
            raise ValueError(f"{protocol_dir}: no trial (one file, or one sub-folder of files, per trial)")
        trials[protocol_dir.name] = [_folder_trial(group, args) for group in groups]
    if not trials:
        raise ValueError(f"{folder}: no protocol folders (named like figure8-1 or single_axis-1)")
    return evaluate_protocols(
        trials, reference.mag_uT, description=f"recordings in {folder} (reference: {reference_dir})"
    )
