"""The clinical tests on the command-line route, every test and seed, against the simulator's truth.

For each scenario (``tug``, ``walk10m``, ``walk2min``, ``walk6min``, ``chair_stand``) and seed:
``simulate --scenario S --magcal-turns --seed K --duration D`` → ``magcal fit --save`` (an
isolated store per session) → ``bodycal --out CAL.json`` → ``protocol TEST SESSION
--calibration CAL.json`` (reprocessed, and ``--result live`` with ``--live``), and the same on a
copy of the session without any marker. Each result key is compared with the truth's
``protocol_json`` (no command reads it): times as differences (s), speeds, distances and the
cadence in per cent, the stands exactly. The goals of issue 35: TUG total and every phase
within 0.3 s, walking speed and distance within 3 %, chair stands exact.

Run: ``.venv/bin/python bench/bench_protocols.py [--scenarios tug,walk10m,...] [--seeds 1-3]
[--live]``. Prints one line per test and seed, then the worst error per key and whether the
marker-less copy gave the same result.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from mimucap.cli import main
from mimucap.core.simulate.clinical_tests import CLINICAL_TESTS
from mimucap.io.session import read_session, write_session
from mimucap.session.clinical_tests import RESULT_KEYS

DURATION_S = {"tug": 62.0, "walk10m": 55.0, "chair_stand": 80.0, "walk2min": 170.0, "walk6min": 410.0}
GOAL = {"time_s": 0.3, "percent": 3.0}


def seeds_of(text: str) -> list[int]:
    if "-" in text:
        first, last = (int(v) for v in text.split("-"))
        return list(range(first, last + 1))
    return [int(v) for v in text.split(",")]


def quiet(argv: list[str]) -> int:
    with open(os.devnull, "w") as sink:
        import contextlib

        with contextlib.redirect_stdout(sink):
            return main(argv)


def run_one(folder: Path, scenario: str, seed: int, live: bool) -> dict:
    session = folder / f"{scenario}_{seed}.h5"
    calibration = folder / f"{scenario}_{seed}_cal.json"
    os.environ["MIMUCAP_DATA_DIR"] = str(folder / f"data_{scenario}_{seed}")
    assert quiet(["simulate", "--scenario", scenario, "--magcal-turns", "--seed", str(seed), "--duration",
                  str(DURATION_S[scenario]), "--out", str(session)]) == 0
    assert quiet(["magcal", "fit", str(session), "--save"]) == 0
    assert quiet(["bodycal", str(session), "--out", str(calibration)]) == 0
    unmarked = folder / f"{scenario}_{seed}_unmarked.h5"
    copy = read_session(session)
    copy.markers = []
    write_session(unmarked, copy)
    test = CLINICAL_TESTS[scenario]
    found = {}
    for name, path in (("marked", session), ("unmarked", unmarked)):
        out = folder / f"{scenario}_{seed}_{name}.json"
        started = time.perf_counter()
        assert quiet(["protocol", test, str(path), "--calibration", str(calibration), "--out", str(out)]
                     + (["--result", "live"] if live else [])) == 0
        found[name] = json.loads(out.read_text())
        found[name + "_s"] = time.perf_counter() - started
    return {"test": test, "truth": read_session(session).truth.protocol, **found}


def error_of(key: str, value, truth) -> tuple[float, str]:
    """(error, unit): seconds for durations, per cent for speeds, distances and cadence."""
    if value is None:
        return float("inf"), "?"
    if key.endswith("_s") and not key.endswith("_m_s"):
        return float(value) - float(truth), "s"
    if key == "stands":
        return float(value) - float(truth), ""
    return 100.0 * (float(value) / float(truth) - 1.0), "%"


def main_bench() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenarios", default="tug,walk10m,chair_stand,walk2min,walk6min")
    parser.add_argument("--seeds", default="1-3")
    parser.add_argument("--live", action="store_true", help="the result as seen live instead of reprocessed")
    args = parser.parse_args()
    worst: dict[tuple[str, str], float] = {}
    same = True
    with tempfile.TemporaryDirectory() as tmp:
        for scenario in args.scenarios.split(","):
            for seed in seeds_of(args.seeds):
                one = run_one(Path(tmp), scenario, seed, args.live)
                parts = []
                for key in RESULT_KEYS[one["test"]]:
                    error, unit = error_of(key, one["marked"][key], one["truth"][key])
                    worst[(one["test"], key)] = max(worst.get((one["test"], key), 0.0), abs(error))
                    parts.append(f"{key} {one['marked'][key]:.3f} (truth {one['truth'][key]:.3f}, {error:+.3f}{unit})")
                    same &= one["unmarked"][key] == one["marked"][key]
                print(f"{one['test']:11s} seed {seed}: " + "; ".join(parts)
                      + f"  [protocol {one['marked_s']:.1f} s; without markers "
                      + ("identical" if all(one["unmarked"][k] == one["marked"][k] for k in RESULT_KEYS[one["test"]])
                         else "DIFFERENT") + "]", flush=True)
    print("\nworst |error| per key (goal: 0.3 s for TUG times, 3 % for speeds and distances, stands exact):")
    for (test, key), value in worst.items():
        unit = "s" if key.endswith("_s") and not key.endswith("_m_s") else ("" if key == "stands" else "%")
        print(f"  {test:11s} {key:18s} {value:.3f} {unit}")
    print(f"results without the markers identical: {same}")


if __name__ == "__main__":
    main_bench()
