"""Supervisor: a failed worker is restarted, a flood cannot grow memory, losses are reported."""

from __future__ import annotations

import socket
import time
from pathlib import Path

from mimucap.acquisition import protocol_udp
from mimucap.acquisition.intake import IntakeSettings
from mimucap.acquisition.samples import Sample
from mimucap.acquisition.supervisor import Supervisor, SupervisorSettings
from mimucap.acquisition.udp import UdpSourceConfig


def poll_until(supervisor, condition, timeout_s=20.0):
    deadline = time.monotonic() + timeout_s
    blocks = []
    while time.monotonic() < deadline:
        blocks.extend(supervisor.poll(0.05))
        if condition():
            return blocks
    raise AssertionError(f"condition not reached: {supervisor.sources()}")


def test_a_failed_worker_is_restarted_until_it_runs():
    blocker = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    blocker.bind(("127.0.0.1", 0))
    port = blocker.getsockname()[1]
    settings = SupervisorSettings(restart_backoff_s=0.2, max_restarts=20)
    with Supervisor([UdpSourceConfig(name="udp", port=port)], settings) as supervisor:
        poll_until(supervisor, lambda: supervisor.sources()["udp"].restarts >= 1)
        status = supervisor.sources()["udp"]
        assert "Address already in use" in status.message
        blocker.close()                        # the port is free again: the next restart runs
        poll_until(supervisor, lambda: supervisor.sources()["udp"].state == "running")
        assert supervisor.worker_pid("udp") is not None


def test_restarts_stop_at_the_limit_with_the_reason():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as blocker:
        blocker.bind(("127.0.0.1", 0))
        port = blocker.getsockname()[1]
        settings = SupervisorSettings(restart_backoff_s=0.05, max_restarts=2)
        with Supervisor([UdpSourceConfig(name="udp", port=port)], settings) as supervisor:
            poll_until(supervisor, supervisor.all_finished)
            status = supervisor.sources()["udp"]
    assert status.state == "failed" and status.restarts == 2 and "Address already in use" in status.message


def rss_kib(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError("no VmRSS")


def test_a_flood_while_nobody_reads_stays_bounded_and_is_reported():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    config = UdpSourceConfig(name="udp", port=port, intake=IntakeSettings(sensor_ids=(1,), max_block_samples=64))
    with Supervisor([config], SupervisorSettings(queue_max_messages=8)) as supervisor:
        poll_until(supervisor, lambda: supervisor.sources()["udp"].state == "running")
        pid = supervisor.worker_pid("udp")
        baseline = rss_kib(pid)
        sent = 0
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
            # Nobody polls meanwhile. A count, not a duration, makes it a flood on a busy machine too.
            end = time.monotonic() + 60.0
            while sent < 24_000 and time.monotonic() < end:
                for _ in range(200):
                    sample = Sample(sensor_id=1, seq=sent, device_time_s=time.monotonic(), gyr=(0.0, 0.0, 1.0))
                    sender.sendto(protocol_udp.encode_sample(sample), ("127.0.0.1", port))
                    sent += 1
        grown_kib = rss_kib(pid) - baseline
        blocks = poll_until(supervisor, lambda: supervisor.sources()["udp"].overflow_samples > 0)
        blocks += poll_until(supervisor, lambda: True, 0.5)
        stats = supervisor.stats()["1"]
        status = supervisor.sources()["udp"]
    assert sent > 20_000
    assert grown_kib < 32 * 1024                   # bounded: no backlog kept in the worker
    # every sent sample is accounted for: delivered, or a counted gap (overflow or kernel drop)
    last_delivered = max(int(b.seq[-1]) for b in blocks)
    assert stats.received + stats.drops == last_delivered + 1
    assert status.rejections["queue_overflow"] == status.overflow_samples > 0
