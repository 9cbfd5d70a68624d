"""Acquisition benchmark: the largest UDP load sustained without drops, and the latency
from an emulated packet's send to the sample's arrival in the pipeline.

    .venv/bin/python bench/bench_acquisition.py [--duration 5] [--loads 10x100,17x200,32x200,...]

For each load (N nodes × rate), emulated nodes driven by the simulated suit run in their own
process (spawn) and send over loopback (127.0.0.1 only) to a UDP worker process; the main
process runs the supervisor as the GUI or recorder would. A load is *sustained* when every
sent sample reached the pipeline (no sequence gaps, no queue overflow, no rejections).
The emulated clocks have no offset and no drift and stamp each packet when it is sent, so the
supervisor's own latency figure (arrival of a block in the main process − the sample's
clock-mapped time) is the send → pipeline latency on the one host monotonic clock.
Column ``net95`` is the p95 of send → worker receive (the rest is worker → main process). The table gives each figure's ratio to the project goal (32 sensors at
200 Hz; p95 < 5 ms). The machine is shared: run it when nothing else is busy.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import socket
import time

import numpy as np

from mimucap.acquisition.emulate_common import EmulatorSettings
from mimucap.acquisition.intake import IntakeSettings
from mimucap.acquisition.supervisor import Supervisor, SupervisorSettings
from mimucap.acquisition.udp import UdpSourceConfig

GOAL_SAMPLES_PER_S = 32 * 200
GOAL_P95_MS = 5.0
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def emulate(n: int, rate: float, duration: float, port: int, results) -> None:
    """Top-level (spawn) emulator process: send, then report how many samples went out.

    Real nodes compute on their own chips: the emulator runs at the lowest CPU priority so
    that it takes from the host only what the acquisition pipeline leaves over.
    """
    os.nice(19)
    from mimucap.acquisition.emulate_motion import SimulatorMotion
    from mimucap.acquisition.emulate_udp import UdpEmulator

    settings = EmulatorSettings(n_sensors=n, rate_hz=rate, duration_s=duration)
    emulator = UdpEmulator(settings, ("127.0.0.1", port), SimulatorMotion(n, rate), stamp_on_send=True)
    schedule = emulator.run()
    results.put((schedule.sent, emulator.send_errors))


def cpu_seconds(pid: int | None) -> float:
    if pid is None:
        return float("nan")
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def run_load(n: int, rate: float, duration: float) -> dict:
    port = free_port()
    config = UdpSourceConfig(name="udp", port=port, intake=IntakeSettings(sensor_ids=tuple(range(1, n + 1))))
    context = multiprocessing.get_context("spawn")
    results = context.Queue()
    network = []
    with Supervisor([config], SupervisorSettings(latency_samples=1_000_000)) as supervisor:
        deadline = time.monotonic() + 20
        while supervisor.sources()["udp"].state != "running" and time.monotonic() < deadline:
            supervisor.poll(0.05)
        emulator = context.Process(target=emulate, args=(n, rate, duration, port, results), daemon=True)
        emulator.start()
        pid = supervisor.worker_pid("udp")
        main_cpu0, worker_cpu0, wall0 = time.process_time(), cpu_seconds(pid), time.monotonic()
        emulator_cpu = 0.0
        last_data = time.monotonic()
        # run until the emulator is done and nothing has arrived for 1 s (stragglers count)
        while emulator.is_alive() or time.monotonic() - last_data < 1.0:
            if emulator.is_alive():
                emulator_cpu = cpu_seconds(emulator.pid)
            now_blocks = supervisor.poll(0.05)
            arrival = time.monotonic()
            if now_blocks:
                last_data = arrival
            if now_blocks:
                network.append(np.concatenate([b.receive_time_s - b.device_time_s for b in now_blocks]))
            if time.monotonic() > wall0 + duration + 30:
                break
        wall = time.monotonic() - wall0
        main_cpu, worker_cpu = time.process_time() - main_cpu0, cpu_seconds(pid) - worker_cpu0
        stats = supervisor.stats()
        status = supervisor.sources()["udp"]
        latencies = [supervisor.latencies_s(sensor) for sensor in stats]
    sent, send_errors = results.get(timeout=10)
    received = sum(s.received for s in stats.values())
    drops = sum(s.drops for s in stats.values())
    lat = np.concatenate(latencies) * 1e3 if latencies else np.array([np.nan])
    net = np.concatenate(network) * 1e3 if network else np.array([np.nan])
    sustained = (received == sent and drops == 0 and status.overflow_samples == 0
                 and not status.rejections and send_errors == 0)
    return {"n": n, "rate": rate, "sent": sent, "received": received, "drops": drops,
            "overflow": status.overflow_samples, "rejections": sum(status.rejections.values()),
            "p50_ms": float(np.percentile(lat, 50)), "p95_ms": float(np.percentile(lat, 95)),
            "max_ms": float(np.max(lat)), "net_p95_ms": float(np.percentile(net, 95)),
            "emulator_cpu": emulator_cpu / duration, "worker_cpu": worker_cpu / wall, "main_cpu": main_cpu / wall,
            "sustained": sustained}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=5.0, help="seconds per load (default 5)")
    parser.add_argument("--loads", default="10x100,17x200,32x200,48x200,64x200,96x200",
                        help="comma-separated NxHZ loads, in increasing order")
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f} (2 cores shared with other work)")
    loads = [(int(a), float(b)) for a, b in (item.split("x") for item in args.loads.split(","))]
    print(f"{'load':>9} {'samples/s':>9} {'sent':>7} {'recv':>7} {'drops':>5} {'ovfl':>4} {'rej':>4} "
          f"{'p50 ms':>7} {'p95 ms':>7} {'max ms':>7} {'net95':>6} {'emu cpu':>7} {'wkr cpu':>7} {'main cpu':>8} "
          f"{'load/goal':>9} {'p95/goal':>8}  sustained")
    best = None
    for n, rate in loads:
        r = run_load(n, rate, args.duration)
        print(f"{n:>4}x{rate:<4g} {n * rate:>9.0f} {r['sent']:>7} {r['received']:>7} {r['drops']:>5} "
              f"{r['overflow']:>4} {r['rejections']:>4} {r['p50_ms']:>7.2f} {r['p95_ms']:>7.2f} "
              f"{r['max_ms']:>7.1f} {r['net_p95_ms']:>6.2f} "
              f"{r['emulator_cpu']:>7.0%} {r['worker_cpu']:>7.0%} {r['main_cpu']:>8.0%} "
              f"{n * rate / GOAL_SAMPLES_PER_S:>9.2f} {r['p95_ms'] / GOAL_P95_MS:>8.2f}  "
              f"{'yes' if r['sustained'] else 'NO'}", flush=True)
        if not r["sustained"]:
            break
        best = (n, rate)
    if best is None:
        print("no load was sustained without drops")
    else:
        print(f"largest load sustained without drops: {best[0]} sensors at {best[1]:g} Hz "
              f"({best[0] * best[1]:.0f} samples/s, {best[0] * best[1] / GOAL_SAMPLES_PER_S:.2f} × the goal)")


if __name__ == "__main__":
    main()
