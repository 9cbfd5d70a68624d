"""Worker processes: one per source, started with the ``spawn`` method.

:func:`run_worker` is the top-level entry point: it receives a frozen, picklable source config,
the supervisor's queue and a stop event, builds the driver for that config and runs it until
the event is set or the source ends. A driver has ``run(stop)`` and ``report(state, message)``
(a cumulative :class:`~mimucap.acquisition.messages.WorkerReport`). Messages out are
:class:`~mimucap.acquisition.messages.BlocksMessage` and
:class:`~mimucap.acquisition.messages.WorkerReport` only. An exception ends the worker with a
``failed`` report naming the error and exit code 1 (the supervisor may restart it).
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.connection
import signal
import sys
import threading
import traceback
from typing import Any

from mimucap.acquisition.messages import STATE_FAILED, STATE_FINISHED, STATE_STOPPED, WorkerReport
from mimucap.acquisition.outbox import Outbox
from mimucap.acquisition.replay import ReplayDriver, ReplaySourceConfig
from mimucap.acquisition.serial_port import SerialDriver, SerialSourceConfig
from mimucap.acquisition.simulated import SimulatedDriver, SimulatedSourceConfig
from mimucap.acquisition.slimevr import SlimeVrDriver, SlimeVrSourceConfig
from mimucap.acquisition.udp import UdpDriver, UdpSourceConfig

#: GIL switch interval in worker processes (s).
WORKER_SWITCH_INTERVAL_S = 0.0005

SourceConfig = (UdpSourceConfig | SerialSourceConfig | SimulatedSourceConfig | ReplaySourceConfig
                | SlimeVrSourceConfig)


def make_driver(config: SourceConfig, outbox: Outbox):
    """The driver object for ``config``."""
    if isinstance(config, UdpSourceConfig):
        return UdpDriver(config, outbox)
    if isinstance(config, SerialSourceConfig):
        return SerialDriver(config, outbox)
    if isinstance(config, SimulatedSourceConfig):
        return SimulatedDriver(config, outbox)
    if isinstance(config, ReplaySourceConfig):
        return ReplayDriver(config, outbox)
    if isinstance(config, SlimeVrSourceConfig):
        return SlimeVrDriver(config, outbox)
    raise TypeError(f"unknown source config {type(config).__name__}")


def _stop_when_parent_dies(parent: Any, stop: Any) -> None:
    multiprocessing.connection.wait([parent.sentinel])
    stop.set()


def _finish(queue: Any) -> None:
    parent = multiprocessing.parent_process()
    if parent is not None and not parent.is_alive():
        queue.cancel_join_thread()  # nobody will read: do not wait for the pipe to drain
    queue.close()
    queue.join_thread()


def run_worker(config: SourceConfig, queue: Any, stop: Any) -> None:
    """Worker process entry point (top-level so that ``spawn`` can import it).

    The worker also stops when its parent process dies (e.g. ``kill -9`` of the recorder),
    so no orphan keeps a port or a device open.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl+C is the supervisor's business
    # the queue's feeder thread must not wait a whole default GIL slice (5 ms) behind a busy
    # receive loop before it can ship a block
    sys.setswitchinterval(WORKER_SWITCH_INTERVAL_S)
    parent = multiprocessing.parent_process()
    if parent is not None:
        threading.Thread(target=_stop_when_parent_dies, args=(parent, stop), daemon=True).start()
    outbox = Outbox(queue, config.name, getattr(config, "report_interval_s", 0.5))
    driver = None
    try:
        driver = make_driver(config, outbox)
        driver.run(stop)
    except Exception as error:  # noqa: BLE001 - reported to the supervisor, then exit 1
        message = f"{type(error).__name__}: {error}"
        traceback.print_exc(file=sys.stderr)
        if driver is not None:
            report = driver.report(STATE_FAILED, message)
        else:
            report = WorkerReport(config.name, STATE_FAILED, message)
        outbox.send_report(report, final=True)
        _finish(queue)
        sys.exit(1)
    final_state = STATE_STOPPED if stop.is_set() else STATE_FINISHED
    outbox.send_report(driver.report(final_state), final=True)
    _finish(queue)
