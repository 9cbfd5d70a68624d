"""Persist magnetometer calibrations per sensor id as versioned JSON.

Location: ``<data dir>/calibrations/magnetometer/<sensor id>.json`` where the data dir is
``$MIMUCAP_DATA_DIR`` if set (tests), else ``$XDG_DATA_HOME/mimucap``, else
``~/.local/share/mimucap``. Writes are atomic (temporary file + rename).

The JSON object (format version :data:`CALIBRATION_FORMAT_VERSION`)::

    {"format": "mimucap-magcal", "format_version": 1, "sensor_id": "S01",
     "created_utc": "2026-11-21T06:30:00Z", "protocol": "single_axis", "samples_used": 2400,
     "offset_uT": [bx, by, bz], "soft_iron": [[...], [...], [...]], "field_uT": 49.3,
     "quality": {"rms_residual_uT": ..., "verdict": "good", ...}}

``soft_iron`` is ``A⁻¹`` (symmetric); apply as ``mag_cal = soft_iron @ (mag_raw − offset_uT)``
(sensor frame, µT). A session file embeds the calibrations it used under
``session.calibrations["magnetometer"][sensor_id]`` with the same object
(:func:`embed_in_session`, :func:`calibration_from_session`).

Loading a calibration for another sensor id is refused; a corrupt, foreign or newer file
raises :class:`CalibrationFileError` (a ``ValueError``) naming the file and the problem.
"""

from __future__ import annotations

import json
import math
import os
import re
import tempfile
from collections.abc import MutableMapping
from pathlib import Path
from typing import Any

import numpy as np

from mimucap.core.magcal import MagCalibration

CALIBRATION_FORMAT = "mimucap-magcal"
CALIBRATION_FORMAT_VERSION = 1
#: Key of the magnetometer calibrations in ``Session.calibrations``.
SESSION_KEY = "magnetometer"
_SENSOR_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]{0,63}$")


class CalibrationFileError(ValueError):
    """A calibration file or object is corrupt, foreign, too new or for another sensor."""


def user_data_dir() -> Path:
    """MimuCap's user data folder (see module docstring for the search order)."""
    override = os.environ.get("MIMUCAP_DATA_DIR")
    if override:
        return Path(override)
    xdg = os.environ.get("XDG_DATA_HOME")
    base = Path(xdg) if xdg else Path.home() / ".local" / "share"
    return base / "mimucap"


def calibration_to_json(calibration: MagCalibration) -> dict[str, Any]:
    """The versioned JSON object of ``calibration`` (plain lists and floats)."""
    return {
        "format": CALIBRATION_FORMAT,
        "format_version": CALIBRATION_FORMAT_VERSION,
        "sensor_id": calibration.sensor_id,
        "created_utc": calibration.created_utc,
        "protocol": calibration.protocol,
        "samples_used": int(calibration.samples_used),
        "offset_uT": [float(v) for v in calibration.offset_uT],
        "soft_iron": [[float(v) for v in row] for row in calibration.soft_iron],
        "field_uT": float(calibration.field_uT),
        "quality": _plain(calibration.quality),
    }


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, float)):
        number = float(value)
        return number if math.isfinite(number) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def calibration_from_json(
    data: Any, source: str, expected_sensor_id: str | None = None
) -> MagCalibration:
    """Parse and validate a calibration object read from ``source`` (used in messages).

    Raises :class:`CalibrationFileError` if it is malformed, of another format, of a newer
    version, or (with ``expected_sensor_id``) for another sensor.
    """
    if not isinstance(data, dict) or data.get("format") != CALIBRATION_FORMAT:
        raise CalibrationFileError(f"{source}: not a MimuCap magnetometer calibration")
    version = data.get("format_version")
    if not isinstance(version, int) or version < 1:
        raise CalibrationFileError(f"{source}: missing or invalid format_version")
    if version > CALIBRATION_FORMAT_VERSION:
        raise CalibrationFileError(
            f"{source}: calibration format version {version} is newer than this MimuCap reads "
            f"({CALIBRATION_FORMAT_VERSION}); update MimuCap"
        )
    sensor_id = data.get("sensor_id")
    if not isinstance(sensor_id, str) or not sensor_id:
        raise CalibrationFileError(f"{source}: missing sensor_id")
    if expected_sensor_id is not None and sensor_id != expected_sensor_id:
        raise CalibrationFileError(
            f"{source}: this calibration belongs to sensor {sensor_id!r}, not {expected_sensor_id!r}; "
            "it cannot be used for another sensor"
        )
    try:
        calibration = MagCalibration(
            sensor_id=sensor_id,
            offset_uT=np.asarray(data["offset_uT"], dtype=np.float64),
            soft_iron=np.asarray(data["soft_iron"], dtype=np.float64),
            field_uT=float(data["field_uT"]),
            created_utc=str(data.get("created_utc", "")),
            protocol=str(data.get("protocol", "")),
            samples_used=int(data.get("samples_used", 0)),
            quality=dict(data.get("quality") or {}),
        )
    except (KeyError, TypeError, ValueError) as error:
        raise CalibrationFileError(f"{source}: invalid calibration ({error})") from error
    return calibration


class CalibrationStore:
    """Magnetometer calibrations on disk, one JSON file per sensor id.

    directory: where the files live (default ``user_data_dir()/calibrations/magnetometer``).
    """

    def __init__(self, directory: str | os.PathLike[str] | None = None) -> None:
        self.directory = Path(directory) if directory is not None else user_data_dir() / "calibrations" / SESSION_KEY

    def path_for(self, sensor_id: str) -> Path:
        """The file of ``sensor_id``; ids must be 1–64 letters, digits, ``_``, ``.`` or ``-``."""
        if not isinstance(sensor_id, str) or not _SENSOR_ID.match(sensor_id) or ".." in sensor_id:
            raise ValueError(
                f"sensor id {sensor_id!r} cannot name a calibration file: use letters, digits, _ . -"
            )
        return self.directory / f"{sensor_id}.json"

    def save(self, calibration: MagCalibration) -> Path:
        """Write ``calibration`` (replacing the sensor's previous one) and return its path."""
        path = self.path_for(calibration.sensor_id)
        path.parent.mkdir(parents=True, exist_ok=True)
        text = json.dumps(calibration_to_json(calibration), indent=2, allow_nan=False)
        handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        try:
            with os.fdopen(handle, "w", encoding="utf-8") as stream:
                stream.write(text + "\n")
            os.replace(temporary, path)
        except BaseException:
            Path(temporary).unlink(missing_ok=True)
            raise
        return path

    def load(self, sensor_id: str) -> MagCalibration:
        """The stored calibration of ``sensor_id``.

        Raises ``FileNotFoundError`` if there is none, :class:`CalibrationFileError` if the
        file is corrupt or belongs to another sensor.
        """
        path = self.path_for(sensor_id)
        if not path.is_file():
            raise FileNotFoundError(f"no magnetometer calibration for sensor {sensor_id!r} (looked for {path})")
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as error:
            raise CalibrationFileError(f"{path}: corrupt calibration file ({error}); calibrate the sensor again") from error
        return calibration_from_json(data, str(path), expected_sensor_id=sensor_id)

    def sensor_ids(self) -> list[str]:
        """Ids of the sensors with a stored calibration, sorted."""
        if not self.directory.is_dir():
            return []
        return sorted(p.stem for p in self.directory.glob("*.json"))


def embed_in_session(calibrations: MutableMapping[str, Any], calibration: MagCalibration) -> None:
    """Put ``calibration`` into a session's ``calibrations`` dict (``["magnetometer"][sensor_id]``)."""
    section = calibrations.setdefault(SESSION_KEY, {})
    if not isinstance(section, dict):
        raise CalibrationFileError(f"session calibrations[{SESSION_KEY!r}] is not a mapping")
    section[calibration.sensor_id] = calibration_to_json(calibration)


def calibration_from_session(calibrations: MutableMapping[str, Any], sensor_id: str) -> MagCalibration:
    """The magnetometer calibration of ``sensor_id`` embedded in a session's ``calibrations``;
    ``KeyError`` naming the sensor if the session has none for it."""
    section = calibrations.get(SESSION_KEY) or {}
    if sensor_id not in section:
        raise KeyError(f"the session holds no magnetometer calibration for sensor {sensor_id!r}")
    return calibration_from_json(section[sensor_id], f"session calibration {sensor_id!r}", sensor_id)
