"""Reading a UDP socket's datagrams: bounded, non-blocking, each stamped when read."""

from __future__ import annotations

import socket
import time

import pytest

from mimucap.acquisition.datagram_socket import drain, open_datagram_socket


@pytest.fixture
def receiver():
    sock = open_datagram_socket("127.0.0.1", 0, 1 << 20, "test")
    yield sock
    sock.close()


def send(sock: socket.socket, payloads) -> None:
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    for payload in payloads:
        sender.sendto(payload, sock.getsockname())
    sender.close()
    time.sleep(0.05)  # loopback delivery


def test_drain_reads_what_is_pending_up_to_its_bound(receiver):
    assert list(drain(receiver, 64, 0.0)) == []  # nothing pending: returns at once
    send(receiver, [bytes([k]) * (k + 1) for k in range(10)] + [b"x" * 100])
    before = time.monotonic()
    first = list(drain(receiver, 64, 1.0, limit=4))
    assert [data for data, _, _ in first] == [bytes([k]) * (k + 1) for k in range(4)]
    assert all(address[0] == "127.0.0.1" for _, address, _ in first)
    stamps = [t for _, _, t in first]
    assert before <= stamps[0] <= stamps[-1] <= time.monotonic() and stamps == sorted(stamps)
    rest = list(drain(receiver, 64, 1.0))
    assert [len(data) for data, _, _ in rest] == [5, 6, 7, 8, 9, 10, 64]  # the oversized one cut at the bound
    assert list(drain(receiver, 64, 0.01)) == []


def test_a_port_in_use_is_refused_with_the_source_named(receiver):
    port = receiver.getsockname()[1]
    with pytest.raises(OSError, match=rf"udp9:127.0.0.1:{port}: cannot listen"):
        open_datagram_socket("127.0.0.1", port, 1 << 20, "udp9")
