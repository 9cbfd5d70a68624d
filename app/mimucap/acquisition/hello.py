"""A node's hello: which hardware sends under a wire id.

A MimuCap node names its samples by a 16-bit wire id, set from its MAC or on its console, so two
nodes may send under one id and one node may change its id. Its hello says which device it is:
its factory MAC (EUI-48), from which the device id ``mac:<12 hex digits>`` follows
(:mod:`mimucap.core.device_identity`). Over UDP the host asks for it (a hello request) and the
node answers, and a node also says it when it starts; over the one-way serial line the node
repeats it every :data:`SERIAL_HELLO_PERIOD_S`. Nodes older than the hello send none: after
:data:`HELLO_WAIT_S` without one their sensors are marked as lacking a device id, with
:data:`NO_HELLO` as the reason, and they keep working.
"""

from __future__ import annotations

from dataclasses import dataclass

from mimucap.core.device_identity import mac_device_id

#: Seconds a node's sensor waits for its hello before it is said to have none (UDP asks every
#: 0.2 s; a serial node repeats its hello every second).
HELLO_WAIT_S = 2.5
#: Seconds between two hello lines of a serial node.
SERIAL_HELLO_PERIOD_S = 1.0
#: Why a sensor has no device id when its node sends no hello.
NO_HELLO = "its node sends no hello with a hardware id (firmware older than the hello of protocol v1)"


@dataclass(frozen=True)
class Hello:
    """Node → host: the node sending under wire id ``sensor_id`` has factory MAC ``mac`` (6 bytes)."""

    sensor_id: int
    mac: bytes

    @property
    def device_id(self) -> str:
        return mac_device_id(self.mac)


@dataclass(frozen=True)
class HelloRequest:
    """Host → node (UDP): "say hello" (``target_id`` the node's wire id, or the broadcast id)."""

    target_id: int
