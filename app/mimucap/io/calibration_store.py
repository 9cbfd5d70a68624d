"""Where calibrations are kept: the user's store of magnetometer calibrations per device, and the
calibrations a session file or a body calibration carries, as versioned JSON.

A calibration describes one piece of hardware, so it is kept for the *device* it was made on
(:mod:`mimucap.core.device_identity`), with the sensor id as its human label. Location:
``<data dir>/calibrations/magnetometer/devices/<device id>.json`` (the device id with ``:`` and
``/`` written ``_``), and ``<data dir>/calibrations/magnetometer/<sensor id>.json`` for a
calibration whose device is not known (a node that sends no hardware id, a file fitted without
one, and every file written before calibrations were tied to devices). The data dir is
``$MIMUCAP_DATA_DIR`` if set (tests), else ``$XDG_DATA_HOME/mimucap``, else
``~/.local/share/mimucap``. Writes are atomic (temporary file + rename).

The JSON object (format version :data:`CALIBRATION_FORMAT_VERSION`; version 1 had no
``device_id`` and is read as a calibration of an unknown device; versions 1 and 2 had no
gyroscope correction and are read with the identity, their ``gyr_quality`` saying so)::

    {"format": "mimucap-magcal", "format_version": 3, "sensor_id": "S01",
     "device_id": "mac:A1B2C3D4E5F6", "created_utc": "2026-11-21T06:30:00Z",
     "protocol": "single_axis", "samples_used": 2400, "offset_uT": [bx, by, bz],
     "soft_iron": [[...], [...], [...]], "field_uT": 49.3,
     "quality": {"rms_residual_uT": ..., "verdict": "good", ...},
     "gyr_correction": [[...], [...], [...]], "gyr_quality": {"applied": true, ...}}

``soft_iron`` is ``A⁻¹`` (symmetric); apply as ``mag_cal = soft_iron @ (mag_raw − offset_uT)``
(sensor frame, µT); ``gyr_correction`` ``C`` as ``ω = C @ ω_raw`` (sensor frame, rad/s; the
identity when the turns did not determine it, :mod:`mimucap.core.magcal.gyro_scale`). The same object is what every other place keeps of a calibration:

* a file given on the command line (``--mag-calibration FILE``, :func:`read_calibration_file`);
* a session file: the magnetometer calibrations a recording applied under
  ``session.calibrations["magnetometer"][sensor_id]`` and its body calibration under
  ``session.calibrations["body"]`` (:func:`session_calibrations`,
  :func:`magnetometer_calibrations_of`, :func:`body_calibration_of`; one at a time:
  :func:`embed_in_session`, :func:`calibration_from_session`);
* a body calibration, which carries the magnetometer calibrations its N-pose orientations were
  computed with (sensor id → the object: :func:`calibrations_to_json`,
  :func:`calibrations_from_json`).

Which stored calibration a sensor gets is :meth:`CalibrationStore.lookup`'s decision: its
device's, and no other. A sensor of a known device never takes a calibration stored under its
label for another device or for an unknown one; a sensor whose device is not known takes only a
calibration of an unknown device stored under its label (its device stays unverified, which
:mod:`mimucap.core.magcal.standing` says). Either refusal comes with a sentence saying why.
Loading a calibration for another sensor id or device is refused; a corrupt, foreign or newer
file raises :class:`CalibrationFileError` (a ``ValueError``) naming the file and the problem.
"""

from __future__ import annotations

import json
import math
import os
import re
import tempfile
from collections.abc import Mapping, MutableMapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mimucap.core import bodycal
from mimucap.core.device_identity import SensorDevice, check_device_id, describe_device
from mimucap.core.magcal.model import MagCalibration
from mimucap.io.json_document import read_json_document

CALIBRATION_FORMAT = "mimucap-magcal"
CALIBRATION_FORMAT_VERSION = 3
#: What an older file without a gyroscope correction says of it.
NO_GYRO_CORRECTION = {"applied": False, "reason": "calibrated before MimuCap estimated the gyroscope's scale"}
#: Sub-folder of the store holding the calibrations of known devices.
DEVICES_FOLDER = "devices"
#: Key of the magnetometer calibrations in ``Session.calibrations``.
SESSION_KEY = "magnetometer"
#: Key of the body calibration in ``Session.calibrations``.
BODY_KEY = "body"
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
        "device_id": calibration.device_id,
        "created_utc": calibration.created_utc,
        "protocol": calibration.protocol,
        "samples_used": int(calibration.samples_used),
        "offset_uT": [float(v) for v in calibration.offset_uT],
        "soft_iron": [[float(v) for v in row] for row in calibration.soft_iron],
        "field_uT": float(calibration.field_uT),
        "quality": _plain(calibration.quality),
        "gyr_correction": [[float(v) for v in row] for row in calibration.gyr_correction],
        "gyr_quality": _plain(calibration.gyr_quality),
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
    device_id = data.get("device_id")
    if device_id is not None:
        try:
            check_device_id(device_id, f"{source}: device_id")
        except ValueError as error:
            raise CalibrationFileError(str(error)) from None
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
            device_id=device_id,
            gyr_correction=np.asarray(data.get("gyr_correction", np.eye(3)), dtype=np.float64),
            gyr_quality=dict(data["gyr_quality"] if "gyr_quality" in data else NO_GYRO_CORRECTION),
        )
    except (KeyError, TypeError, ValueError) as error:
        raise CalibrationFileError(f"{source}: invalid calibration ({error})") from error
    return calibration


@dataclass(frozen=True)
class StoredCalibration:
    """What the store holds for one sensor (:meth:`CalibrationStore.lookup`): ``calibration``
    to apply, or ``None``; ``note``: why a calibration stored under the sensor's label is not
    applied, or that the one applied cannot be checked against the device ("" when there is
    nothing to say)."""

    calibration: MagCalibration | None
    note: str = ""


def device_file_name(device_id: str) -> str:
    """The file name of ``device_id``'s calibration (``mac:A1…/1`` → ``mac_A1…_1.json``)."""
    return check_device_id(device_id).replace(":", "_").replace("/", "_") + ".json"


class CalibrationStore:
    """Magnetometer calibrations on disk, one JSON file per device (see the module docstring).

    directory: where the files live (default ``user_data_dir()/calibrations/magnetometer``).
    """

    def __init__(self, directory: str | os.PathLike[str] | None = None) -> None:
        self.directory = Path(directory) if directory is not None else user_data_dir() / "calibrations" / SESSION_KEY

    def path_for(self, sensor_id: str, device_id: str | None = None) -> Path:
        """The file of ``device_id``'s calibration, or, without a device, of ``sensor_id``'s
        (ids must be 1–64 letters, digits, ``_``, ``.`` or ``-``)."""
        if device_id is not None:
            return self.directory / DEVICES_FOLDER / device_file_name(device_id)
        if not isinstance(sensor_id, str) or not _SENSOR_ID.match(sensor_id) or ".." in sensor_id:
            raise ValueError(
                f"sensor id {sensor_id!r} cannot name a calibration file: use letters, digits, _ . -"
            )
        return self.directory / f"{sensor_id}.json"

    def save(self, calibration: MagCalibration) -> Path:
        """Write ``calibration`` (replacing its device's previous one, or, without a device, the
        sensor's) and return its path."""
        path = self.path_for(calibration.sensor_id, calibration.device_id)
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

    def _read(self, path: Path, sensor_id: str | None = None) -> MagCalibration:
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as error:
            raise CalibrationFileError(f"{path}: corrupt calibration file ({error}); calibrate the sensor again") from error
        return calibration_from_json(data, str(path), expected_sensor_id=sensor_id)

    def load(self, sensor_id: str, device_id: str | None = None) -> MagCalibration:
        """The stored calibration of device ``device_id``, or, without one, the calibration
        stored under label ``sensor_id``: the unknown device's, else the only device's labelled
        so (a tool's look-up by name; :meth:`lookup` decides what a sensor may use).

        Raises ``FileNotFoundError`` if there is none, :class:`CalibrationFileError` if the
        file is corrupt, belongs to another sensor or device, or the label names several devices.
        """
        if device_id is not None:
            path = self.path_for(sensor_id, device_id)
            if not path.is_file():
                raise FileNotFoundError(f"no magnetometer calibration for {describe_device(device_id)} "
                                        f"(looked for {path})")
            calibration = self._read(path)
            if calibration.device_id != device_id:
                raise CalibrationFileError(f"{path}: this calibration belongs to device {calibration.device_id}, "
                                           f"not {device_id}; it cannot be used for another device")
            return calibration
        path = self.path_for(sensor_id)
        if path.is_file():
            return self._read(path, sensor_id)
        labelled = [c for c in self._device_calibrations() if c.sensor_id == sensor_id]
        if len(labelled) > 1:
            raise CalibrationFileError(f"{self.directory}: {len(labelled)} devices have a calibration labelled "
                                       f"{sensor_id} ({', '.join(c.device_id for c in labelled)}): name the device")
        if not labelled:
            raise FileNotFoundError(f"no magnetometer calibration for sensor {sensor_id!r} (looked in {self.directory})")
        return labelled[0]

    def _device_calibrations(self) -> list[MagCalibration]:
        """Every readable calibration of a known device (an unreadable file is skipped: it is
        named when its device is looked up)."""
        folder = self.directory / DEVICES_FOLDER
        found = []
        for path in sorted(folder.glob("*.json")) if folder.is_dir() else ():
            try:
                found.append(self._read(path))
            except (CalibrationFileError, OSError):
                continue
        return found

    def lookup(self, sensor_id: str, device: SensorDevice) -> StoredCalibration:
        """The calibration sensor ``sensor_id`` may use, being ``device`` (see the module
        docstring), with a note when one stored under its label is not used or when its device
        cannot be checked. A device that is not settled yet gets nothing and no note (ask again
        once the source has said). A corrupt file of its own raises :class:`CalibrationFileError`."""
        if not device.settled:
            return StoredCalibration(None)
        if device.device_id is not None:
            path = self.path_for(sensor_id, device.device_id)
            if path.is_file():
                return StoredCalibration(self.load(sensor_id, device.device_id))
            others = self._labelled(sensor_id, exclude=device.device_id)
            if not others:
                return StoredCalibration(None)
            return StoredCalibration(None, f"the calibration stored under {sensor_id} {others}; this sensor is "
                                           f"{describe_device(device.device_id)}: not used, calibrate it here")
        path = self.path_for(sensor_id)
        if path.is_file():
            return StoredCalibration(self._read(path, sensor_id))
        others = self._labelled(sensor_id, exclude=None)
        if not others:
            return StoredCalibration(None)
        return StoredCalibration(None, f"{sensor_id} does not say which device it is ({device.missing}); the "
                                       f"calibration stored under {sensor_id} {others}: not used")

    def _labelled(self, sensor_id: str, exclude: str | None) -> str:
        """How the calibrations labelled ``sensor_id`` other than ``exclude``'s are described
        ("is of MAC …, made …"), "" when there are none."""
        stored = [c for c in self._device_calibrations() if c.sensor_id == sensor_id and c.device_id != exclude]
        unknown = self.path_for(sensor_id)
        if exclude is not None and unknown.is_file():
            try:
                stored.append(self._read(unknown, sensor_id))
            except (CalibrationFileError, OSError):
                pass
        if not stored:
            return ""
        described = [(f"is of {describe_device(c.device_id)}" if c.device_id else
                      "was made before calibrations were tied to a device")
                     + (f" ({c.created_utc})" if c.created_utc else "") for c in stored]
        return " and ".join(described)

    def sensor_ids(self) -> list[str]:
        """Labels (sensor ids) of the stored calibrations, sorted, each once."""
        if not self.directory.is_dir():
            return []
        labels = {p.stem for p in self.directory.glob("*.json")}
        labels.update(c.sensor_id for c in self._device_calibrations())
        return sorted(labels)


def calibrations_to_json(calibrations: Mapping[str, MagCalibration]) -> dict[str, dict[str, Any]]:
    """Sensor id → the JSON object of its calibration (what a session or a body calibration keeps)."""
    return {sensor_id: calibration_to_json(calibration) for sensor_id, calibration in calibrations.items()}


def calibrations_from_json(section: Any, origin: str, what: str = "magnetometer calibrations") -> dict[str, MagCalibration]:
    """Inverse of :func:`calibrations_to_json`; :class:`CalibrationFileError` naming ``origin``
    (and ``what``, when the section is no mapping) when it is malformed or a calibration is
    filed under another sensor's id."""
    if not isinstance(section, Mapping):
        raise CalibrationFileError(f"{origin}: {what} is not a mapping")
    return {sensor_id: calibration_from_json(data, f"{origin}: magnetometer calibration of {sensor_id}", sensor_id)
            for sensor_id, data in section.items()}


def read_calibration_file(path: str | os.PathLike[str], option: str = "") -> MagCalibration:
    """The calibration in the JSON file ``path`` (any sensor's); ``ValueError`` naming the file
    (and ``option``, the command-line option that gave it) and what it is when it cannot be read
    or is not one (:func:`~mimucap.io.json_document.read_json_document`)."""
    what = f"magnetometer calibration ({option})" if option else "magnetometer calibration"
    return calibration_from_json(read_json_document(path, what), str(path))


def session_calibrations(mag_calibrations: Mapping[str, MagCalibration],
                         body_calibration: bodycal.BodyCalibration | None) -> dict[str, Any]:
    """The ``calibrations`` a recording stores: the magnetometer calibrations it applied and its
    body calibration (each only when there is one)."""
    calibrations: dict[str, Any] = {}
    if mag_calibrations:
        calibrations[SESSION_KEY] = calibrations_to_json(mag_calibrations)
    if body_calibration is not None:
        calibrations[BODY_KEY] = body_calibration.to_dict()
    return calibrations


def magnetometer_calibrations_of(calibrations: Mapping[str, Any], origin: str) -> dict[str, MagCalibration]:
    """Sensor → the magnetometer calibration a session's ``calibrations`` carry (none: empty);
    :class:`CalibrationFileError` naming ``origin`` when one is malformed."""
    return calibrations_from_json(calibrations.get(SESSION_KEY) or {}, origin)


def body_calibration_of(calibrations: Mapping[str, Any], metadata: Mapping[str, Any],
                        origin: str) -> bodycal.BodyCalibration | None:
    """The body calibration a session stores (``calibrations["body"]``, or an older file's
    ``metadata["body_calibration"]``), or None; ``ValueError`` naming ``origin`` when malformed."""
    body = calibrations.get(BODY_KEY) or metadata.get("body_calibration")
    if not body:
        return None
    return bodycal.BodyCalibration.from_dict(body, origin=f"{origin}: body calibration")


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
