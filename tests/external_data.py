"""The public recordings the full suite reads, where they are looked for, and what each one is.

They are not part of the repository (each carries its own licence): the suite reads them from
the folder named by ``MIMUCAP_TEST_DATA`` (default ``../shared/data`` beside the repository).
A test that needs one carries the marker ``@pytest.mark.data("<set>")``; when the set is missing
the test is skipped with the set's name, and the run ends with one line counting those skips.
With ``MIMUCAP_REQUIRE_TEST_DATA=1`` (CI) a missing set fails the run instead, naming it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_ROOT_TEXT = "../shared/data"


@dataclass(frozen=True)
class DataSet:
    """One public recording set: its folder below the data root and what a reader needs to know."""

    folder: str
    title: str
    origin: str
    licence: str


DATA_SETS: dict[str, DataSet] = {
    "broad": DataSet("broad", "BROAD orientation trials",
                     "Laidig, Caruso, Cereatti, Seel, \"BROAD - A Benchmark for Robust Inertial Orientation "
                     "Estimation\", Data 6(7):72, 2021 (14 of its 39 trials)", "CC BY 4.0"),
    "mag-hmc5883l": DataSet("mag/sunsided_hmc5883l", "HMC5883L magnetometer turns",
                            "the public sunsided/sensor-fusion repository", "EUPL-1.2"),
    "mag-mpu9250": DataSet("mag/jremington_mpu9250", "MPU-9250 magnetometer samples",
                           "the public jremington MPU-9250 calibration repository", "MIT"),
    "mag-ellipsoid": DataSet("mag/bazhin_ellipsoid_fit", "ellipsoid-fit magnetometer samples",
                             "the public bazhin ellipsoid_fit repository", "MIT"),
    "opensense": DataSet("body/opensense_example", "OpenSense Xsens walk",
                         "the OpenSim project's OpenSense example (eight Xsens MTw, Rajagopal 2015 model)",
                         "Apache-2.0"),
    "mvnx": DataSet("body/mvnx_sample", "Xsens MVNX sample",
                    "unit-test data of the public andres-fr/blender-mvnx-io repository", "GPL-3.0"),
    "gaitmap": DataSet("gait/gaitmap_example", "gaitmap foot-IMU walk",
                       "the example data of the public mad-lab-fau/gaitmap repository", "MIT"),
}


def data_root() -> Path:
    """The folder holding the data sets: ``$MIMUCAP_TEST_DATA``, else ``../shared/data``."""
    named = os.environ.get("MIMUCAP_TEST_DATA")
    return Path(named) if named else (REPO_ROOT / DEFAULT_ROOT_TEXT)


def data_path(name: str, *parts: str) -> Path:
    """A path inside data set ``name`` (not checked: tests that use it carry ``data(name)``)."""
    return data_root().joinpath(DATA_SETS[name].folder, *parts)


def is_present(name: str) -> bool:
    return data_path(name).is_dir()


def data_required() -> bool:
    """CI sets ``MIMUCAP_REQUIRE_TEST_DATA=1``: there a missing set is an error, not a skip."""
    return os.environ.get("MIMUCAP_REQUIRE_TEST_DATA", "") not in ("", "0")
