"""APDM ``Format=7`` CSV (found among OpenSense's format samples): orientations of APDM sensors.

One block per sensor with ``Orientation S,X,Y,Z`` = ``q_world_from_sensor`` in a z-up world;
``Time`` in microseconds (the table starts at 0). Sensors are named by their label, else their
id. Bad input raises ``ValueError`` naming the file, line and sensor.
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import numpy as np

from mimucap.io.orientation_tables import QuaternionTable, check_time, checked_unit, parse_float


def read_apdm_csv(path: str | Path) -> QuaternionTable:
    """Read an APDM ``Format=7`` CSV: sensors named by their label (else id), world z up."""
    path = Path(path)
    source = str(path)
    with path.open(newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    if len(rows) < 4 or not rows[0] or not rows[0][0].startswith("Format="):
        raise ValueError(f"{source}: not an APDM 'Format=' CSV")
    ids, groups, axes = rows[0], rows[1], rows[2]
    width = len(groups)
    starts = [i for i in range(1, len(ids)) if re.fullmatch(r"\d+", ids[i].strip())]
    if not starts:
        raise ValueError(f"{source}: line 1: no sensor ids")
    if groups[0].strip().lower() != "time":
        raise ValueError(f"{source}: line 2: first column must be Time")
    sensors: dict[str, int] = {}
    for k, start in enumerate(starts):
        end = starts[k + 1] if k + 1 < len(starts) else width
        label = ids[start + 3].strip() if start + 3 < len(ids) and ids[start + 3].strip() else ids[start].strip()
        cols = [i for i in range(start, end) if groups[i].strip().lower() == "orientation"]
        if not cols or cols[0] + 4 > width or [a.strip().upper() for a in axes[cols[0]:cols[0] + 4]] != ["S", "X", "Y", "Z"]:
            raise ValueError(f"{source}: sensor {label}: no 'Orientation S,X,Y,Z' columns")
        sensors[label] = cols[0]
    data_rows = rows[3:]
    lines = np.arange(4, 4 + len(data_rows))
    values = []
    for number, row in zip(lines, data_rows):
        if len(row) != width:
            raise ValueError(f"{source}: line {number}: {len(row)} fields, expected {width}")
        values.append([parse_float(c, source, number, groups[i] or f"col{i}") if c.strip() else math.nan
                       for i, c in enumerate(row)])
    data = np.array(values)
    t = (data[:, 0] - data[0, 0]) * 1e-6
    check_time(t, source, lines)
    quats = {label: checked_unit(data[:, c:c + 4], source, label, lines) for label, c in sensors.items()}
    return QuaternionTable(t, quats, np.array([0.0, 0.0, 1.0]), "APDM world (z up)", source)
