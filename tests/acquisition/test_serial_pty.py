"""Real pseudo-terminal: an emulated serial receiver read by a worker through pyserial,
unplugged (link removed, pty closed) and plugged back in during the recording."""

from __future__ import annotations

import threading
import time

import numpy as np

from mimucap.acquisition.emulate_common import EmulatorSettings
from mimucap.acquisition.emulate_serial import SerialEmulator
from mimucap.acquisition.intake import IntakeSettings
from mimucap.acquisition.serial_port import SerialSourceConfig
from mimucap.acquisition.supervisor import Supervisor


def poll_until(supervisor, condition, blocks, timeout_s=15.0):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        blocks.extend(supervisor.poll(0.05))
        if condition():
            return
    raise AssertionError(f"condition not reached; sources: {supervisor.sources()}")


def test_serial_unplug_and_replug_are_survived(tmp_path, synthetic_motion):
    n, rate = 3, 100.0
    settings = EmulatorSettings(n_sensors=n, rate_hz=rate, drift_ppm=200.0, offset_ms=5000.0)
    emulator = SerialEmulator(settings, synthetic_motion(n, rate), link=tmp_path / "ttyMIMU0")
    stop = threading.Event()
    thread = threading.Thread(target=emulator.run, args=(stop,), daemon=True)
    config = SerialSourceConfig(name="radio", device=emulator.device_path, baud=115200,
                                reconnect_interval_s=0.1,
                                intake=IntakeSettings(sensor_ids=tuple(settings.sensor_ids())))
    blocks = []
    try:
        thread.start()
        with Supervisor([config]) as supervisor:
            received = lambda: {k: s.received for k, s in supervisor.stats().items()}  # noqa: E731
            poll_until(supervisor, lambda: len(received()) == n and min(received().values()) >= 100, blocks)
            emulator.unplug()
            poll_until(supervisor, lambda: supervisor.sources()["radio"].state == "disconnected", blocks)
            before = received()
            time.sleep(0.5)
            emulator.replug()
            poll_until(supervisor, lambda: supervisor.sources()["radio"].reconnects == 1
                       and all(received()[k] >= before[k] + 100 for k in before), blocks)
            stats = supervisor.stats()
            status = supervisor.sources()["radio"]
    finally:
        stop.set()
        thread.join(5)
        emulator.close()
    assert status.state == "running" and status.reconnects == 1
    # the samples written while unplugged never arrived: they show up as drops, per sensor
    # (plus the few lines still in the pty buffer at the moment of the unplug)
    missing_per_sensor = emulator.unplugged_samples / n
    for s in stats.values():
        assert missing_per_sensor - 2 <= s.drops <= missing_per_sensor + 10
    # one-way clock mapping: sample times land on the nominal instants within a few ms
    schedule = emulator.schedule
    late = [b for b in blocks if b.seq[0] > schedule.ticks - 100]
    assert late
    for block in late:
        nominal = schedule.start_host_s + block.seq / rate
        assert np.max(np.abs(block.t_s - nominal)) < 5e-3
        assert np.all(np.isfinite(block.gyr))
