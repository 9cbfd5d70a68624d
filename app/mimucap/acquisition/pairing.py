"""Which devices a network source lets into a session: the paired suit.

A *suit* is the list of devices (:mod:`mimucap.core.device_identity`) paired with this
installation. A network source (UDP nodes, SlimeVR trackers) hears anything on its port; sensor
ids do not tell a second suit numbered alike from ours, device ids do. When a source is given the
suit (``paired_devices``, a set of device ids), a sample is let in only when its sensor's
device is in it; every other sample is refused as ``unpaired_device`` and counted, and the
sensor is reported as an :class:`UnpairedSensor` (so that the user can be offered to pair it)
instead of among the session's devices: it never reaches the pipeline or a recording.

A sensor whose device is not known yet (a UDP node whose hello has not arrived) is refused until
it is; one that cannot tell its device (a node without the hello, a SlimeVR tracker whose
handshake carries no MAC) cannot be paired and stays refused. ``paired_devices=None`` checks
nothing (the simulated suit, a replayed file, a serial line, and a UDP source whose senders are
named by address: a fixed set-up).
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

from mimucap.core.device_identity import SensorDevice


def admits(paired_devices: Collection[str] | None, device: SensorDevice | None) -> bool:
    """Whether a sensor that is ``device`` (``None``: not told yet) is let in by a source given
    the suit ``paired_devices`` (``None``: every device is)."""
    if paired_devices is None:
        return True
    return device is not None and device.device_id is not None and device.device_id in paired_devices


@dataclass(frozen=True)
class UnpairedSensor:
    """A sensor a source heard and refused because its device is not paired.

    ``sensor``: the name it sends under; ``device``: its device (unsettled while the source
    may still tell it, or why it has none); ``refused``: its samples refused so far.
    """

    sensor: str
    device: SensorDevice
    refused: int

    @property
    def pairable(self) -> bool:
        """Whether it could be paired (its device id is known)."""
        return self.device.device_id is not None

    def describe(self) -> str:
        """The sensor and its device in words (``sensor 3: MAC 02:…``)."""
        return f"sensor {self.sensor}: {self.device.describe()}"
