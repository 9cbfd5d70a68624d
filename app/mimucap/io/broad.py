"""Reader of BROAD trials (Berlin Robust Orientation Estimation Assessment Dataset, HDF5).

One file per trial with datasets ``imu_gyr`` (N, 3) rad/s, ``imu_acc`` (N, 3) m/s², ``imu_mag``
(N, 3) µT (sensor frame), the optical reference ``opt_quat`` (N, 4) ``q_world_from_sensor``
(scalar first, ENU; NaN rows where markers were occluded), ``opt_pos`` (N, 3) m, ``movement``
(N,) bool and the attribute ``sampling_rate`` (Hz). Only the IMU channels and
``sampling_rate`` are required (the ``mimucap fuse`` input); the reference is optional. A
gyroscope beyond :data:`~mimucap.io.session.MAX_GYRO_RAD_S` (most likely °/s) is refused.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from mimucap.io.session import gyro_range_problem

REQUIRED_DATASETS = ("imu_gyr", "imu_acc", "imu_mag")

#: Category of a BROAD trial from its name (the dataset's own grouping).
CATEGORY_PATTERNS = (
    ("tapping", re.compile(r"tapping")),
    ("vibration", re.compile(r"vibration")),
    ("magnets", re.compile(r"magnet")),
    ("undisturbed", re.compile(r"undisturbed")),
)


@dataclass(frozen=True)
class BroadTrial:
    """One BROAD trial: IMU samples, time stamps and (when present) the optical reference."""

    name: str
    sampling_rate_hz: float
    gyr_rad_s: np.ndarray
    acc_m_s2: np.ndarray
    mag_uT: np.ndarray
    q_ref_world_from_sensor: np.ndarray | None
    movement: np.ndarray | None

    @property
    def n_samples(self) -> int:
        return self.gyr_rad_s.shape[0]

    @property
    def t_s(self) -> np.ndarray:
        """Sample times (s) from the constant sampling rate, starting at 0."""
        return np.arange(self.n_samples) / self.sampling_rate_hz

    @property
    def category(self) -> str:
        """``undisturbed``, ``tapping``, ``vibration``, ``magnets`` or ``other``."""
        for category, pattern in CATEGORY_PATTERNS:
            if pattern.search(self.name):
                return category
        return "other"


def _dataset(handle: h5py.File, path: Path, name: str, columns: int | None) -> np.ndarray:
    if name not in handle:
        raise ValueError(f"{path}: not a BROAD trial, dataset {name!r} is missing "
                         f"(found: {', '.join(sorted(handle.keys())) or 'nothing'})")
    data = np.asarray(handle[name][()], dtype=np.float64)
    if columns is not None and (data.ndim != 2 or data.shape[1] != columns):
        raise ValueError(f"{path}: dataset {name!r} must have shape (N, {columns}), got {data.shape}")
    return data


def is_broad_file(path: str | Path) -> bool:
    """Whether ``path`` is an HDF5 file holding the BROAD IMU datasets."""
    try:
        with h5py.File(path, "r") as handle:
            return all(name in handle for name in REQUIRED_DATASETS)
    except OSError:
        return False


def read_broad(path: str | Path) -> BroadTrial:
    """Read one BROAD trial; ``ValueError`` naming the file and the problem if it is not one."""
    path = Path(path)
    if not path.is_file():
        raise OSError(f"{path}: no such file")
    try:
        handle = h5py.File(path, "r")
    except OSError as error:
        raise ValueError(f"{path}: not an HDF5 file ({error})") from None
    with handle:
        gyr = _dataset(handle, path, "imu_gyr", 3)
        problem = gyro_range_problem(gyr)
        if problem is not None:
            raise ValueError(f"{path}: imu_gyr: {problem}")
        acc = _dataset(handle, path, "imu_acc", 3)
        mag = _dataset(handle, path, "imu_mag", 3)
        if not (gyr.shape == acc.shape == mag.shape):
            raise ValueError(f"{path}: imu_gyr {gyr.shape}, imu_acc {acc.shape} and imu_mag "
                             f"{mag.shape} must have the same number of rows")
        if "sampling_rate" not in handle.attrs:
            raise ValueError(f"{path}: attribute 'sampling_rate' (Hz) is missing")
        rate = float(np.asarray(handle.attrs["sampling_rate"]).reshape(-1)[0])
        if not np.isfinite(rate) or rate <= 0.0:
            raise ValueError(f"{path}: sampling_rate must be a positive number, got {rate}")
        q_ref = movement = None
        if "opt_quat" in handle:
            q_ref = _dataset(handle, path, "opt_quat", 4)
            if q_ref.shape[0] != gyr.shape[0]:
                raise ValueError(f"{path}: opt_quat has {q_ref.shape[0]} rows, imu_gyr {gyr.shape[0]}")
        if "movement" in handle:
            movement = np.asarray(handle["movement"][()]).astype(bool).reshape(-1)
            if movement.shape[0] != gyr.shape[0]:
                raise ValueError(f"{path}: movement has {movement.shape[0]} rows, imu_gyr {gyr.shape[0]}")
    return BroadTrial(path.stem, rate, gyr, acc, mag, q_ref, movement)


def list_broad_trials(directory: str | Path) -> list[Path]:
    """BROAD trial files (``*.hdf5``, ``*.h5``) in ``directory``, sorted by name."""
    directory = Path(directory)
    if not directory.is_dir():
        raise OSError(f"{directory}: not a directory")
    files = sorted(p for p in directory.iterdir() if p.suffix in (".hdf5", ".h5") and p.is_file())
    if not files:
        raise ValueError(f"{directory}: no BROAD trial (*.hdf5) found")
    return files
