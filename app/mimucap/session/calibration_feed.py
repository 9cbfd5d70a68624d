"""Sample feeds for the calibration procedures (no Qt).

A calibration procedure pulls blocks of samples from a *feed* and, when the source is
simulated, tells the simulated subject what the current wizard page asks for. A feed has:

* ``sensor_ids`` (tuple of str), ``simulated`` (bool), ``time_s`` (s, time of the newest
  sample delivered; for a simulator this is simulated user time);
* ``read() -> dict[str, FeedSamples]``: the samples that arrived since the last call;
* ``request_activity(name, **params)``: ask the simulated subject to do ``name`` (the
  activities of :meth:`mimucap.core.simulate.SuitSimulator.set_activity`); a feed of real
  sensors ignores it (the wizard page tells the person instead).

:class:`SimulatorFeed` drives a :class:`~mimucap.core.simulate.SuitSimulator` by a fixed
step of simulated time per ``read()`` (tests run faster than real time) or by a clock. When
the simulated units send no on-board orientation, it runs the online orientation filter
(:class:`mimucap.core.fusion.OrientationEKF`) per sensor, with the magnetometer calibrations
given by :meth:`SimulatorFeed.set_magnetometer_calibration` applied first.

Frames and units: samples are in each sensor's frame; ``acc`` m/s² (specific force), ``gyr``
rad/s, ``mag_uT`` µT, ``q_world_from_sensor`` (N, 4) scalar-first, world ENU.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from mimucap.core.fusion import OrientationEKF
from mimucap.core.magcal import MagCalibration
from mimucap.core.simulate import SuitSimulator


@dataclass(frozen=True)
class FeedSamples:
    """One sensor's new samples: ``t_s`` (N,) s, ``acc`` (N, 3) m/s², ``gyr`` (N, 3) rad/s,
    ``mag_uT`` (N, 3) µT, ``q_world_from_sensor`` (N, 4) or None (no orientation yet)."""

    t_s: np.ndarray
    acc: np.ndarray
    gyr: np.ndarray
    mag_uT: np.ndarray
    q_world_from_sensor: np.ndarray | None


class CalibrationFeed(Protocol):
    """What a calibration procedure needs from a source (see the module docstring)."""

    sensor_ids: tuple[str, ...]
    simulated: bool

    @property
    def time_s(self) -> float: ...

    def read(self) -> dict[str, FeedSamples]: ...

    def request_activity(self, name: str, **params: Any) -> None: ...


class SimulatorFeed:
    """A :class:`SuitSimulator` as a calibration feed.

    ``step_s``: simulated seconds per :meth:`read` (default 0.1 s). ``clock``: if given (a
    monotonic clock in s), each read advances by the clock's elapsed time times
    ``time_scale`` instead (at most ``max_step_s``). ``fuse``: run the online orientation
    filter when the units send no orientation (default True).
    """

    simulated = True

    def __init__(
        self,
        simulator: SuitSimulator,
        step_s: float = 0.1,
        clock: Callable[[], float] | None = None,
        time_scale: float = 1.0,
        max_step_s: float = 0.25,
        fuse: bool = True,
    ) -> None:
        if not (math.isfinite(step_s) and step_s > 0):
            raise ValueError(f"feed step must be a positive number of seconds, got {step_s}")
        if not (math.isfinite(time_scale) and time_scale > 0):
            raise ValueError(f"time scale must be positive, got {time_scale}")
        self.simulator = simulator
        self.sensor_ids = tuple(simulator.sensor_ids)
        self.step_s = float(step_s)
        self.clock = clock
        self.time_scale = float(time_scale)
        self.max_step_s = float(max_step_s)
        self.fuse = bool(fuse)
        self._last_wall: float | None = None
        self._filters: dict[str, OrientationEKF] = {}
        self._time_s = simulator.time_s
        self.mag_calibrations: dict[str, MagCalibration] = {}

    def set_magnetometer_calibration(self, calibration: MagCalibration) -> None:
        """Correct this sensor's magnetometer before fusing its orientation (the delivered
        ``mag_uT`` stays raw: a new magnetometer calibration needs raw samples)."""
        if calibration.sensor_id not in self.sensor_ids:
            raise ValueError(f"sensor {calibration.sensor_id} is not in this suit")
        self.mag_calibrations[calibration.sensor_id] = calibration

    @property
    def time_s(self) -> float:
        """Simulated time (s) up to which samples have been delivered."""
        return self._time_s

    def request_activity(self, name: str, **params: Any) -> None:
        """Make the simulated subject do ``name`` from now on (see ``SuitSimulator.set_activity``)."""
        self.simulator.set_activity(name, **params)

    def _duration(self) -> float:
        if self.clock is None:
            return self.step_s
        now = self.clock()
        if self._last_wall is None:
            self._last_wall = now
            return 0.0
        elapsed = min(max(now - self._last_wall, 0.0), self.max_step_s)
        self._last_wall = now
        return elapsed * self.time_scale

    def read(self) -> dict[str, FeedSamples]:
        """Advance the simulation and return each sensor's new samples."""
        block = self.simulator.advance(self._duration())
        self._time_s = self.simulator.time_s
        result = {}
        for sensor_id, samples in block.samples.items():
            q = samples.q_world_from_sensor
            if q is None and self.fuse and samples.t_s.shape[0] > 0:
                ekf = self._filters.get(sensor_id)
                if ekf is None:
                    ekf = self._filters[sensor_id] = OrientationEKF()
                mag = samples.mag_uT
                calibration = self.mag_calibrations.get(sensor_id)
                if calibration is not None:
                    mag = calibration.apply(mag, sensor_id)
                q = ekf.update_batch(samples.t_s, samples.gyr, samples.acc, mag).q_world_from_sensor
            result[sensor_id] = FeedSamples(samples.t_s, samples.acc, samples.gyr, samples.mag_uT, q)
        return result


def feed_for_live_session(live_session: Any, time_scale: float = 1.0) -> SimulatorFeed:
    """The calibration feed of the main window's live pipeline.

    The pipeline of this version runs an in-process simulator (``live_session.simulator``):
    the feed advances that simulator by the wall clock, so the wizard's simulated subject
    performs what the pages ask. Raises ``ValueError`` for a pipeline without a source the
    wizards can read.
    """
    simulator = getattr(live_session, "simulator", None)
    if not isinstance(simulator, SuitSimulator):
        raise ValueError("the live session has no sensor source the calibration wizards can read")
    return SimulatorFeed(simulator, clock=time.monotonic, time_scale=time_scale)
