"""Source spec strings: the one way to name a data source in the CLI, GUI and session files.

Valid forms (see :data:`VALID_FORMS`)::

    simulated[:SCENARIO][@ROOM]  the simulated suit in real time (default scenario "demo", room
                              "clean"; e.g. simulated:demo@clinic)
    udp:BIND_ADDRESS:PORT     wireless nodes speaking the UDP protocol, e.g. udp:0.0.0.0:5555
    serial:DEVICE[@BAUD]      a serial board or radio receiver, e.g. serial:/dev/ttyUSB0@115200
    replay:FILE[@SPEED]       a session file or Xsens export, SPEED × real time (default 1)
    slimevr[:[BIND_ADDRESS:]PORT]  a SlimeVR server for SlimeVR trackers (default 0.0.0.0:6969)

:func:`parse_source_spec` returns a frozen spec; :func:`format_source_spec` is its inverse.
"""

from __future__ import annotations

import ipaddress
import re
from dataclasses import dataclass

from mimucap.acquisition.slimevr_protocol import DEFAULT_PORT

VALID_FORMS = ("simulated[:SCENARIO][@ROOM]", "udp:BIND_ADDRESS:PORT", "serial:DEVICE[@BAUD]",
               "replay:FILE[@SPEED]", "slimevr[:[BIND_ADDRESS:]PORT]")
DEFAULT_SCENARIO = "demo"
#: The simulated suit's room when the spec names none (the earth field alone).
DEFAULT_ROOM = "clean"
DEFAULT_BAUD = 115200
#: Where SlimeVR trackers look for their server (they broadcast to this port on the LAN).
DEFAULT_SLIMEVR_ADDRESS = "0.0.0.0"
DEFAULT_SLIMEVR_PORT = DEFAULT_PORT
_SCENARIO_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_\-]*$")


@dataclass(frozen=True)
class SimulatedSpec:
    scenario: str = DEFAULT_SCENARIO
    room: str = DEFAULT_ROOM


@dataclass(frozen=True)
class UdpSpec:
    bind_address: str
    port: int


@dataclass(frozen=True)
class SerialSpec:
    device: str
    baud: int = DEFAULT_BAUD


@dataclass(frozen=True)
class ReplaySpec:
    path: str
    speed: float = 1.0


@dataclass(frozen=True)
class SlimeVrSpec:
    bind_address: str = DEFAULT_SLIMEVR_ADDRESS
    port: int = DEFAULT_SLIMEVR_PORT


SourceSpec = SimulatedSpec | UdpSpec | SerialSpec | ReplaySpec | SlimeVrSpec


def _error(spec: str, why: str) -> ValueError:
    return ValueError(f"invalid source {spec!r}: {why}; valid forms: {', '.join(VALID_FORMS)}")


def _bind_address(spec: str, address: str) -> str:
    address = address.strip("[]")
    try:
        ipaddress.ip_address(address)
    except ValueError:
        if address != "localhost":
            raise _error(spec, f"bad bind address {address!r}") from None
    return address


def _port(spec: str, port_text: str) -> int:
    if not port_text.isdigit() or not 0 < int(port_text) < 65536:
        raise _error(spec, f"bad port {port_text!r} (1..65535)")
    return int(port_text)


def parse_source_spec(spec: str) -> SourceSpec:
    """Parse ``spec``; a malformed one raises a one-line ``ValueError`` listing the valid forms."""
    if not isinstance(spec, str) or not spec.strip():
        raise _error(str(spec), "empty")
    kind, _, rest = spec.strip().partition(":")
    text = spec.strip()
    if text == "simulated" or text.startswith(("simulated:", "simulated@")):
        scenario, sep, room = text[len("simulated"):].removeprefix(":").partition("@")
        scenario = scenario or DEFAULT_SCENARIO
        if not _SCENARIO_RE.match(scenario):
            raise _error(spec, f"bad scenario name {scenario!r}")
        if sep and not _SCENARIO_RE.match(room):
            raise _error(spec, f"bad room name {room!r}")
        return SimulatedSpec(scenario, room if sep else DEFAULT_ROOM)
    if kind == "udp":
        address, sep, port_text = rest.rpartition(":")
        if not sep or not address:
            raise _error(spec, "expected udp:BIND_ADDRESS:PORT")
        return UdpSpec(_bind_address(spec, address), _port(spec, port_text))
    if kind == "slimevr":
        if spec.strip() == "slimevr":
            return SlimeVrSpec()
        address, sep, port_text = rest.rpartition(":")
        if sep and not address:
            raise _error(spec, "expected slimevr:[BIND_ADDRESS:]PORT")
        address = _bind_address(spec, address) if sep else DEFAULT_SLIMEVR_ADDRESS
        return SlimeVrSpec(address, _port(spec, port_text))
    if kind == "serial":
        device, sep, baud_text = rest.rpartition("@") if "@" in rest else (rest, "", "")
        if not device:
            raise _error(spec, "missing device")
        if sep and (not baud_text.isdigit() or not 0 < int(baud_text) <= 10_000_000):
            raise _error(spec, f"bad baud rate {baud_text!r}")
        return SerialSpec(device, int(baud_text) if sep else DEFAULT_BAUD)
    if kind == "replay":
        path, sep, speed_text = rest.rpartition("@") if "@" in rest else (rest, "", "")
        if not path:
            raise _error(spec, "missing file")
        speed = 1.0
        if sep:
            try:
                speed = float(speed_text)
            except ValueError:
                raise _error(spec, f"bad speed {speed_text!r}") from None
            if not 0.0 < speed < 1e6:
                raise _error(spec, f"bad speed {speed_text!r} (must be > 0)")
        return ReplaySpec(path, speed)
    raise _error(spec, f"unknown kind {kind!r}")


def format_source_spec(spec: SourceSpec) -> str:
    """The spec string of ``spec`` (``parse_source_spec(format_source_spec(s)) == s``)."""
    if isinstance(spec, SimulatedSpec):
        room = "" if spec.room == DEFAULT_ROOM else f"@{spec.room}"
        return f"simulated:{spec.scenario}{room}"
    if isinstance(spec, UdpSpec):
        address = f"[{spec.bind_address}]" if ":" in spec.bind_address else spec.bind_address
        return f"udp:{address}:{spec.port}"
    if isinstance(spec, SerialSpec):
        return f"serial:{spec.device}@{spec.baud}"
    if isinstance(spec, ReplaySpec):
        return f"replay:{spec.path}@{spec.speed:g}"
    if isinstance(spec, SlimeVrSpec):
        address = f"[{spec.bind_address}]" if ":" in spec.bind_address else spec.bind_address
        return f"slimevr:{address}:{spec.port}"
    raise TypeError(f"not a source spec: {spec!r}")
