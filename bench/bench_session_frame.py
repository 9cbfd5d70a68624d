"""Per-call CPU cost of the live session layer (no Qt): what the GUI process pays per timer tick.

Plain script: ``.venv/bin/python bench/bench_session_frame.py [--seconds S] [--warmup S]
[--sensors N ...]`` (``--warmup 45`` for the steady state of the latency statistics).

A :class:`~mimucap.session.live.live_session.LiveSession` on the in-process simulated suit
(``simulated:walk``, 100 Hz; 17 sensors wear the fifteen-segment model, 10 the ten-segment
one) is driven by a fake monotonic clock in 16 ms ticks, as the GUI's frame clock
(``mimucap.gui.main_window.PUMP_INTERVAL_MS``) does, so the figures do not depend on the
machine's load. Each tick runs :meth:`LiveSession.step`; then, as the GUI's timers would:

* every tick (the 3D view draws the new pose at 62.5 frames/s): :meth:`LiveSession.frame`
  (forward kinematics and the figure's matrices);
* every second tick (the plots at ~31 Hz, two poses each): :meth:`LiveSession.joint_series`
  of the first joint, which computes the joint angles of the poses since the last call;
* every 16th tick (the panel at ~4 Hz): :meth:`LiveSession.sensor_rows`.

Two pose sources are measured: the simulator's truth (the default before a body calibration)
and a body calibration with the suit's true mounting (fusion → calibration → segments).
Printed: the mean per-call CPU time of this thread in milliseconds (``time.thread_time``, so
other processes on a busy machine do not count) of each call (``step`` also split into the
simulator's share, ``feed.poll``, and the pipeline's), and its ratio to the target (> 1 is
better than the target).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mimucap.core import skeleton
from mimucap.core.bodycal import BodyCalibration, CalibrationQuality
from mimucap.session.live.live_session import LiveSession, open_live_session

#: The GUI's frame clock (s): one pipeline step and one 3D frame per tick.
TICK_S = 0.016
WARMUP_S = 1.0
#: Per-call targets (ms) that keep the GUI process under half a core.
TARGETS_MS = {"frame": 0.5, "angles": 1.0, "sensor_rows": 1.0}
#: How often the GUI calls each (per second): a step and a frame per tick, the plots' joint
#: angles every second tick, the panel every 16th.
CALLS_PER_S = {"frame": 1 / TICK_S, "angles": 1 / (2 * TICK_S), "step": 1 / TICK_S, "sensor_rows": 1 / (16 * TICK_S)}


def _known_mounting_calibration(session: LiveSession) -> BodyCalibration:
    mounting = session.feed.simulator.mounting
    return BodyCalibration(
        q_world_from_body=skeleton.q_world_from_body_facing(0.0), up_world=np.array([0.0, 0.0, 1.0]),
        sensors={m.segment: sid for sid, m in mounting.items()},
        q_segment_from_sensor={m.segment: m.q_segment_from_sensor for m in mounting.values()},
        quality=CalibrationQuality("known mounting", ()))


class _TimedPoll:
    """Wraps a feed's ``poll`` to sum the time it takes (the simulator's share of ``step``)."""

    def __init__(self, poll) -> None:
        self._poll = poll
        self.total_s = 0.0

    def __call__(self):
        start = time.thread_time()
        try:
            return self._poll()
        finally:
            self.total_s += time.thread_time() - start


def run(n_sensors: int, seconds: float, body_calibration: bool, warmup_s: float = WARMUP_S) -> dict[str, float]:
    now = [1000.0]
    session = open_live_session("simulated:walk", clock=lambda: now[0], n_sensors=n_sensors)
    if body_calibration:
        session.apply_body_calibration(_known_mounting_calibration(session))
    timed_poll = _TimedPoll(session.feed.poll)
    session.feed.poll = timed_poll
    session.start()
    joint = session.joint_names[0]
    totals = {"step": 0.0, "frame": 0.0, "angles": 0.0, "sensor_rows": 0.0}
    counts = dict.fromkeys(totals, 0)
    warmup_ticks = int(round(warmup_s / TICK_S))
    ticks = warmup_ticks + int(round(seconds / TICK_S))
    poll_at_start = 0.0
    for tick in range(ticks):
        measuring = tick >= warmup_ticks
        if tick == warmup_ticks:
            poll_at_start = timed_poll.total_s
        now[0] += TICK_S
        calls = [("step", session.step), ("frame", session.frame)]
        if tick % 2 == 0:
            calls.append(("angles", lambda: session.joint_series(joint, 10.0)))
        if tick % 16 == 0:
            calls.append(("sensor_rows", session.sensor_rows))
        for name, call in calls:
            start = time.thread_time()
            call()
            elapsed = time.thread_time() - start
            if measuring:
                totals[name] += elapsed
                counts[name] += 1
    session.stop()
    result = {name: 1000.0 * totals[name] / max(counts[name], 1) for name in totals}
    poll_ms = 1000.0 * (timed_poll.total_s - poll_at_start) / max(counts["step"], 1)
    result["poll"] = poll_ms
    result["pipeline"] = result["step"] - poll_ms
    result["pose_source"] = session.pose_source
    result["segments"] = len(session.model.segment_names)
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="measured simulated seconds per load")
    parser.add_argument("--sensors", type=int, nargs="+", default=[17, 10], help="suit sizes to measure")
    parser.add_argument("--warmup", type=float, default=WARMUP_S,
                        help="simulated seconds before measuring (45 fills the 4096 latencies per sensor "
                             "that sensor_rows summarises)")
    args = parser.parse_args()
    columns = ("frame", "angles", "step", "poll", "pipeline", "sensor_rows")
    print(f"Live session per-call CPU time (ms, mean over {args.seconds:.0f} s of {1000 * TICK_S:.0f} ms ticks after "
          f"{args.warmup:.0f} s warm-up); ratio = target / measured (> 1 is better); core % = share of one "
          f"core at the GUI's call rates ({', '.join(f'{k} {v:.3g}/s' for k, v in CALLS_PER_S.items())})")
    print(f"{'load':<42}" + "".join(f"{name if name in TARGETS_MS or name == 'step' else f'({name})':>13}"
                                    for name in columns) + f"{'core %':>9}")
    for n in args.sensors:
        for calibrated in (False, True):
            r = run(n, args.seconds, calibrated, args.warmup)
            share = sum(r[k] * rate for k, rate in CALLS_PER_S.items()) / 10.0  # ms per s -> % of a core
            label = f"{n} sensors, {r['segments']} seg, {r['pose_source']}"
            print(f"{label:<42}" + "".join(f"{r[k]:>13.3f}" for k in columns) + f"{share:>9.1f}")
            print(f"{'  ratio to target':<42}" + "".join(
                f"{TARGETS_MS[k] / r[k]:>13.1f}" if k in TARGETS_MS else f"{'':>13}" for k in columns))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
