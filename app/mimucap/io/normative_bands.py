"""Normative bands of joint angles over the gait cycle: a small documented CSV format.

::

    # mimucap-normative-bands 1
    # source: who measured it, on whom, and the licence
    joint,axis,percent,mean_deg,sd_deg
    knee,flexion,0,5.0,3.0
    knee,flexion,10,15.0,4.5
    ...

* Lines starting with ``#`` are comments; the first must be ``# mimucap-normative-bands 1``,
  and a ``# source:`` line is required (a band without its source is not a reference).
* The header is ``joint,axis,percent`` followed by either ``mean_deg,sd_deg`` (the band is
  mean ± SD) or ``lower_deg,upper_deg``.
* ``joint`` is a model joint without side (``hip``, ``knee``, ``ankle``, ``lumbar``, ...): a
  band applies to both sides, since the joint angles are mirrored (left like right);
  ``axis`` is ``flexion``, ``adduction`` or ``rotation``; ``percent`` of the gait cycle from
  initial contact (0) to the next initial contact (100), ascending per joint and axis, from 0
  to 100; angles in degrees in the signs of ``core.skeleton.JOINT_ANGLE_SIGNS_DOC``.

No band is shipped with MimuCap: published normal gait curves carry their authors' licences.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from mimucap.core.analysis.gait_cycle import NormativeBand

MAGIC = "# mimucap-normative-bands 1"
AXES = ("flexion", "adduction", "rotation")


def read_normative_bands(path: str | Path) -> dict[tuple[str, str], NormativeBand]:
    """The bands of a file, keyed (joint, axis); ``ValueError`` naming the file and line."""
    source = Path(path)
    lines = source.read_text(encoding="utf-8").splitlines()
    if not lines or lines[0].strip() != MAGIC:
        raise ValueError(f"{source}: line 1 must be '{MAGIC}'")
    origin = ""
    data: list[tuple[int, str]] = []
    for number, line in enumerate(lines, start=1):
        stripped = line.strip()
        if stripped.startswith("#"):
            if stripped[1:].strip().lower().startswith("source:"):
                origin = stripped[1:].strip()[len("source:"):].strip()
        elif stripped:
            data.append((number, line))
    if not origin:
        raise ValueError(f"{source}: a '# source: ...' line naming where the band comes from is required")
    if not data:
        raise ValueError(f"{source}: no header and no rows")
    header_line, header_text = data[0]
    header = [h.strip() for h in next(csv.reader([header_text]))]
    if header[:3] != ["joint", "axis", "percent"] or header[3:] not in (["mean_deg", "sd_deg"], ["lower_deg", "upper_deg"]):
        raise ValueError(f"{source}: line {header_line}: header must be joint,axis,percent,mean_deg,sd_deg "
                         f"or joint,axis,percent,lower_deg,upper_deg")
    with_sd = header[3] == "mean_deg"
    rows: dict[tuple[str, str], list[tuple[float, float, float]]] = {}
    for number, text in data[1:]:
        cells = [c.strip() for c in next(csv.reader([text]))]
        if len(cells) != 5:
            raise ValueError(f"{source}: line {number}: expected 5 values, got {len(cells)}")
        joint, axis = cells[0], cells[1]
        if not joint.isidentifier() or axis not in AXES:
            raise ValueError(f"{source}: line {number}: joint {joint!r} / axis {axis!r} (axis one of {', '.join(AXES)})")
        try:
            percent, a, b = (float(c) for c in cells[2:])
        except ValueError:
            raise ValueError(f"{source}: line {number}: percent and angles must be numbers") from None
        if not all(math.isfinite(v) for v in (percent, a, b)) or not 0.0 <= percent <= 100.0:
            raise ValueError(f"{source}: line {number}: percent must be 0..100 and angles finite")
        if with_sd and b < 0:
            raise ValueError(f"{source}: line {number}: SD must not be negative")
        if not with_sd and b < a:
            raise ValueError(f"{source}: line {number}: upper limit below lower limit")
        series = rows.setdefault((joint, axis), [])
        if series and percent <= series[-1][0]:
            raise ValueError(f"{source}: line {number}: percent must increase within {joint} {axis}")
        series.append((percent, a, b))
    bands = {}
    for (joint, axis), series in rows.items():
        values = np.asarray(series, dtype=float)
        if values[0, 0] != 0.0 or values[-1, 0] != 100.0:
            raise ValueError(f"{source}: {joint} {axis} must cover 0 to 100 % of the cycle")
        lower, upper = (values[:, 1] - values[:, 2], values[:, 1] + values[:, 2]) if with_sd else (values[:, 1], values[:, 2])
        bands[(joint, axis)] = NormativeBand(joint, axis, values[:, 0], lower, upper, origin)
    return bands
