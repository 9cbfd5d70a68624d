"""Body calibration files (``CAL.json``): write and read :class:`~mimucap.core.bodycal.BodyCalibration`.

Content (JSON object): ``format`` = ``"mimucap-body-calibration"``, ``format_version`` = 1,
``method`` (``"npose_tpose"`` or ``"heading"``), ``q_world_from_body`` ``[w, x, y, z]``,
``up_world`` (the world's up unit vector), ``segments``: ``{segment: {"sensor": id,
"q_segment_from_sensor": [w, x, y, z]}}``, ``quality`` (figures in degrees, see
:meth:`~mimucap.core.bodycal.CalibrationQuality.to_dict`), ``verdict`` (``good``,
``acceptable`` or ``poor``), the pose windows in seconds and, when written by the command line,
the model, input file and reader options.

Reading refuses, naming the file and the segment or key: a quaternion or vector cell that is
not a number, and one sensor serving two segments (as ``mimucap bodycal --mapping`` does).
"""

from __future__ import annotations

import json
import numbers
from collections.abc import Mapping
from pathlib import Path

from mimucap.core.bodycal import BodyCalibration
from mimucap.io.json_document import read_json_document


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
    document = read_json_document(path, "body calibration")
    _check_numeric_cells(document, path)
    calibration = BodyCalibration.from_dict(document, str(path))
    _check_one_segment_per_sensor(calibration, path)
    return calibration, document


#: Top-level keys holding a vector or quaternion, checked cell by cell before conversion.
_VECTOR_KEYS = ("q_world_from_body", "up_world")


def _is_number(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _check_vector(value: object, where: str) -> None:
    """``ValueError`` naming ``where`` when ``value`` is not a list of numbers."""
    if not isinstance(value, list) or not all(_is_number(v) for v in value):
        raise ValueError(f"{where}: expected a list of numbers, got {value!r}")


def _check_numeric_cells(document: object, path: Path) -> None:
    """Name the file and the segment or key of a non-numeric cell (the conversion to floats
    would only say ``could not convert string to float``). Structure errors are left to
    :meth:`BodyCalibration.from_dict`."""
    if not isinstance(document, Mapping):
        return
    for key in _VECTOR_KEYS:
        if key in document:
            _check_vector(document[key], f"{path}: {key}")
    segments = document.get("segments")
    if isinstance(segments, Mapping):
        for segment, entry in segments.items():
            if isinstance(entry, Mapping) and "q_segment_from_sensor" in entry:
                _check_vector(entry["q_segment_from_sensor"], f"{path}: segment {segment}: q_segment_from_sensor")


def _check_one_segment_per_sensor(calibration: BodyCalibration, path: Path) -> None:
    """``ValueError`` when one sensor is given to two segments: a sensor is worn on one segment."""
    segment_of: dict[str, str] = {}
    for segment, sensor in calibration.sensors.items():
        if sensor in segment_of:
            raise ValueError(f"{path}: sensor {sensor} serves two segments ({segment_of[sensor]} and {segment}); "
                             f"a sensor is worn on one segment")
        segment_of[sensor] = segment
