"""Reader of BROAD trials (Berlin Robust Orientation Estimation Assessment Dataset, HDF5).

One file per trial with datasets ``imu_gyr`` (N, 3) rad/s, ``imu_acc`` (N, 3) m/s², ``imu_mag``
(N, 3) µT (sensor frame), the optical reference ``opt_quat`` (N, 4) ``q_world_from_sensor``
(scalar first, ENU; NaN rows where markers were occluded), ``opt_pos`` (N, 3) m, ``movement``
(N,) bool and the attribute ``sampling_rate`` (Hz). Only the IMU channels and
``sampling_rate`` are required (the ``mimucap fuse`` input); the reference is optional, and so
is ``imu_mag`` when the caller fuses without the magnetometer (``require_mag=False``). A
gyroscope beyond :data:`~mimucap.core.sensor_limits.GYR_MAX_RAD_S` (most likely °/s) is refused.

A file is recognised as a BROAD trial by its layout (any of BROAD's datasets and no MimuCap
``format`` attribute), not by its completeness: a trial that lacks an IMU channel is read as
one and refused naming the missing dataset (``X.hdf5: BROAD trial without 'imu_mag'``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from mimucap.core.sensor_samples import SensorSamples
from mimucap.io.session import gyro_range_problem

#: The IMU datasets a trial must hold, the magnetometer's only when it is used.
INERTIAL_DATASETS = ("imu_gyr", "imu_acc")
REQUIRED_DATASETS = INERTIAL_DATASETS + ("imu_mag",)
#: Every dataset of a BROAD trial; any one of them marks a file as laid out like one.
BROAD_DATASETS = REQUIRED_DATASETS + ("opt_quat", "opt_pos", "movement")
#: What each required dataset holds: (N, 3) in the sensor frame.
CHANNEL_MEANINGS = {"imu_gyr": "gyroscope, rad/s", "imu_acc": "accelerometer, m/s²",
                    "imu_mag": "magnetometer, µT"}

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
    mag_uT: np.ndarray | None       #: ``None`` only when read with ``require_mag=False``
    q_ref_world_from_sensor: np.ndarray | None
    movement: np.ndarray | None

    @property
    def n_samples(self) -> int:
        return self.gyr_rad_s.shape[0]

    @property
    def t_s(self) -> np.ndarray:
        """Sample times (s) from the constant sampling rate, starting at 0."""
        t = np.arange(self.n_samples, dtype=np.float64)  # k / rate, divided in place: one array
        t /= self.sampling_rate_hz
        return t

    def samples(self, with_mag: bool = True) -> SensorSamples:
        """The trial's IMU channels as one sensor's samples, named after the trial (the
        magnetometer as the data set calibrated it, µT, unless ``with_mag`` is False)."""
        return SensorSamples(self.name, self.t_s, np.arange(self.n_samples), acc=self.acc_m_s2, gyr=self.gyr_rad_s,
                             mag_uT=self.mag_uT if with_mag else None)

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


def _has_broad_layout(handle: h5py.File) -> bool:
    """Whether an open HDF5 file is laid out as a BROAD trial: at least one of
    :data:`BROAD_DATASETS` and no ``format`` attribute (which marks a MimuCap session)."""
    return "format" not in handle.attrs and any(name in handle for name in BROAD_DATASETS)


def is_broad_file(path: str | Path) -> bool:
    """Whether ``path`` is an HDF5 file laid out as a BROAD trial, complete or not (then
    :func:`read_broad` names the missing dataset; a foreign HDF5 file gives ``False``)."""
    try:
        with h5py.File(path, "r") as handle:
            return _has_broad_layout(handle)
    except OSError:
        return False


def _check_channels(handle: h5py.File, path: Path, required: tuple[str, ...]) -> None:
    """``ValueError`` naming every ``required`` IMU dataset the file lacks: a BROAD trial
    without some channel, or a file that is no BROAD trial at all."""
    missing = [name for name in required if name not in handle]
    if not missing:
        return
    found = ", ".join(sorted(handle.keys())) or "nothing"
    if not _has_broad_layout(handle):
        raise ValueError(f"{path}: not a BROAD trial, dataset {missing[0]!r} is missing (found: {found})")
    names = " and ".join(f"{name!r} ({CHANNEL_MEANINGS[name]})" for name in missing)
    raise ValueError(f"{path}: BROAD trial without {names}; it holds {found}")


def read_broad(path: str | Path, require_mag: bool = True) -> BroadTrial:
    """Read one BROAD trial; ``ValueError`` naming the file and the problem if it is not one.

    With ``require_mag=False`` a trial without ``imu_mag`` is read with ``mag_uT=None``.
    """
    path = Path(path)
    if not path.is_file():
        raise OSError(f"{path}: no such file")
    try:
        handle = h5py.File(path, "r")
    except OSError as error:
        raise ValueError(f"{path}: not an HDF5 file ({error})") from None
    with handle:
        _check_channels(handle, path, REQUIRED_DATASETS if require_mag else INERTIAL_DATASETS)
        gyr = _dataset(handle, path, "imu_gyr", 3)
        problem = gyro_range_problem(gyr)
        if problem is not None:
            raise ValueError(f"{path}: imu_gyr: {problem}")
        acc = _dataset(handle, path, "imu_acc", 3)
        mag = _dataset(handle, path, "imu_mag", 3) if "imu_mag" in handle else None  # present when required
        if gyr.shape != acc.shape or (mag is not None and mag.shape != gyr.shape):
            shapes = f"imu_gyr {gyr.shape}, imu_acc {acc.shape}" + ("" if mag is None else f", imu_mag {mag.shape}")
            raise ValueError(f"{path}: {shapes} must have the same number of rows")
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
