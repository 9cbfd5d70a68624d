"""The paired suit on disk: the devices this installation takes data from over the network.

A suit is a list of devices (:mod:`mimucap.core.device_identity`): each paired device's id, the
sensor id it was heard as when it was paired (a label for people) and when it was paired. The
network sources let in only these devices (:mod:`mimucap.acquisition.pairing`).

Location: ``<data dir>/paired_devices.json``, beside the ``calibrations`` folder of
:class:`~mimucap.io.calibration_store.CalibrationStore` (the data dir is
:func:`~mimucap.io.calibration_store.user_data_dir`). Writes are atomic (a temporary file
renamed). The JSON object (format version :data:`PAIRINGS_FORMAT_VERSION`)::

    {"format": "mimucap-pairings", "format_version": 1,
     "devices": [{"device_id": "mac:02A1B2C3D4E5", "label": "3", "paired_utc": "2026-11-28T08:30:00Z"}]}

A corrupt, foreign or newer file raises :class:`PairingFileError` (a ``ValueError``) naming the
file: a suit that cannot be read is never taken for an empty one silently.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from mimucap.core.device_identity import check_device_id, describe_device
from mimucap.io.calibration_store import user_data_dir

PAIRINGS_FORMAT = "mimucap-pairings"
PAIRINGS_FORMAT_VERSION = 1
PAIRINGS_FILE_NAME = "paired_devices.json"


class PairingFileError(ValueError):
    """The pairings file is corrupt, foreign or too new."""


@dataclass(frozen=True)
class PairedDevice:
    """One device of the suit: ``device_id``; ``label``, the sensor id it was heard as when it
    was paired; ``paired_utc``, when (ISO 8601, UTC)."""

    device_id: str
    label: str = ""
    paired_utc: str = ""

    def describe(self) -> str:
        """``MAC 02:A1:… (heard as sensor 3)``."""
        return describe_device(self.device_id) + (f" (heard as sensor {self.label})" if self.label else "")


def default_pairings_path() -> Path:
    """The user's pairings file (see the module docstring)."""
    return user_data_dir() / PAIRINGS_FILE_NAME


class PairingStore:
    """The paired devices in the JSON file ``path`` (default :func:`default_pairings_path`)."""

    def __init__(self, path: str | os.PathLike[str] | None = None) -> None:
        self.path = Path(path) if path is not None else default_pairings_path()

    def devices(self) -> list[PairedDevice]:
        """The paired devices, in the order they were paired (none when the file does not exist)."""
        if not self.path.is_file():
            return []
        try:
            data = json.loads(self.path.read_text(encoding="utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as error:
            raise PairingFileError(f"{self.path}: corrupt pairings file ({error}); pair the devices again "
                                   f"after removing it") from None
        return _devices_from_json(data, str(self.path))

    def device_ids(self) -> frozenset[str]:
        """The device ids of the suit."""
        return frozenset(device.device_id for device in self.devices())

    def pair(self, devices: Iterable[tuple[str, str]]) -> list[str]:
        """Add ``(device id, label)`` pairs to the suit; returns the device ids that were not paired
        before (a device paired already keeps its entry). ``ValueError`` for a malformed id."""
        known = self.devices()
        ids = {device.device_id for device in known}
        now = datetime.now(timezone.utc).isoformat(timespec="seconds").replace("+00:00", "Z")
        added = []
        for device_id, label in devices:
            check_device_id(device_id)
            if device_id not in ids:
                ids.add(device_id)
                known.append(PairedDevice(device_id, str(label), now))
                added.append(device_id)
        if added:
            self._write(known)
        return added

    def unpair(self, device_ids: Iterable[str]) -> list[str]:
        """Remove devices from the suit; returns those that were in it."""
        wanted = set(device_ids)
        known = self.devices()
        kept = [device for device in known if device.device_id not in wanted]
        removed = [device.device_id for device in known if device.device_id in wanted]
        if removed:
            self._write(kept)
        return removed

    def _write(self, devices: list[PairedDevice]) -> None:
        document = {"format": PAIRINGS_FORMAT, "format_version": PAIRINGS_FORMAT_VERSION,
                    "devices": [{"device_id": d.device_id, "label": d.label, "paired_utc": d.paired_utc}
                                for d in devices]}
        self.path.parent.mkdir(parents=True, exist_ok=True)
        temporary = self.path.with_name(f".{self.path.name}.{os.getpid()}.part")
        temporary.write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")
        os.replace(temporary, self.path)


def _devices_from_json(data: Any, origin: str) -> list[PairedDevice]:
    if not isinstance(data, dict) or data.get("format") != PAIRINGS_FORMAT:
        raise PairingFileError(f"{origin}: not a MimuCap pairings file")
    version = data.get("format_version")
    if not isinstance(version, int) or version < 1:
        raise PairingFileError(f"{origin}: missing or invalid format_version")
    if version > PAIRINGS_FORMAT_VERSION:
        raise PairingFileError(f"{origin}: pairings format version {version} is newer than this MimuCap reads "
                               f"({PAIRINGS_FORMAT_VERSION}); update MimuCap")
    entries = data.get("devices")
    if not isinstance(entries, list):
        raise PairingFileError(f"{origin}: 'devices' must be a list")
    devices = []
    for index, entry in enumerate(entries):
        where = f"{origin}: device {index + 1}"
        if not isinstance(entry, dict):
            raise PairingFileError(f"{where}: expected an object with a device_id")
        try:
            device_id = check_device_id(entry.get("device_id"), where)
        except ValueError as error:
            raise PairingFileError(str(error)) from None
        devices.append(PairedDevice(device_id, str(entry.get("label") or ""), str(entry.get("paired_utc") or "")))
    return devices
