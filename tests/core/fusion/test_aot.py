"""The kernels compiled ahead of time: the same results as numba's JIT, never used when stale,
and a process that uses them does not import numba."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mimucap.core.fusion import aot, kernel_selection
from mimucap.core.fusion.ekf import OrientationEKF, fuse, update_together
from mimucap.core.fusion.offline import fuse_offline
from mimucap.core.fusion.params import FusionParams
from mimucap.io.broad_trials import read_broad
from tests.external_data import data_path

BROAD_DIR = data_path("broad")
#: A trial with a magnet moved near the sensor: magnetometer rejection, rest, motion.
TRIAL = BROAD_DIR / "28_disturbed_stationary_magnet_A.hdf5"
#: Largest difference of a quaternion component between the two kinds of kernels. With the
#: ``host`` target they agree bitwise when the JIT kernels come from numba's cache; a fresh JIT
#: compilation can round the last bits otherwise (a few 1e-15).
TOLERANCE = 1e-12


@pytest.fixture(scope="module")
def compiled_dir(tmp_path_factory) -> Path:
    """A folder holding the current compiled module: the installed one, else one built here."""
    if aot.load_ahead_of_time() is not None:
        return aot.COMPILED_DIR
    from mimucap.core.fusion.aot_build import build

    folder = tmp_path_factory.mktemp("compiled")
    build("host" if aot.cpu_signature() is not None else "generic", folder)
    return folder


@pytest.fixture(scope="module")
def compiled(compiled_dir) -> aot.FusionKernels:
    kernels = aot.load_ahead_of_time(compiled_dir)
    assert kernels is not None and kernels.ahead_of_time
    return kernels


@pytest.fixture(scope="module")
def jit() -> aot.FusionKernels:
    return kernel_selection.jit_kernels()


def both(compiled, jit, run):
    """``run()`` with the compiled kernels, then with the JIT kernels."""
    results = []
    for kernels in (compiled, jit):
        with kernel_selection.kernels_in_use(kernels):
            results.append(run())
    return results


def assert_same(one, other) -> None:
    """Two FusionResults agree: orientations and biases within TOLERANCE (NaN where NaN),
    flags and counters exactly."""
    for name in ("q_world_from_sensor", "bias_rad_s"):
        a, b = getattr(one, name), getattr(other, name)
        assert a.shape == b.shape
        assert np.array_equal(np.isnan(a), np.isnan(b)), name
        assert np.nanmax(np.abs(a - b), initial=0.0) <= TOLERANCE, name
    assert np.array_equal(one.flags, other.flags)
    assert list(one.counters) == list(other.counters)


@pytest.mark.data("broad")
@pytest.mark.parametrize("use_mag", [True, False])
def test_compiled_and_jit_kernels_agree_on_a_real_broad_trial(compiled, jit, use_mag):
    trial = read_broad(TRIAL)
    mag = trial.mag_uT if use_mag else None
    online = both(compiled, jit, lambda: fuse(trial.t_s, trial.gyr_rad_s, trial.acc_m_s2, mag, use_mag=use_mag))
    assert_same(*online)
    offline = both(compiled, jit, lambda: fuse_offline(trial.t_s, trial.gyr_rad_s, trial.acc_m_s2, mag,
                                                       use_mag=use_mag))
    assert_same(*offline)
    # the comparison can fail: the smoother's result is not the filter's
    assert np.nanmax(np.abs(online[0].q_world_from_sensor - offline[0].q_world_from_sensor)) > 1e-3
    flags = online[0].flag_masks()
    assert flags["rest"].any() and (flags["mag_rejected"].any() or not use_mag)


def _edge_recording(n: int = 1500, seed: int = 1):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 100.0
    gyr = rng.normal(0.0, 0.5, (n, 3))
    acc = np.tile([0.0, 0.0, 9.81], (n, 1)) + rng.normal(0.0, 0.5, (n, 3))
    mag = np.tile([0.0, 20.0, -40.0], (n, 1)) + rng.normal(0.0, 1.0, (n, 3))
    acc[:40] = np.nan            # no valid accelerometer sample yet: uninitialised rows
    gyr[300:305] = np.nan        # skipped gyro samples
    acc[500:520] = 0.0           # zero specific force: missing
    mag[600:700] = np.nan        # magnetometer dropout
    mag[800:900] *= 3.0          # a magnetic disturbance
    acc[1000] = [200.0, 0.0, 0.0]  # a knock
    t[1100:] += 2.0              # a gap in the time stamps
    t[1200] = t[1199]            # a repeated time stamp
    gyr[1250:] = rng.normal(0.0, 0.002, (n - 1250, 3))    # at rest: the bias is learnt
    acc[1250:] = [0.0, 0.0, 9.81] + rng.normal(0.0, 0.01, (n - 1250, 3))
    return t, gyr, acc, mag


@pytest.mark.parametrize("algorithm", ["ekf-taylor3", "ekf-rk4", "taylor3", "rk4"])
def test_compiled_and_jit_kernels_agree_on_edge_cases(compiled, jit, algorithm):
    t, gyr, acc, mag = _edge_recording()
    for mag_used in (mag, None):
        use_mag = mag_used is not None
        assert_same(*both(compiled, jit, lambda: fuse(t, gyr, acc, mag_used, algorithm=algorithm, use_mag=use_mag)))
        assert_same(*both(compiled, jit, lambda: fuse_offline(t, gyr, acc, mag_used, algorithm=algorithm,
                                                              use_mag=use_mag)))
    declined = FusionParams(declination_rad=0.2, propagation="exact")
    assert_same(*both(compiled, jit, lambda: fuse(t, gyr, acc, mag, params=declined, algorithm=algorithm)))


def test_compiled_and_jit_kernels_agree_without_accelerometer_and_without_any_valid_sample(compiled, jit):
    t, gyr, acc, mag = _edge_recording()
    assert_same(*both(compiled, jit, lambda: fuse(t, gyr, None, mag)))
    nothing = np.full_like(acc, np.nan)   # the command line refuses such a file: no orientation at all
    results = both(compiled, jit, lambda: fuse(t, gyr, nothing, mag))
    assert_same(*results)
    assert np.isnan(results[0].q_world_from_sensor).all()
    empty = both(compiled, jit, lambda: fuse_offline(t[:0], gyr[:0], acc[:0], mag[:0]))
    assert_same(*empty)


def test_compiled_and_jit_kernels_agree_block_by_block_and_for_several_sensors(compiled, jit):
    """As the live session feeds them: a few samples at a time, several filters in one call."""
    t, gyr, acc, mag = _edge_recording()
    outputs = []
    for kernels in (compiled, jit):
        with kernel_selection.kernels_in_use(kernels):
            filters = [OrientationEKF(), OrientationEKF()]
            blocks = []
            for start in range(0, len(t), 7):
                stop = start + 7
                blocks.append(update_together(filters, np.stack([t[start:stop]] * 2),
                                              np.stack([gyr[start:stop], -gyr[start:stop]]),
                                              np.stack([acc[start:stop]] * 2), np.stack([mag[start:stop]] * 2)))
            outputs.append((np.concatenate([b.q_world_from_sensor for b in blocks], axis=1),
                            np.concatenate([b.flags for b in blocks], axis=1),
                            np.stack([f.state.aux[0] for f in filters])))
    (q_a, flags_a, aux_a), (q_b, flags_b, aux_b) = outputs
    assert np.nanmax(np.abs(q_a - q_b)) <= TOLERANCE
    assert np.array_equal(np.isnan(q_a), np.isnan(q_b))
    assert np.array_equal(flags_a, flags_b) and np.allclose(aux_a, aux_b, rtol=0.0, atol=TOLERANCE)


def test_the_compiled_kernels_refuse_arguments_they_would_misread(compiled):
    from mimucap.core.fusion.ekf import _unused_outputs
    from mimucap.core.fusion.params import DEFAULT_FUSION_PARAMS, pack_params
    from mimucap.core.fusion.state import FusionState

    n = 5
    state = FusionState.new(1)
    good = dict(p=pack_params(DEFAULT_FUSION_PARAMS), t=np.arange(n, dtype=float)[None] / 100.0,
                gyr=np.zeros((1, n, 3)), acc=np.tile([0.0, 0.0, 9.81], (1, n, 1)),
                mag=np.tile([0.0, 20.0, -40.0], (1, n, 1)), q=state.q_world_from_sensor,
                b=state.bias_rad_s, P=state.cov, aux=state.aux, out_q=np.empty((1, n, 4)),
                out_bias=np.empty((1, n, 3)), out_flags=np.zeros((1, n), np.uint8), store=False)
    rest = _unused_outputs(1)[1:]

    def call(**changes):
        args = {**good, **changes}
        compiled.ekf_sensors(*args.values(), *rest)

    call()
    assert np.isfinite(good["out_q"]).all()
    read_only = np.zeros((1, n, 3))
    read_only.flags.writeable = False
    for changes, word in [({"gyr": np.zeros((1, n, 6))[:, :, ::2]}, "C-contiguous"),
                          ({"gyr": np.zeros((1, n, 3), np.float32)}, "float64"),
                          ({"gyr": np.zeros((n, 3))}, "3 dimensions"),
                          ({"gyr": read_only}, "writeable"),
                          ({"gyr": [[0.0, 0.0, 0.0]]}, "list"),
                          ({"store": 0}, "bool")]:
        with pytest.raises(TypeError, match=word):
            call(**changes)
    with pytest.raises(TypeError, match="18 arguments"):
        compiled.ekf_sensors(*good.values())


def test_a_missing_or_stale_module_is_never_loaded(compiled_dir, tmp_path, monkeypatch):
    assert aot.load_ahead_of_time(tmp_path) is None                       # never built
    current = next(aot.module_path(target, compiled_dir) for target in aot.target_ids()
                   if aot.module_path(target, compiled_dir).is_file())
    stale = tmp_path / current.name.replace(aot.MODULE_PREFIX, aot.MODULE_PREFIX + "0")
    shutil.copy(current, stale)                                           # another fingerprint
    assert aot.load_ahead_of_time(tmp_path) is None
    # an edit of a kernel's source changes the name looked for
    sources = tmp_path / "sources"
    sources.mkdir()
    for name in aot.KERNEL_SOURCES:
        shutil.copy(aot.PACKAGE_DIR / name, sources / name)
    names = [aot.module_name(target) for target in aot.target_ids()]
    with monkeypatch.context() as patch:
        patch.setattr(aot, "PACKAGE_DIR", sources)
        assert [aot.module_name(target) for target in aot.target_ids()] == names
        with open(sources / "kernels.py", "a", encoding="utf-8") as handle:
            handle.write("\n# edited\n")
        assert aot.load_ahead_of_time(compiled_dir) is None
    # so does a change of the settings layout, or of the CPU
    with monkeypatch.context() as patch:
        patch.setattr(aot, "LAYOUT_FINGERPRINT", aot.LAYOUT_FINGERPRINT + 1)
        assert aot.load_ahead_of_time(compiled_dir) is None
    if aot.cpu_signature() is not None and aot.module_path(aot.target_ids()[0], compiled_dir).is_file():
        with monkeypatch.context() as patch:
            patch.setattr(aot, "cpu_signature", lambda: "model name:another CPU")
            assert aot.load_ahead_of_time(compiled_dir) is None
    assert aot.load_ahead_of_time(compiled_dir) is not None
    # without a current module the process runs the JIT kernels
    monkeypatch.setattr(aot, "COMPILED_DIR", tmp_path)
    monkeypatch.setattr(kernel_selection, "_selected", None)
    assert kernel_selection.fusion_kernels().origin == "numba JIT"


def test_the_environment_can_choose_the_jit_kernels(compiled_dir, monkeypatch):
    monkeypatch.setattr(aot, "COMPILED_DIR", compiled_dir)
    monkeypatch.setattr(kernel_selection, "_selected", None)
    assert kernel_selection.fusion_kernels().ahead_of_time
    monkeypatch.setattr(kernel_selection, "_selected", None)
    monkeypatch.setenv(kernel_selection.KERNELS_ENV, "jit")
    assert not kernel_selection.fusion_kernels().ahead_of_time
    monkeypatch.setattr(kernel_selection, "_selected", None)
    monkeypatch.setenv(kernel_selection.KERNELS_ENV, "fast")
    with pytest.raises(ValueError, match="MIMUCAP_FUSION_KERNELS"):
        kernel_selection.fusion_kernels()


#: Runs ``mimucap fuse`` and the GUI's kernel preparation in a fresh interpreter whose compiled
#: modules are in argv[1]; prints which heavy modules got imported.
PROBE = r"""
import json, sys
from pathlib import Path
import mimucap.core.fusion.aot as aot
import mimucap.core.fusion.kernel_selection as kernel_selection
aot.COMPILED_DIR = Path(sys.argv[1])
from mimucap.cli import main
code = main(["fuse", sys.argv[2], "--out", sys.argv[3]])
from mimucap.session.live.kernel_preparation import KernelPreparation
report = KernelPreparation().run()
print(json.dumps({"code": code, "origin": kernel_selection.fusion_kernels().origin, "ahead_of_time": report.ahead_of_time,
                  "imported": [name for name in ("numba", "llvmlite", "scipy") if name in sys.modules]}))
"""


@pytest.mark.data("broad")
def test_fuse_and_the_first_start_do_not_import_numba_with_compiled_kernels(compiled_dir, compiled, jit, tmp_path):
    out = tmp_path / "q.npy"
    env = {key: value for key, value in os.environ.items() if key != kernel_selection.KERNELS_ENV}
    done = subprocess.run([sys.executable, "-c", PROBE, str(compiled_dir), str(TRIAL), str(out)],
                          capture_output=True, text=True, timeout=120, env=env)
    assert done.returncode == 0, done.stderr
    seen = json.loads(done.stdout.strip().splitlines()[-1])
    assert seen == {"code": 0, "origin": compiled.origin, "ahead_of_time": True, "imported": []}
    trial = read_broad(TRIAL)
    with kernel_selection.kernels_in_use(jit):
        expected = fuse(trial.t_s, trial.gyr_rad_s, trial.acc_m_s2, trial.mag_uT).q_world_from_sensor
    written = np.load(out)
    assert np.array_equal(np.isnan(written), np.isnan(expected))
    assert np.nanmax(np.abs(written - expected)) <= TOLERANCE


def test_the_build_signatures_follow_the_entry_points():
    from mimucap.core.fusion.aot_build import signature, target_id

    assert signature("rts_smooth_sensors") == "void(" + ", ".join(
        ["f8[:, :, ::1]"] * 4 + ["f8[:, :, :, ::1]"] * 3 + ["f8[:, :, ::1]"] * 2) + ")"
    assert "u1[:, ::1], b1, " in signature("ekf_sensors")
    assert target_id("generic").startswith("generic:")
    with pytest.raises(ValueError, match="unknown target"):
        target_id("fastest")


@pytest.mark.data("broad")
def test_the_generic_target_for_bundles_agrees_with_the_jit_kernels(tmp_path, jit):
    """What the desktop bundle ships: compiled for any CPU of the architecture (no fused
    multiply-add, so the last bits may differ from the JIT's)."""
    from mimucap.core.fusion.aot_build import build

    path = build("generic", tmp_path)
    assert path.name.startswith(aot.module_name(aot.target_ids()[-1]))
    generic = aot.load_ahead_of_time(tmp_path)
    assert generic is not None and generic.origin == path.name
    trial = read_broad(TRIAL)
    assert_same(*both(generic, jit, lambda: fuse(trial.t_s, trial.gyr_rad_s, trial.acc_m_s2, trial.mag_uT)))
    t, gyr, acc, mag = _edge_recording()
    assert_same(*both(generic, jit, lambda: fuse_offline(t, gyr, acc, mag)))
