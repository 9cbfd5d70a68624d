"""Real loopback UDP: emulated nodes → worker process → supervisor.

Checks sample counts, drops from injected loss, the recovered clock offset and drift, and
that packets from outside the session are counted and ignored.
"""

from __future__ import annotations

import socket
import threading
import time

import numpy as np
import pytest

from mimucap.acquisition import protocol_udp
from mimucap.acquisition.emulate_common import EmulatorSettings
from mimucap.acquisition.emulate_udp import UdpEmulator
from mimucap.acquisition.intake import IntakeSettings
from mimucap.acquisition.supervisor import Supervisor
from mimucap.acquisition.udp import UdpSourceConfig
from mimucap.acquisition.wire_sample import Sample


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def wait_for(condition, supervisor, timeout_s=15.0):
    deadline = time.monotonic() + timeout_s
    blocks = []
    while time.monotonic() < deadline:
        blocks.extend(supervisor.poll(0.05))
        if condition():
            return blocks
    raise AssertionError("condition not reached in time")


def run_emulator(settings, port, motion):
    emulator = UdpEmulator(settings, ("127.0.0.1", port), motion)
    thread = threading.Thread(target=emulator.run, daemon=True)
    thread.start()
    return emulator, thread


def test_nodes_recorded_with_counts_drops_and_clock_recovered(synthetic_motion):
    n, rate, duration = 4, 100.0, 4.0
    settings = EmulatorSettings(n_sensors=n, rate_hz=rate, loss=0.1, drift_ppm=300.0,
                                offset_ms=-1234.5, duration_s=duration, seed=3, corrupt=0.02)
    port = free_udp_port()
    config = UdpSourceConfig(name="udp", port=port, sync_interval_s=0.1,
                             intake=IntakeSettings(sensor_ids=tuple(settings.sensor_ids())))
    with Supervisor([config]) as supervisor:
        wait_for(lambda: supervisor.sources()["udp"].state == "running", supervisor)
        emulator, thread = run_emulator(settings, port, synthetic_motion(n, rate))
        blocks = wait_for(lambda: not thread.is_alive(), supervisor)

        def accounted() -> bool:   # reports are cumulative and come every 0.5 s: wait for the last
            received = sum(s.received for s in supervisor.stats().values())
            rejected = sum(supervisor.sources()["udp"].rejections.values())
            return received + rejected == emulator.schedule.sent

        blocks += wait_for(accounted, supervisor)
        stats = supervisor.stats()
        status = supervisor.sources()["udp"]
    schedule = emulator.schedule
    assert schedule.ticks == int(duration * rate)
    assert sorted(stats) == ["1", "2", "3", "4"]
    received = sum(s.received for s in stats.values())
    damaged = emulator.corrupt.corrupted
    assert schedule.sent == n * schedule.ticks - schedule.lost and damaged > 0
    assert received == schedule.sent - damaged
    # every damaged datagram is caught: by its CRC, or earlier by its magic or version byte
    assert sum(status.rejections.values()) == damaged
    assert set(status.rejections) <= {"bad_checksum", "bad_magic", "unsupported_version"}
    drops = sum(s.drops for s in stats.values())
    lost = schedule.lost + damaged
    assert lost - 2 * n <= drops <= lost                  # losses at the very ends are invisible
    assert 0.07 < drops / (received + drops) < 0.17
    # clock: mapped sample times equal the nominal sample instants on the host clock
    for sensor_id, estimate in status.clocks.items():
        now = time.monotonic()
        true_device = now * (1 + 300e-6) - 1.2345
        assert abs(float(estimate.device_from_host(now)) - true_device) < 1e-3, sensor_id
        assert estimate.drift_ppm == pytest.approx(300.0, abs=150.0)
    late = [b for b in blocks if b.seq[0] >= schedule.ticks // 2]
    assert late
    for block in late:
        nominal = schedule.start_host_s + block.seq / rate
        assert np.max(np.abs(block.t_s - nominal)) < 1e-3
        assert block.channels() == ("acc", "gyr", "mag_uT", "q_world_from_sensor", "calibration", "battery_pct")
        assert np.all(np.isfinite(block.acc))
        np.testing.assert_allclose(block.acc[:, 2], 9.81, atol=1e-5)


def test_foreign_sensors_addresses_and_garbage_are_counted_and_ignored():
    port = free_udp_port()
    config = UdpSourceConfig(name="udp", port=port, allowed_addresses=("127.0.0.1",),
                             intake=IntakeSettings(sensor_ids=(1,)))
    with Supervisor([config]) as supervisor:
        wait_for(lambda: supervisor.sources()["udp"].state == "running", supervisor)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
            for seq in range(50):
                t = time.monotonic()
                for sensor_id in (1, 9):
                    sample = Sample(sensor_id=sensor_id, seq=seq, device_time_s=t, gyr=(0.0, 0.0, 1.0))
                    sender.sendto(protocol_udp.encode_sample(sample), ("127.0.0.1", port))
                sender.sendto(b"\x00" * 40, ("127.0.0.1", port))
                sender.sendto(b"\xff" * 2000, ("127.0.0.1", port))
                time.sleep(0.002)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as stranger:
            stranger.bind(("127.0.0.2", 0))   # loopback, but not an allowed address
            sample = Sample(sensor_id=1, seq=1000, device_time_s=time.monotonic(), gyr=(0.0, 0.0, 1.0))
            for _ in range(5):
                stranger.sendto(protocol_udp.encode_sample(sample), ("127.0.0.1", port))
        wait_for(lambda: supervisor.sources()["udp"].rejections.get("oversized", 0) == 50
                 and supervisor.sources()["udp"].rejections.get("unknown_address", 0) == 5
                 and supervisor.stats().get("1") is not None
                 and supervisor.stats()["1"].received == 50, supervisor)
        status = supervisor.sources()["udp"]
        assert sorted(supervisor.stats()) == ["1"]
        assert status.rejections["unknown_sensor"] == 50
        assert status.rejections["bad_magic"] == 50
        assert status.unknown_sensors == {"id 9": 50, "address 127.0.0.2": 5}
        assert status.rejections["unknown_address"] == 5


def test_jitter_that_reorders_packets_is_counted_not_silent(synthetic_motion):
    n, rate = 2, 100.0
    settings = EmulatorSettings(n_sensors=n, rate_hz=rate, jitter_ms=25.0, duration_s=2.0, seed=5)
    port = free_udp_port()
    config = UdpSourceConfig(name="udp", port=port, intake=IntakeSettings(sensor_ids=(1, 2)))
    with Supervisor([config]) as supervisor:
        wait_for(lambda: supervisor.sources()["udp"].state == "running", supervisor)
        emulator, thread = run_emulator(settings, port, synthetic_motion(n, rate))
        wait_for(lambda: not thread.is_alive(), supervisor)
        # every packet is delivered or counted (reports come every 0.5 s: wait for the last one)
        wait_for(lambda: sum(s.received for s in supervisor.stats().values())
                 + supervisor.sources()["udp"].rejections.get("stale_sequence", 0) == emulator.schedule.sent,
                 supervisor)
        stats = supervisor.stats()
        status = supervisor.sources()["udp"]
    received = sum(s.received for s in stats.values())
    stale = status.rejections.get("stale_sequence", 0)
    assert stale > 0                                     # 25 ms jitter at 10 ms spacing reorders
    assert received + stale == emulator.schedule.sent    # every packet is delivered or counted
    assert all(s.received + s.drops <= int(rate * 2.0) for s in stats.values())  # no sample invented


def test_a_node_sending_nan_shows_rejections_not_drops():
    """Through a real socket and worker process: samples of a known node with NaN or
    out-of-range values are rejections of that node with their reason, and the sequence
    numbers they leave free are not counted as dropped packets, not even until the next
    report; a real loss still is."""
    port = free_udp_port()
    config = UdpSourceConfig(name="udp", port=port, intake=IntakeSettings(sensor_ids=(1,)))
    nan_seqs, huge_seqs, lost_seqs = {7, 8, 30}, {41}, {55}
    seen_drops = []

    def drops_now(supervisor) -> int:
        stats = supervisor.stats().get("1")
        return 0 if stats is None else stats.drops
    with Supervisor([config]) as supervisor:
        wait_for(lambda: supervisor.sources()["udp"].state == "running", supervisor)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
            for seq in range(80):
                gyr = (float("nan") if seq in nan_seqs else 500.0 if seq in huge_seqs else 0.0, 0.0, 1.0)
                sample = Sample(sensor_id=1, seq=seq, device_time_s=time.monotonic(), gyr=gyr)
                if seq not in lost_seqs:
                    sender.sendto(protocol_udp.encode_sample(sample), ("127.0.0.1", port))
                time.sleep(0.002)
                supervisor.poll(0.0)
                seen_drops.append(drops_now(supervisor))
        wait_for(lambda: seen_drops.append(drops_now(supervisor)) or (
                 supervisor.stats().get("1") is not None
                 and supervisor.stats()["1"].received == 75
                 and sum(supervisor.sources()["udp"].rejections.values()) == 4
                 and supervisor.stats()["1"].drops == 1), supervisor)
        stats = supervisor.stats()["1"]
        status = supervisor.sources()["udp"]
    assert status.rejections == {"non_finite": 3, "out_of_range": 1}
    assert stats.rejections == {"non_finite": 3, "out_of_range": 1}
    assert stats.drops == 1
    assert max(seen_drops) == 1      # never more for a moment (the counts travel with the blocks)
