"""A bound UDP socket and the reading of its datagrams, shared by the drivers that receive
datagrams (:mod:`mimucap.acquisition.udp`, :mod:`mimucap.acquisition.slimevr`).

:func:`drain` waits for the socket to become readable, then reads every datagram pending
without blocking, up to a bound so that the caller's timers (time sync, heartbeats, flushing)
get their turn in a long burst. Each datagram is stamped with the host's monotonic clock (s)
when it is read. When to flush the samples is each driver's own rule.
"""

from __future__ import annotations

import select
import socket
import time
from collections.abc import Iterator

#: Datagrams read per wake-up before timers and flushing get their turn.
MAX_DRAIN = 512


def open_datagram_socket(bind_address: str, port: int, receive_buffer_bytes: int, name: str) -> socket.socket:
    """A non-blocking UDP socket bound to ``bind_address``:``port`` (IPv6 when the address
    has a colon) with a kernel receive buffer of ``receive_buffer_bytes``; ``OSError`` naming
    the source ``name`` and the address when it cannot be bound."""
    family = socket.AF_INET6 if ":" in bind_address else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_DGRAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, receive_buffer_bytes)
        sock.bind((bind_address, port))
    except OSError as error:
        sock.close()
        raise OSError(f"{name}:{bind_address}:{port}: cannot listen ({error.strerror or error})") from None
    sock.setblocking(False)
    return sock


def drain(sock: socket.socket, max_bytes: int, timeout_s: float,
          limit: int = MAX_DRAIN) -> Iterator[tuple[bytes, tuple, float]]:
    """``(data, address, received_s)`` of the datagrams of the non-blocking ``sock``: waits up
    to ``timeout_s`` (s) for the first, then yields those pending, at most ``limit``.

    A datagram longer than ``max_bytes`` is cut there (read ``max_bytes + 1`` to tell an
    oversized one); ``received_s`` is ``time.monotonic()`` just after it was read. An error
    of one read (on Linux an ICMP "port unreachable" reported after a send to a peer that went
    away) skips that read, not the rest.
    """
    readable, _, _ = select.select([sock], [], [], timeout_s)
    if not readable:
        return
    recvfrom = sock.recvfrom
    clock = time.monotonic
    for _ in range(limit):
        try:
            data, address = recvfrom(max_bytes)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            continue
        yield data, address, clock()
