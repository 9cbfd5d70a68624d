"""Sample feeds for the calibration procedures (no Qt).

A calibration procedure pulls blocks of samples from a *feed* and, when the source is
simulated, tells the simulated subject what the current wizard page asks for. A feed has:

* ``sensor_ids`` (tuple of str), ``simulated`` (bool), ``time_s`` (s, time of the newest
  sample delivered; for a simulator this is simulated user time);
* ``read() -> dict[str, FeedSamples]``: the samples that arrived since the last call;
* ``request_activity(name, **params)``: ask the simulated subject to do ``name`` (the
  activities of :meth:`mimucap.core.simulate.SuitSimulator.set_activity`); a feed of real
  sensors ignores it (the wizard page tells the person instead).

:class:`SimulatedSuitFeed` drives a :class:`~mimucap.core.simulate.SuitSimulator` directly by a
fixed step of simulated time per ``read()`` (tests and time measurements run faster than real
time; ``time_s`` is then simulated user time). When the simulated units send no on-board
orientation, it runs the online orientation filter
(:class:`mimucap.core.fusion.OrientationEKF`) per sensor, with the magnetometer calibrations
given by :meth:`SimulatedSuitFeed.set_magnetometer_calibration` applied first.
:class:`LiveSessionFeed` reads the main window's live session instead (what the wizards use
when the main window opens them).

Frames and units: samples are in each sensor's frame; ``acc`` m/s² (specific force), ``gyr``
rad/s, ``mag_uT`` µT, ``q_world_from_sensor`` (N, 4) scalar-first, world ENU.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from mimucap.core.fusion import OrientationEKF
from mimucap.core.magcal import MagCalibration
from mimucap.core.simulate import SuitSimulator


@dataclass(frozen=True)
class FeedSamples:
    """One sensor's new samples: ``t_s`` (N,) s, ``acc`` (N, 3) m/s², ``gyr`` (N, 3) rad/s,
    ``mag_uT`` (N, 3) µT, ``q_world_from_sensor`` (N, 4); a channel the sensor does not send
    (or an orientation not available) is None, never zero-filled."""

    t_s: np.ndarray
    acc: np.ndarray | None
    gyr: np.ndarray | None
    mag_uT: np.ndarray | None
    q_world_from_sensor: np.ndarray | None


class CalibrationFeed(Protocol):
    """What a calibration procedure needs from a source (see the module docstring)."""

    sensor_ids: tuple[str, ...]
    simulated: bool

    @property
    def time_s(self) -> float: ...

    def read(self) -> dict[str, FeedSamples]: ...

    def request_activity(self, name: str, **params: Any) -> None: ...


class SimulatedSuitFeed:
    """A :class:`SuitSimulator` as a calibration feed.

    ``step_s``: simulated seconds per :meth:`read` (default 0.1 s). ``fuse``: run the online
    orientation filter when the units send no orientation (default True).
    """

    simulated = True

    def __init__(
        self,
        simulator: SuitSimulator,
        step_s: float = 0.1,
        fuse: bool = True,
    ) -> None:
        if not (math.isfinite(step_s) and step_s > 0):
            raise ValueError(f"feed step must be a positive number of seconds, got {step_s}")
        self.simulator = simulator
        self.sensor_ids = tuple(simulator.sensor_ids)
        self.step_s = float(step_s)
        self.fuse = bool(fuse)
        self._filters: dict[str, OrientationEKF] = {}
        self._time_s = simulator.time_s
        self.mag_calibrations: dict[str, MagCalibration] = {}

    def set_magnetometer_calibration(self, calibration: MagCalibration) -> None:
        """Correct this sensor's magnetometer before fusing its orientation (the delivered
        ``mag_uT`` stays raw: a new magnetometer calibration needs raw samples). The sensor's
        filter restarts, as in the live session, so its heading does not converge slowly from
        the one the uncorrected field gave."""
        if calibration.sensor_id not in self.sensor_ids:
            raise ValueError(f"sensor {calibration.sensor_id} is not in this suit")
        self.mag_calibrations[calibration.sensor_id] = calibration
        self._filters.pop(calibration.sensor_id, None)

    @property
    def time_s(self) -> float:
        """Simulated time (s) up to which samples have been delivered."""
        return self._time_s

    def request_activity(self, name: str, **params: Any) -> None:
        """Make the simulated subject do ``name`` from now on (see ``SuitSimulator.set_activity``)."""
        self.simulator.set_activity(name, **params)

    def read(self) -> dict[str, FeedSamples]:
        """Advance the simulation and return each sensor's new samples."""
        block = self.simulator.advance(self.step_s)
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


class LiveSessionFeed:
    """The main window's live session (:class:`mimucap.session.live.LiveSession`) as a feed.

    Subscribes to ``live_session.events.blocks`` (raw blocks, as the session's timer steps
    it) and hands them out per sensor on :meth:`read`. Times are session seconds
    (``host_time_s − live_session.t0_host_s``) times the source's ``time_scale`` (a simulated
    suit may run faster than real time; the gyroscope is integrated over sensor time). Orientations: the device's own when it sends
    them, otherwise an online :class:`~mimucap.core.fusion.OrientationEKF` per sensor on the
    magnetometer samples corrected by ``live_session.mag_calibrations``. Activity requests go
    to ``live_session.simulator`` when the source is the simulated suit. Call :meth:`close`
    when the wizard closes.
    """

    def __init__(self, live_session: Any) -> None:
        self.live_session = live_session
        self.sensor_ids = tuple(live_session.sensor_ids)
        self.simulated = getattr(live_session, "simulator", None) is not None
        self._pending: list[Any] = []
        self._filters: dict[str, OrientationEKF] = {}
        self._calibration_used: dict[str, object] = {}
        self._time_s = math.nan
        live_session.events.blocks.connect(self._on_blocks)

    def _on_blocks(self, blocks: list) -> None:
        self._pending.extend(blocks)

    @property
    def time_s(self) -> float:
        return self._time_s

    def request_activity(self, name: str, **params: Any) -> None:
        simulator = getattr(self.live_session, "simulator", None)
        if simulator is not None:
            simulator.set_activity(name, **params)

    def _orientation(self, sensor_id: str, t: np.ndarray, block: Any) -> np.ndarray | None:
        if block.q_world_from_sensor is not None:
            return block.q_world_from_sensor
        if block.gyr is None or block.acc is None:
            return None
        calibration = self.live_session.mag_calibrations.get(sensor_id)
        if self._calibration_used.get(sensor_id) is not calibration:
            self._filters.pop(sensor_id, None)  # a new magnetometer calibration: restart
            self._calibration_used[sensor_id] = calibration
        mag = block.mag_uT
        if mag is not None and calibration is not None:
            mag = calibration.apply(mag, sensor_id)
        ekf = self._filters.get(sensor_id)
        if ekf is None:
            ekf = self._filters[sensor_id] = OrientationEKF()
        return ekf.update_batch(t, block.gyr, block.acc, mag).q_world_from_sensor

    def read(self) -> dict[str, FeedSamples]:
        """The blocks that arrived since the last call, per sensor (a channel is None when
        any of the sensor's blocks lacks it)."""
        blocks, self._pending = self._pending, []
        t0 = self.live_session.t0_host_s or 0.0
        scale = float(getattr(getattr(self.live_session, "feed", None), "time_scale", 1.0))
        parts: dict[str, list[FeedSamples]] = {}
        for block in blocks:
            if len(block) == 0:
                continue
            t = (np.asarray(block.host_time_s, dtype=np.float64) - t0) * scale
            q = self._orientation(block.sensor_id, t, block)
            parts.setdefault(block.sensor_id, []).append(FeedSamples(t, block.acc, block.gyr, block.mag_uT, q))
            self._time_s = max(float(t[-1]), self._time_s) if math.isfinite(self._time_s) else float(t[-1])

        def joined(items: list[FeedSamples], name: str) -> np.ndarray | None:
            arrays = [getattr(item, name) for item in items]
            return None if any(a is None for a in arrays) else np.concatenate(arrays)

        return {sensor_id: FeedSamples(joined(items, "t_s"), joined(items, "acc"), joined(items, "gyr"),
                                       joined(items, "mag_uT"), joined(items, "q_world_from_sensor"))
                for sensor_id, items in parts.items()}

    def close(self) -> None:
        """Stop listening to the live session."""
        self.live_session.events.blocks.disconnect(self._on_blocks)


def feed_for_live_session(live_session: Any) -> LiveSessionFeed:
    """The calibration feed of the main window's live session (see :class:`LiveSessionFeed`)."""
    return LiveSessionFeed(live_session)
