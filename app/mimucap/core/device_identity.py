"""Which physical device a sensor is: the identity a calibration belongs to.

A *sensor id* (``S01``, ``3``, ``A1B2C3D4E5F6-0``) is a label: the session's name for a sensor,
set on a node's console, by a wire id or by a suit's numbering. Two suits numbered alike carry
the same labels, and a node re-flashed with another id carries another one. A magnetometer
calibration describes one piece of hardware (its hard and soft iron), so it is stored and
applied by the *device id*: a stable key a source reads from the hardware, ``scheme:value``.

=========  ========================================  ================================================
scheme     value                                     where it comes from
=========  ========================================  ================================================
``mac``    ``A1B2C3D4E5F6``                          a MimuCap node's factory MAC (EUI-48), in its
                                                     hello (UDP protocol, serial line)
``mac``    ``A1B2C3D4E5F6/1``                        sensor 1 of a SlimeVR tracker, its MAC from the
                                                     tracker's handshake
``xsens``  ``00B41234``                              an Xsens device id (MT Manager exports, MVNX)
``sim``    ``5f3a09c2/S01``                          unit S01 of a simulated suit; ``5f3a09c2`` is the
                                                     suit (:func:`mimucap.core.simulate.suit_fingerprint`:
                                                     its seed and error model, which draw its units)
=========  ========================================  ================================================

The same key serves every transport: a node heard over UDP or over its USB serial line is one
device. :class:`SensorDevice` is what a source says about one sensor: its device id, why it has
none (an older node that sends no hello, a recording made before devices were recorded), or
nothing yet (the source may still tell: a node's hello has not arrived).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

SCHEMES = ("mac", "xsens", "sim")
_DEVICE_ID = re.compile(r"^(mac|xsens|sim):[A-Za-z0-9][A-Za-z0-9_.\-/]{0,79}$")
_MAC = re.compile(r"^[0-9A-F]{12}$")


def check_device_id(text: Any, origin: str = "device id") -> str:
    """``text`` if it is a device id (``scheme:value``, see the module docstring), else a
    ``ValueError`` naming ``origin``."""
    if not isinstance(text, str) or not _DEVICE_ID.match(text) or ".." in text:
        raise ValueError(f"{origin}: {text!r} is not a device id (expected one of "
                         f"{', '.join(s + ':…' for s in SCHEMES)})")
    return text


def mac_text(mac: bytes) -> str:
    """The 12 upper-case hex digits of a 6-byte MAC; ``ValueError`` for another length or a MAC
    that identifies nothing (all zeros, all ones: a board that could not read its own)."""
    mac = bytes(mac)
    if len(mac) != 6:
        raise ValueError(f"a MAC has 6 bytes, got {len(mac)}")
    if mac in (bytes(6), b"\xff" * 6):
        raise ValueError(f"MAC {mac.hex().upper()} identifies no device")
    return mac.hex().upper()


def mac_device_id(mac: bytes | str, sensor: int | None = None) -> str:
    """The device id of the node with MAC ``mac`` (6 bytes, or 12 hex digits), or of its
    ``sensor``-th sensor when one device carries several (a SlimeVR tracker)."""
    text = mac_text(bytes.fromhex(mac) if isinstance(mac, str) else mac)
    return f"mac:{text}" if sensor is None else f"mac:{text}/{int(sensor)}"


def xsens_device_id(device: str) -> str:
    """The device id of the Xsens device ``device`` (as MT Manager and MVN print it)."""
    return check_device_id(f"xsens:{str(device).strip().upper()}", "Xsens device id")


def simulated_device_id(suit: str, sensor_id: str) -> str:
    """The device id of unit ``sensor_id`` of the simulated suit ``suit`` (its fingerprint)."""
    return check_device_id(f"sim:{suit}/{sensor_id}", "simulated unit")


def describe_device(device_id: str) -> str:
    """A device id in words: ``"MAC A1:B2:C3:D4:E5:F6"``, ``"sensor 1 of MAC …"``,
    ``"Xsens 00B41234"``, ``"simulated unit S01 of suit 5f3a09c2"``."""
    scheme, _, value = device_id.partition(":")
    if scheme == "mac":
        mac, _, sensor = value.partition("/")
        pretty = ":".join(mac[i:i + 2] for i in range(0, len(mac), 2)) if _MAC.match(mac) else mac
        return f"sensor {sensor} of MAC {pretty}" if sensor else f"MAC {pretty}"
    if scheme == "xsens":
        return f"Xsens {value}"
    if scheme == "sim":
        suit, _, unit = value.partition("/")
        return f"simulated unit {unit} of suit {suit}"
    return device_id


@dataclass(frozen=True)
class SensorDevice:
    """What a source says about the device behind one sensor.

    ``device_id``: its device id (:func:`check_device_id`), or ``None``; ``missing``: why it has
    none ("" while the source may still tell, e.g. before a node's hello arrived).
    """

    device_id: str | None = None
    missing: str = ""

    def __post_init__(self) -> None:
        if self.device_id is not None:
            check_device_id(self.device_id)

    @property
    def known(self) -> bool:
        return self.device_id is not None

    @property
    def settled(self) -> bool:
        """Whether the source has said what it will say (the device id, or why there is none)."""
        return self.device_id is not None or bool(self.missing)

    def describe(self) -> str:
        """The device in words, or why it is not known."""
        if self.device_id is not None:
            return describe_device(self.device_id)
        return self.missing or "not identified yet"

    def to_json(self) -> dict[str, Any]:
        return {"device_id": self.device_id, "missing": self.missing} if self.missing else {"device_id": self.device_id}

    @classmethod
    def from_json(cls, data: Any, origin: str) -> SensorDevice:
        """The value :meth:`to_json` wrote (a bare device id string is accepted too);
        ``ValueError`` naming ``origin`` otherwise."""
        if isinstance(data, str):
            return cls(check_device_id(data, origin))
        if not isinstance(data, Mapping):
            raise ValueError(f"{origin}: expected an object with a device_id, got {data!r}")
        device_id = data.get("device_id")
        missing = data.get("missing") or ""
        if not isinstance(missing, str):
            raise ValueError(f"{origin}: 'missing' must be a text, got {missing!r}")
        return cls(None if device_id is None else check_device_id(device_id, origin), missing)


def devices_to_json(devices: Mapping[str, SensorDevice]) -> dict[str, dict[str, Any]]:
    """Sensor id → :meth:`SensorDevice.to_json`, for the settled ones (a recording's ``devices``)."""
    return {sensor: device.to_json() for sensor, device in devices.items() if device.settled}


def devices_from_json(data: Any, origin: str) -> dict[str, SensorDevice]:
    """The mapping :func:`devices_to_json` wrote (``{}`` for ``None``); ``ValueError`` naming
    ``origin`` and the sensor when an entry is malformed."""
    if data is None:
        return {}
    if not isinstance(data, Mapping):
        raise ValueError(f"{origin}: expected sensor id → device, got {type(data).__name__}")
    return {str(sensor): SensorDevice.from_json(value, f"{origin} of sensor {sensor}") for sensor, value in data.items()}
