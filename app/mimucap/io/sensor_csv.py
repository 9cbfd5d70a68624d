"""One sensor's raw channels and orientation as CSV (an export of a reviewed recording).

Columns: ``t_s`` (s, the session's clock), then those the sensor has, in the sensor frame:
``acc_<x|y|z>_m_s2`` (specific force), ``gyr_<x|y|z>_rad_s``, ``mag_<x|y|z>_uT`` (raw field),
then ``q_world_from_sensor_<w|x|y|z>`` (scalar first, world ENU) when the processing gave one.
``#`` lines first: the sensor and its segment, then the caller's notes (what the result holds,
the markers of the range).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mimucap.core.sensor_samples import SensorSamples


def write_sensor_csv(path: str | Path, samples: SensorSamples, q_world_from_sensor: np.ndarray | None,
                     notes: Sequence[str] = ()) -> Path:
    """Write ``samples`` (the rows to export; absent channels are left out) with their
    orientations ``q_world_from_sensor`` (N, 4) or None, headed by ``notes``."""
    columns: list[tuple[str, np.ndarray]] = [("t_s", np.asarray(samples.t_s))]
    for name, unit, values in (("acc", "m_s2", samples.acc), ("gyr", "rad_s", samples.gyr),
                               ("mag", "uT", samples.mag_uT)):
        if values is not None:
            columns += [(f"{name}_{axis}_{unit}", values[:, i]) for i, axis in enumerate("xyz")]
    if q_world_from_sensor is not None:
        columns += [(f"q_world_from_sensor_{c}", q_world_from_sensor[:, i]) for i, c in enumerate("wxyz")]
    path = Path(path)
    with path.open("w", encoding="utf-8", newline="") as handle:
        handle.write(f"# MimuCap sensor {samples.sensor_id} (segment {samples.segment or 'none'}); sensor frame; "
                     "q_world_from_sensor scalar first, world ENU\n")
        for line in notes:
            handle.write(f"# {line}\n")
        handle.write(",".join(name for name, _ in columns) + "\n")
        table = np.column_stack([v for _, v in columns])
        np.savetxt(handle, table, delimiter=",", fmt="%.6f")
    return path
