"""Cost of reading datagrams through the drivers' shared ``drain`` against a bare receive loop.

    .venv/bin/python bench/bench_datagram_drain.py [--datagrams 400] [--rounds 90]

Each round queues ``--datagrams`` datagrams of 120 bytes (a 17-board UDP packet is about that)
on a loopback socket, then reads them all, once with :func:`mimucap.acquisition.datagram_socket.drain`
and once with the loop it replaced written out in place (``select``, then ``recvfrom`` until
the socket is empty, each datagram stamped with ``time.monotonic()``), in alternating order.
Prints the median time per datagram of each and their ratio; the decoding and the samples'
handling that follow in a driver cost far more per datagram and are left out on purpose.
"""

from __future__ import annotations

import argparse
import select
import socket
import statistics
import time

from mimucap.acquisition.datagram_socket import MAX_DRAIN, drain, open_datagram_socket

MAX_BYTES = 1500


def bare_loop(sock: socket.socket, handle) -> None:
    readable, _, _ = select.select([sock], [], [], 0.05)
    if readable:
        for _ in range(MAX_DRAIN):
            try:
                data, address = sock.recvfrom(MAX_BYTES)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                continue
            handle(data, address, time.monotonic())


def drain_loop(sock: socket.socket, handle) -> None:
    for data, address, received in drain(sock, MAX_BYTES, 0.05):
        handle(data, address, received)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--datagrams", type=int, default=400)
    parser.add_argument("--rounds", type=int, default=90)
    args = parser.parse_args()
    receiver = open_datagram_socket("127.0.0.1", 0, 4 << 20, "bench")
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    payload = b"x" * 120
    count = [0]

    def handle(data, address, received_s):
        count[0] += 1

    loops = {"bare loop": bare_loop, "drain": drain_loop}
    per_datagram_us: dict[str, list[float]] = {name: [] for name in loops}
    for index in range(args.rounds):
        order = list(loops.items()) if index % 2 else list(loops.items())[::-1]
        for name, loop in order:
            for _ in range(args.datagrams):
                sender.sendto(payload, receiver.getsockname())
            time.sleep(0.002)
            count[0] = 0
            start = time.perf_counter()
            while count[0] < args.datagrams:
                loop(receiver, handle)
            per_datagram_us[name].append((time.perf_counter() - start) / args.datagrams * 1e6)
    bare = statistics.median(per_datagram_us["bare loop"])
    for name, values in per_datagram_us.items():
        median = statistics.median(values)
        print(f"{name:10s} {median:6.3f} µs per datagram (median of {args.rounds})   {median / bare:.3f}")


if __name__ == "__main__":
    main()
