"""``mimucap simulate``: write a session file from the simulated sensor suit.

``mimucap simulate --scenario NAME --duration S --sensors N --seed K --out FILE.h5
[--rate HZ] [--drops P] [--no-truth] [--errors PRESET] [--height M] [--onboard]
[--disturbance BX,BY,BZ,START,END ...] [--room clean|clinic|treadmill] [--[no-]magcal-turns]``

Scenarios: ``demo`` (magnetometer turns, then N-pose, T-pose, walking, turning, squats, arm
raises, looping from the N-pose),
``bodycal`` (N-pose 3 s, T-pose 3 s, N-pose), or one activity (``npose``, ``tpose``,
``walk``, ``turn``, ``arm_raise``, ``squat``, ``mag_single_axis``, ``mag_figure8``,
``mag_tumble``), or a clinical test (``tug``, ``walk10m``, ``walk2min``, ``walk6min``,
``chair_stand``; :mod:`mimucap.core.simulate.clinical_tests`: the truth holds its true results
in the truth group's ``protocol_json``). Sensors: 1..17 (10: the ten-segment suit; 17: the
fifteen-segment suit with second units on thorax and pelvis, worn but assigned to no segment:
each segment carries one sensor). The file names each unit's device (the suit's seed and error
model, and the unit). ``--disturbance`` adds a magnetic field (world ENU, µT) to every sensor
from START to END seconds (0.5-s ramps), e.g. ``30,0,-10,5,8``. ``--room`` puts the subject in a
room whose field changes with position, measured by each unit where it is
(:mod:`mimucap.core.simulate.rooms`): ``clean`` (default, the earth field alone), ``clinic`` (a
reinforced floor, strongest at the feet, and a steel bed beside the walkway, passed on the way
out and back) or ``treadmill`` (the walking happens on a treadmill). The file (format in ``docs/session-format.md``)
holds the raw streams, a marker at the start of each phase ("magnetometer turns", "N-pose",
"T-pose", "walk", ...; :mod:`mimucap.core.phases`) and, unless ``--no-truth``, the ground truth.
The demo begins with the magnetometer turns: every unit is taken off the body, the units are
held together and turned once about each of their axes (about 26 s), then worn again, so that
``mimucap magcal fit FILE.h5`` can calibrate them all from the file; ``--no-magcal-turns``
leaves them out, ``--magcal-turns`` puts them before any other scenario.
Prints one summary line. The duration must hold at least one sample (≥ 1/rate s) and at most
:data:`MAX_SENSOR_SAMPLES` sensor samples (duration × rate × sensors, e.g. 100 minutes of 10
sensors at 100 Hz): a larger request is refused before any memory is taken.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from pathlib import Path

from typing import TYPE_CHECKING

from mimucap.cli import check_output_path
from mimucap.core.simulate.names import ERROR_PRESET_NAMES, ROOM_NAMES, SCENARIOS

if TYPE_CHECKING:
    from mimucap.core.simulate.magnetic_field import MagneticDisturbance

#: Most sensor samples (duration × rate × sensors) one simulation may hold: the simulation, its
#: truth and the session written from it hold every sample several times over (raw channels,
#: the truth's per-sensor orientations, positions and fields, the file's buffers), so this bound
#: keeps a simulation within a few gigabytes of memory, e.g. 10 sensors at 100 Hz for 100 minutes.
MAX_SENSOR_SAMPLES = 6_000_000


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``simulate`` sub-command."""
    parser = subparsers.add_parser(
        "simulate", help="write a session file from the simulated sensor suit (with ground truth)",
        description="Simulate a sensor suit on a moving skeleton and write an HDF5 session file.",
    )
    parser.add_argument("--scenario", default="demo", help=f"one of: {', '.join(SCENARIOS)} (default demo)")
    parser.add_argument("--duration", type=float, default=30.0, metavar="S",
                        help=f"seconds to simulate (default 30; duration × rate × sensors at most "
                             f"{MAX_SENSOR_SAMPLES:,})")
    parser.add_argument("--sensors", type=int, default=10, metavar="N", help="number of sensors 1..17 (default 10)")
    parser.add_argument("--seed", type=int, default=0, metavar="K", help="random seed (default 0)")
    parser.add_argument("--out", required=True, metavar="FILE.h5", help="session file to write")
    parser.add_argument("--rate", type=float, default=100.0, metavar="HZ", help="sample rate (default 100 Hz)")
    parser.add_argument("--drops", type=float, default=0.0, metavar="P", help="packet drop probability 0..0.9 (default 0)")
    parser.add_argument("--no-truth", action="store_true", help="leave the ground truth out of the file")
    parser.add_argument("--errors", default="default", metavar="PRESET",
                        help=f"sensor error model: {', '.join(ERROR_PRESET_NAMES)} (default default)")
    parser.add_argument("--onboard", action="store_true", help="sensors also send on-board orientation (like a BNO055)")
    parser.add_argument("--height", type=float, default=1.75, metavar="M", help="subject height in metres (default 1.75)")
    parser.add_argument("--magcal-turns", action=argparse.BooleanOptionalAction, default=None,
                        help="begin with the magnetometer turns of all units (default: for the demo only)")
    parser.add_argument("--room", default="clean", metavar="ROOM",
                        help=f"room whose magnetic field varies with position: {', '.join(ROOM_NAMES)} (default clean: "
                             f"the earth field alone; clinic: reinforced floor, steel bed beside the walkway; "
                             f"treadmill: walking on a treadmill)")
    parser.add_argument("--disturbance", action="append", default=[], metavar="BX,BY,BZ,START,END",
                        help="add a field (world ENU, µT) to all sensors from START to END s; repeatable")
    parser.set_defaults(func=run)


def parse_disturbance(text: str) -> MagneticDisturbance:
    """``"BX,BY,BZ,START,END"`` (µT, µT, µT, s, s) → a :class:`MagneticDisturbance` for all sensors."""
    from mimucap.core.simulate.magnetic_field import MagneticDisturbance

    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) != 5 or not all(map(math.isfinite, values)):
        raise ValueError(f"--disturbance {text!r}: expected five numbers BX,BY,BZ,START,END (µT and s)")
    return MagneticDisturbance(field_uT=tuple(values[:3]), start_s=values[3], end_s=values[4])


def check_size(duration_s: float, rate_hz: float, n_sensors: int) -> None:
    """Refuse a simulation that would hold no sample, or more than
    :data:`MAX_SENSOR_SAMPLES` (which would exhaust the memory before writing anything)."""
    if not duration_s * rate_hz >= 1.0:
        raise ValueError(f"--duration {duration_s:g} s holds no sample at {rate_hz:g} Hz: give at least "
                         f"{1.0 / rate_hz:g} s")
    samples = duration_s * rate_hz * n_sensors
    if samples > MAX_SENSOR_SAMPLES:
        most_s = MAX_SENSOR_SAMPLES / (rate_hz * n_sensors)
        raise ValueError(f"--duration {duration_s:g} s of {n_sensors} sensors at {rate_hz:g} Hz is "
                         f"{samples:.3g} samples, more than the {MAX_SENSOR_SAMPLES:,} a simulation can hold "
                         f"in memory: at most {most_s:.0f} s at this rate and sensor count")


def run(args: argparse.Namespace) -> int:
    """Simulate, write the file and print one summary line; bad arguments raise ValueError."""
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.core.simulate.sensor_errors import error_model
    from mimucap.core.simulate.suit import simulate_session
    from mimucap.io.session import session_from_simulation, write_session

    if Path(args.out).suffix.lower() not in (".h5", ".hdf5"):
        raise ValueError(f"{args.out}: a simulated session is an HDF5 file: name it .h5 or .hdf5")
    check_output_path(args.out)
    errors = error_model(args.errors)
    if args.onboard:
        errors = dataclasses.replace(errors, onboard_orientation=True)
    config = SimulationConfig(
        scenario=args.scenario, duration_s=args.duration, n_sensors=args.sensors, rate_hz=args.rate,
        seed=args.seed, errors=errors, drop_probability=args.drops, height_m=args.height,
        disturbances=tuple(parse_disturbance(text) for text in args.disturbance),
        magcal_turns=(args.scenario == "demo") if args.magcal_turns is None else args.magcal_turns,
        room=args.room,
    )
    check_size(config.duration_s, config.rate_hz, config.n_sensors)
    result = simulate_session(config)
    path = write_session(args.out, session_from_simulation(result, include_truth=not args.no_truth))
    total = len(result.truth.t_s) * len(result.samples)
    kept = sum(len(s.t_s) for s in result.samples.values())
    print(
        f"wrote {path}: scenario {config.scenario}, {config.n_sensors} sensors on {result.model_name}, "
        f"{config.duration_s:g} s at {config.rate_hz:g} Hz, {kept} samples ({total - kept} dropped), "
        f"seed {config.seed}, room {config.room}, {'no truth' if args.no_truth else 'with truth'}"
    )
    return 0
