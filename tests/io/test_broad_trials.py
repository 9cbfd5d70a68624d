"""BROAD reader: real trial layout, and clear errors for files that are not BROAD trials."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from mimucap.io.broad_trials import is_broad_file, list_broad_trials, read_broad
from mimucap.core.sensor_limits import GYR_MAX_RAD_S
from tests.external_data import data_path

BROAD_DIR = data_path("broad")


@pytest.mark.data("broad")
def test_reads_a_real_trial():
    trial = read_broad(BROAD_DIR / "24_disturbed_tapping_A.hdf5")
    assert trial.name == "24_disturbed_tapping_A"
    assert trial.category == "tapping"
    assert trial.sampling_rate_hz == pytest.approx(285.714, abs=1e-3)  # BROAD: 285.714 Hz
    n = trial.n_samples
    assert trial.gyr_rad_s.shape == trial.acc_m_s2.shape == trial.mag_uT.shape == (n, 3)
    assert trial.q_ref_world_from_sensor.shape == (n, 4)
    assert trial.movement.dtype == bool and trial.movement.any() and not trial.movement.all()
    # at rest the accelerometer reads about +g, the magnetometer the Berlin field (~45–50 µT)
    assert np.linalg.norm(trial.acc_m_s2[:100], axis=1).mean() == pytest.approx(9.81, abs=0.15)
    assert 35.0 < np.linalg.norm(trial.mag_uT[:100], axis=1).mean() < 60.0
    assert np.isnan(trial.q_ref_world_from_sensor).any(axis=1).any()  # occlusions kept as NaN
    assert trial.t_s[1] == pytest.approx(1 / trial.sampling_rate_hz)


@pytest.mark.data("broad")
def test_lists_the_trials_and_their_categories():
    files = list_broad_trials(BROAD_DIR)
    assert len(files) == 14
    categories = {read_broad(f).category for f in files[7:10]}
    assert categories <= {"undisturbed", "tapping", "vibration", "magnets"}


def test_clear_errors(tmp_path):
    missing = tmp_path / "missing.hdf5"
    with pytest.raises(OSError, match="no such file"):
        read_broad(missing)
    text = tmp_path / "text.hdf5"
    text.write_text("not hdf5")
    with pytest.raises(ValueError, match="not an HDF5 file"):
        read_broad(text)
    assert not is_broad_file(text)
    partial = tmp_path / "partial.hdf5"
    with h5py.File(partial, "w") as handle:
        handle["imu_gyr"] = np.zeros((5, 3))
        handle["imu_acc"] = np.zeros((5, 3))
    with pytest.raises(ValueError, match=r"partial.hdf5: BROAD trial without 'imu_mag'"):
        read_broad(partial)
    shape = tmp_path / "shape.hdf5"
    with h5py.File(shape, "w") as handle:
        handle["imu_gyr"] = np.zeros((5, 3))
        handle["imu_acc"] = np.zeros((5, 3))
        handle["imu_mag"] = np.zeros((5, 2))
        handle.attrs["sampling_rate"] = 100.0
    with pytest.raises(ValueError, match=r"imu_mag.*\(N, 3\)"):
        read_broad(shape)
    rate = tmp_path / "rate.hdf5"
    with h5py.File(rate, "w") as handle:
        for name in ("imu_gyr", "imu_acc", "imu_mag"):
            handle[name] = np.zeros((5, 3))
    with pytest.raises(ValueError, match="sampling_rate"):
        read_broad(rate)
    with pytest.raises(ValueError, match="no BROAD trial"):
        list_broad_trials(_empty(tmp_path))


@pytest.mark.data("broad")
def test_a_trial_without_an_imu_dataset_is_told_from_a_foreign_file(tmp_path):
    """Was: a BROAD trial lacking ``imu_mag`` was not recognised at all, so ``mimucap fuse``
    called it a foreign HDF5 file ("not a MimuCap session")."""
    source = BROAD_DIR / "24_disturbed_tapping_A.hdf5"
    for missing in (("imu_mag",), ("imu_acc",), ("imu_gyr", "imu_acc")):
        path = tmp_path / f"without_{'_'.join(missing)}.hdf5"
        with h5py.File(source) as src, h5py.File(path, "w") as dst:
            for name in src:
                if name not in missing:
                    dst.create_dataset(name, data=src[name][:500])
            dst.attrs["sampling_rate"] = src.attrs["sampling_rate"]
        assert is_broad_file(path)
        names = " and ".join(f"'{name}'" + r" \([a-z]+, [^)]+\)" for name in missing)
        with pytest.raises(ValueError, match=f"{path.name}: BROAD trial without {names}; it holds"):
            read_broad(path)
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as handle:
        handle["x"] = np.zeros(3)
    session = tmp_path / "session.h5"
    with h5py.File(session, "w") as handle:       # a MimuCap session is marked by its 'format'
        handle.attrs["format"] = "mimucap-session"
        handle["imu_acc"] = np.zeros((3, 3))
    assert not is_broad_file(foreign) and not is_broad_file(session)
    with pytest.raises(ValueError, match=r"foreign.h5: not a BROAD trial, dataset 'imu_gyr' is missing"):
        read_broad(foreign)


def _empty(tmp_path: Path) -> Path:
    folder = tmp_path / "empty"
    folder.mkdir()
    return folder


@pytest.mark.data("broad")
def test_every_real_trial_is_within_the_gyroscope_bound():
    for path in list_broad_trials(BROAD_DIR):
        trial = read_broad(path)
        assert np.nanmax(np.abs(trial.gyr_rad_s)) < GYR_MAX_RAD_S, path.name


@pytest.mark.data("broad")
def test_a_gyroscope_in_degrees_per_second_is_refused(tmp_path):
    with h5py.File(BROAD_DIR / "06_undisturbed_fast_rotation_A.hdf5", "r") as source:
        gyr, acc, mag = (source[name][:20000] for name in ("imu_gyr", "imu_acc", "imu_mag"))
        rate = source.attrs["sampling_rate"]
    path = tmp_path / "dps.hdf5"
    with h5py.File(path, "w") as handle:
        handle["imu_gyr"], handle["imu_acc"], handle["imu_mag"] = np.rad2deg(gyr), acc, mag
        handle.attrs["sampling_rate"] = rate
    row, axis = np.unravel_index(np.nanargmax(np.abs(gyr)), gyr.shape)
    with pytest.raises(ValueError, match=rf"dps\.hdf5: imu_gyr: gyroscope reaches .* rad/s about its "
                                         rf"{'xyz'[axis]} axis at row {row}, .*is it in °/s\?"):
        read_broad(path)
