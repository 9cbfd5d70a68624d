"""Named, counted reasons for refusing a packet, a line or a sample.

Every parser and driver of the acquisition layer is *total*: any input either becomes a
sample or is refused with one of the reasons below, and the refusal is counted. Nothing is
dropped silently, so the supervisor can tell a user *why* data is missing
(e.g. ``bad_checksum: 12, unknown_sensor: 340``).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping
from enum import Enum


class Rejection(str, Enum):
    """Why an input was refused. The value is the stable name used in reports and files."""

    TOO_SHORT = "too_short"                #: fewer bytes than the smallest valid packet
    OVERSIZED = "oversized"                #: a packet or line longer than the protocol allows
    BAD_MAGIC = "bad_magic"                #: the packet does not start with the protocol magic
    UNSUPPORTED_VERSION = "unsupported_version"
    UNKNOWN_TYPE = "unknown_type"          #: a message type this host does not know
    UNKNOWN_FLAGS = "unknown_flags"        #: payload flags with reserved bits set
    LENGTH_MISMATCH = "length_mismatch"    #: payload length disagrees with the flags
    BAD_CHECKSUM = "bad_checksum"          #: CRC32 (UDP) or XOR checksum (serial) mismatch
    MALFORMED_LINE = "malformed_line"      #: not ``$MIMU,...*HH`` or not ASCII
    BAD_FIELD = "bad_field"                #: a field that is not a number or a known tag
    NON_FINITE = "non_finite"              #: NaN or infinity in a measurement
    OUT_OF_RANGE = "out_of_range"          #: a value outside the physical limits
    UNKNOWN_SENSOR = "unknown_sensor"      #: a sensor id that is not part of the session
    UNKNOWN_ADDRESS = "unknown_address"    #: a UDP sender that is not part of the session
    UNPAIRED_DEVICE = "unpaired_device"    #: a device not paired with the suit, or not identified yet
    STALE_SEQUENCE = "stale_sequence"      #: duplicate or older sequence number
    UNEXPECTED_MESSAGE = "unexpected_message"  #: a valid message the host does not expect here
    QUEUE_OVERFLOW = "queue_overflow"      #: the pipeline was full; the sample was discarded
    UNDECODABLE = "undecodable"            #: the decoder itself failed on this input


class RejectionCounter:
    """Counts of refused inputs by :class:`Rejection` reason (plain dict semantics)."""

    def __init__(self, counts: Mapping[str, int] | None = None) -> None:
        self._counts: Counter[str] = Counter()
        if counts:
            self.update(counts)

    def add(self, reason: Rejection | str, count: int = 1) -> None:
        """Count ``count`` refusals for ``reason``."""
        self._counts[Rejection(reason).value] += int(count)

    def update(self, counts: Mapping[str, int] | Iterable[tuple[str, int]]) -> None:
        """Add counts from another counter's :meth:`as_dict` (or pairs)."""
        items = counts.items() if isinstance(counts, Mapping) else counts
        for reason, count in items:
            self.add(reason, count)

    def total(self) -> int:
        """Number of refusals of every reason."""
        return sum(self._counts.values())

    def as_dict(self) -> dict[str, int]:
        """``{reason name: count}``, only reasons that occurred, sorted by name."""
        return {name: self._counts[name] for name in sorted(self._counts) if self._counts[name]}

    def take(self) -> dict[str, int]:
        """Return :meth:`as_dict` and reset the counts (for incremental reports)."""
        counts = self.as_dict()
        self._counts.clear()
        return counts

    def __getitem__(self, reason: Rejection | str) -> int:
        return self._counts[Rejection(reason).value]

    def __repr__(self) -> str:
        return f"RejectionCounter({self.as_dict()})"
