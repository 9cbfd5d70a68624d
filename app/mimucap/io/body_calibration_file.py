"""Body calibration files (``CAL.json``): write and read :class:`~mimucap.core.bodycal.BodyCalibration`.

Content (JSON object): ``format`` = ``"mimucap-body-calibration"``, ``format_version`` = 1,
``method`` (``"npose_tpose"`` or ``"heading"``), ``q_world_from_body`` ``[w, x, y, z]``,
``up_world`` (the world's up unit vector), ``segments``: ``{segment: {"sensor": id,
"q_segment_from_sensor": [w, x, y, z]}}``, ``quality`` (figures in degrees, see
:meth:`~mimucap.core.bodycal.CalibrationQuality.to_dict`), ``verdict`` (``good``,
``acceptable`` or ``poor``), the pose windows in seconds and, when written by the command line,
the model, input file and reader options.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path

from mimucap.core.bodycal import BodyCalibration


def calibration_document(calibration: BodyCalibration, extra: Mapping[str, object] | None = None) -> dict:
    """The JSON document of ``calibration`` with ``extra`` keys (model, input...) added."""
    document = calibration.to_dict()
    for key, value in (extra or {}).items():
        if key in document:
            raise ValueError(f"calibration document key {key!r} is reserved")
        document[key] = value
    return document


def write_body_calibration(path: str | Path, calibration: BodyCalibration, extra: Mapping[str, object] | None = None) -> dict:
    """Write ``calibration`` as JSON to ``path``; return the document written."""
    document = calibration_document(calibration, extra)
    Path(path).write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")
    return document


def read_body_calibration(path: str | Path) -> tuple[BodyCalibration, dict]:
    """Read a calibration file: the calibration and the whole JSON document."""
    path = Path(path)
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as error:
        raise ValueError(f"{path}: invalid JSON at line {error.lineno}: {error.msg}") from None
    return BodyCalibration.from_dict(document, str(path)), document
