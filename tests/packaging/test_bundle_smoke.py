"""Smoke test of the desktop bundle (``make bundle-check``, which CI runs after ``make test``).

The bundle folder is named by ``MIMUCAP_BUNDLE`` (``make bundle-check``: ``dist/mimucap``);
without it these tests are skipped, so that ``make test`` needs neither PyInstaller nor a
bundle. The bundled program runs in a user folder of its own, as does the source install's
(``python -m mimucap`` of this tree) it is compared with.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mimucap.io.angles_export import read_angles_csv
from tests.gui.test_gui_command import assert_shows_the_uncalibrated_skeleton

REPO = Path(__file__).resolve().parents[2]
BUNDLE_ENV = "MIMUCAP_BUNDLE"
if not os.environ.get(BUNDLE_ENV):
    pytest.skip(f"the bundle's smoke test runs in `make bundle-check` ({BUNDLE_ENV} names the bundle)",
                allow_module_level=True)

#: The issue's limit on the bundle folder's size (bytes).
MAX_BUNDLE_BYTES = 400e6
#: The simulated session both installs process (seconds; the demo begins with the
#: magnetometer turns and holds the N- and T-pose).
SESSION_S = 40
#: Largest difference (degrees) between the bundle's joint angles and the source install's: one
#: unit in the last of the six decimals the CSV prints. The bundle runs the kernels compiled
#: for any CPU of the architecture, the source install those compiled for this CPU, which may
#: fuse multiplications and additions: the same arithmetic up to the last bits of each step,
#: which can round a printed angle the other way.
ANGLE_ATOL_DEG = 1.01e-6


def _bundle_module():
    spec = importlib.util.spec_from_file_location("bundle", REPO / "packaging" / "bundle.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


bundle_tools = _bundle_module()


@pytest.fixture(scope="module")
def bundle() -> Path:
    folder = Path(os.environ[BUNDLE_ENV]).resolve()
    assert bundle_tools.executable(folder).is_file(), f"no bundled program in {folder}"
    return folder


def _user_env(folder: Path) -> dict[str, str]:
    """The environment of a program run with its own, empty user folders under ``folder``."""
    return {**os.environ, "HOME": str(folder / "home"), "XDG_CONFIG_HOME": str(folder / "config"),
            "XDG_DATA_HOME": str(folder / "share"),
            "XDG_STATE_HOME": str(folder / "state"), "MIMUCAP_DATA_DIR": str(folder / "data")}


def _run(command: list[str], folder: Path, *args: str) -> subprocess.CompletedProcess:
    done = subprocess.run([*command, *args], cwd=folder, env=_user_env(folder), capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, f"{' '.join(command + list(args))} failed:\n{done.stderr}"
    return done


def _source_command() -> list[str]:
    return [sys.executable, "-m", "mimucap"]


def test_the_bundle_is_built_from_these_sources_without_numba_and_within_400_MB(bundle):
    assert bundle_tools.read_fingerprints(bundle).get("sources") == bundle_tools.sources_fingerprint(), \
        "the bundle was built from other sources: make bundle"
    size = bundle_tools.folder_size(bundle)
    print(f"bundle {bundle}: {size / 1e6:.0f} MB")
    assert size <= MAX_BUNDLE_BYTES
    internal = bundle / "_internal"
    assert not (internal / "numba").exists() and not (internal / "llvmlite").exists()
    compiled = list((internal / "mimucap" / "core" / "fusion" / "_compiled").glob("fusion_kernels_*"))
    assert len(compiled) == 1  # the generic kernels, named for the sources shipped beside them
    assert (bundle / "install.sh").is_file() and (internal / "mimucap.desktop").is_file()


def test_the_bundled_app_shows_the_simulated_suit(bundle, tmp_path):
    out = tmp_path / "bundle.png"
    _run([str(bundle_tools.executable(bundle))], tmp_path, "gui", "--source", "simulated", "--screenshot",
         str(out), "--after", "1.5")
    assert_shows_the_uncalibrated_skeleton(out)


def _pipeline(command: list[str], folder: Path) -> dict:
    """simulate → magcal fit (stored) → bodycal → angles with ``command``, in ``folder``."""
    folder.mkdir()
    _run(command, folder, "simulate", "--scenario", "demo", "--duration", str(SESSION_S), "--no-truth",
         "--out", "session.h5")
    _run(command, folder, "magcal", "fit", "session.h5", "--save")
    _run(command, folder, "bodycal", "session.h5", "--out", "body.json")
    _run(command, folder, "angles", "session.h5", "--calibration", "body.json", "--out", "angles.csv")
    angles = read_angles_csv(folder / "angles.csv")
    # the calibrations the command stored (its files, not its printout: a windowed program on
    # Windows prints nothing), one per sensor device
    stored = sorted(folder.rglob("magnetometer/devices/*.json"))
    return {"magcal": [json.loads(path.read_text(encoding="utf-8")) for path in stored],
            "body": json.loads((folder / "body.json").read_text(encoding="utf-8")), "angles": angles}


def _numbers(value, path=""):
    """``(path, number)`` of every number in a JSON value (lists and objects flattened)."""
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return
    if isinstance(value, (int, float)):
        yield path, float(value)
    elif isinstance(value, dict):
        for key, item in value.items():
            yield from _numbers(item, f"{path}/{key}")
    elif isinstance(value, list):
        for index, item in enumerate(value):
            yield from _numbers(item, f"{path}[{index}]")


def test_the_bundled_commands_give_the_source_installs_numbers(bundle, tmp_path):
    bundled = _pipeline([str(bundle_tools.executable(bundle))], tmp_path / "bundle")
    source = _pipeline(_source_command(), tmp_path / "source")

    # Magnetometer calibration (no fusion kernel: the same numpy and scipy code).
    assert [fit["device_id"] for fit in bundled["magcal"]] == [fit["device_id"] for fit in source["magcal"]]
    assert len(bundled["magcal"]) == 10
    for mine, theirs in zip(bundled["magcal"], source["magcal"]):
        assert mine["quality"]["verdict"] == theirs["quality"]["verdict"] == "good"
        for key in ("offset_uT", "soft_iron", "field_uT", "samples_used"):
            np.testing.assert_allclose(mine[key], theirs[key], rtol=1e-9, atol=1e-9, err_msg=key)

    # Body calibration: the same verdict, segments and numbers (orientations through the filter).
    assert bundled["body"].get("verdict") == source["body"].get("verdict")
    mine, theirs = dict(_numbers(bundled["body"])), dict(_numbers(source["body"]))
    assert mine.keys() == theirs.keys() and len(mine) > 50
    # (a magnetometer calibration's age depends on when each run made it, not on the numbers)
    differing = {key: (mine[key], theirs[key]) for key in mine
                 if not key.endswith("/age_h") and not np.isclose(mine[key], theirs[key], rtol=1e-7, atol=1e-7)}
    assert not differing

    # Joint angles, and where they are trustworthy.
    angles, reference = bundled["angles"], source["angles"]
    assert len(angles.t_s) == len(reference.t_s) == SESSION_S * 100
    np.testing.assert_array_equal(angles.t_s, reference.t_s)
    assert angles.angles_deg.keys() == reference.angles_deg.keys() and len(angles.angles_deg) == 27
    for name, values in angles.angles_deg.items():
        np.testing.assert_allclose(values, reference.angles_deg[name], rtol=0, atol=ANGLE_ATOL_DEG, err_msg=name)
    assert angles.ok.keys() == reference.ok.keys() and len(angles.ok) == 9
    for joint, ok in angles.ok.items():
        np.testing.assert_array_equal(ok, reference.ok[joint], err_msg=joint)
