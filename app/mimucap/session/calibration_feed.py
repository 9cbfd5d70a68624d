"""Sample feeds for the calibration procedures (no Qt).

A calibration procedure pulls samples from a *feed* and tells the subject what the current page
asks for. A feed has:

* ``sensor_ids`` (tuple of str), ``time_s`` (s, time of the newest sample delivered);
* ``read() -> dict[str, SensorSamples]``: the samples that arrived since the last call
  (:class:`mimucap.core.samples.SensorSamples`, ``t_s`` in session seconds, raw magnetometer),
  with ``q_world_from_sensor`` the orientation the live session's processing path gave them
  and, in ``extra[DOUBT_EXTRA]`` (N,), the reasons it may be wrong (:mod:`mimucap.core.doubt`);
* ``static_orientation(sensor_id, acc, mag_raw_uT)``: ``q_world_from_sensor`` (4,) of a still
  window from its mean specific force and magnetic field, the field corrected as the
  pipeline corrects it (:func:`mimucap.core.bodycal.static_alignment`), or None for a sensor
  whose orientation does not come from the pipeline's filter with a calibrated magnetometer;
* ``magnetometer_calibrations()``: sensor → the magnetometer calibration the pipeline applies
  now (those a body calibration made from these orientations holds with);
* ``device(sensor_id)``: what the source says of the sensor's device
  (:class:`~mimucap.core.device_identity.SensorDevice`): a calibration is made for it;
* ``instruct(instruction)``: what the subject is asked to do
  (:mod:`mimucap.session.instructions`); the source decides who follows it (a person reads the
  screen; the simulated subject does it). No procedure asks which one it is.

:class:`LiveSessionFeed` reads the main window's live session. :class:`SimulatedSuitFeed` is the
same feed on a live session of its own over the simulated suit, stepped by a fixed amount of
simulated time per ``read()`` (tests, benchmarks and screenshots run faster than real time).
Either way the orientations come from the one pipeline; no feed runs a filter of its own.

Frames and units: samples are in each sensor's frame; ``acc`` m/s² (specific force), ``gyr``
rad/s, ``mag_uT`` µT (raw: a new magnetometer calibration needs raw samples),
``q_world_from_sensor`` (N, 4) scalar-first, world ENU.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, Protocol

import numpy as np

from mimucap.core.bodycal import static_alignment
from mimucap.core.device_identity import SensorDevice
from mimucap.core.magcal import MagCalibration
from mimucap.core.samples import SensorSamples, concatenate_samples
from mimucap.core.simulate.suit import SuitSimulator
from mimucap.session.instructions import Instruction

#: The per-sample extra of a calibration feed's samples that holds the reasons their
#: orientation may be wrong (``uint16`` bits of :mod:`mimucap.core.doubt`).
DOUBT_EXTRA = "doubt"


class CalibrationFeed(Protocol):
    """What a calibration procedure needs from a source (see the module docstring)."""

    sensor_ids: tuple[str, ...]

    @property
    def time_s(self) -> float: ...

    def read(self) -> dict[str, SensorSamples]: ...

    def static_orientation(self, sensor_id: str, acc: np.ndarray, mag_raw_uT: np.ndarray) -> np.ndarray | None: ...

    def magnetometer_calibrations(self) -> dict[str, MagCalibration]: ...

    def device(self, sensor_id: str) -> SensorDevice: ...

    def instruct(self, instruction: Instruction) -> None: ...


class LiveSessionFeed:
    """The main window's live session (:class:`mimucap.session.live.LiveSession`) as a feed.

    Subscribes to ``live_session.events.processed`` (each sensor's new samples and the
    orientations the session's pipeline gave them) and hands them out per sensor on
    :meth:`read`. Times are session seconds (a block's host ``t_s`` − ``live_session.t0_host_s``).
    Instructions go to ``live_session.instruct``. Call :meth:`close` when the wizard closes.
    """

    def __init__(self, live_session: Any) -> None:
        self.live_session = live_session
        self.sensor_ids = tuple(live_session.sensor_ids)
        self._pending: list[Any] = []
        self._time_s = math.nan
        live_session.events.processed.connect(self._on_processed)

    def _on_processed(self, items: list) -> None:
        self._pending.extend(items)

    @property
    def time_s(self) -> float:
        return self._time_s

    def instruct(self, instruction: Instruction) -> None:
        self.live_session.instruct(instruction)

    def device(self, sensor_id: str) -> SensorDevice:
        """What the live session's source says of ``sensor_id``'s device."""
        return self.live_session.device_of(sensor_id)

    def static_orientation(self, sensor_id: str, acc: np.ndarray, mag_raw_uT: np.ndarray) -> np.ndarray | None:
        """``q_world_from_sensor`` (4,) of ``sensor_id`` held still over the samples ``acc`` (K, 3)
        m/s² and ``mag_raw_uT`` (K, 3) raw µT, with the magnetometer calibration and declination
        the live session's pipeline uses; None when the sensor has no magnetometer calibration
        (its raw field is not what the filter will settle on) or sends its own orientation.
        ``ValueError`` when the field is vertical or disturbed (its magnitude off the
        calibration's by more than the filter's tolerance)."""
        chain = self.live_session.pipeline.chains.get(sensor_id)
        if chain is None or chain.onboard or chain.mag_calibration is None:
            return None
        fusion = chain.settings.fusion
        return static_alignment(acc, chain.calibrated_mag(np.asarray(mag_raw_uT, dtype=np.float64)),
                                fusion.declination_rad, chain.mag_calibration.field_uT, fusion.mag_norm_tol)

    def magnetometer_calibrations(self) -> dict[str, MagCalibration]:
        """Sensor → the magnetometer calibration the live session's pipeline applies now."""
        return dict(self.live_session.mag_calibrations)

    def read(self) -> dict[str, SensorSamples]:
        """The samples that arrived since the last call, per sensor (a channel is None when
        any of the sensor's blocks lacks it)."""
        items, self._pending = self._pending, []
        parts: dict[str, list[SensorSamples]] = {}
        for item in items:
            if len(item.t_s) == 0:
                continue
            q = None if item.orientation is None else item.orientation.q_world_from_sensor
            extra = item.block.extra
            if item.orientation is not None:
                extra = {**(extra or {}), DOUBT_EXTRA: item.orientation.doubt}
            parts.setdefault(item.sensor_id, []).append(
                replace(item.block, t_s=item.t_s, q_world_from_sensor=q, extra=extra))
            newest = float(item.t_s[-1])
            self._time_s = max(newest, self._time_s) if math.isfinite(self._time_s) else newest
        return {sensor_id: concatenate_samples(samples, missing="drop") for sensor_id, samples in parts.items()}

    def close(self) -> None:
        """Stop listening to the live session."""
        self.live_session.events.processed.disconnect(self._on_processed)


class SteppedClock:
    """A monotonic clock (s) that moves only when told (``clock.now += step``)."""

    def __init__(self, start_s: float = 0.0) -> None:
        self.now = float(start_s)

    def __call__(self) -> float:
        return self.now


class SimulatedSuitFeed(LiveSessionFeed):
    """A live session of its own on the simulated suit (``simulator``), stepped ``step_s``
    simulated seconds per :meth:`read` (default 0.1 s): a calibration feed that runs faster
    than real time, through the same pipeline as the main window's. Its magnetometer
    calibrations live in memory (``live_session.apply_mag_calibration``)."""

    def __init__(self, simulator: SuitSimulator, step_s: float = 0.1) -> None:
        if not (math.isfinite(step_s) and step_s > 0):
            raise ValueError(f"feed step must be a positive number of seconds, got {step_s}")
        from mimucap.session.feeds import SimulatorFeed
        from mimucap.session.live import LiveSession

        self.simulator = simulator
        self.step_s = float(step_s)
        self._clock = SteppedClock()
        source = SimulatorFeed(simulator.config, clock=self._clock, simulator=simulator)
        live = LiveSession(source, "simulated", model_name=simulator.model.name,
                           height_m=simulator.config.height_m, clock=self._clock)
        live.start()
        super().__init__(live)

    def set_magnetometer_calibration(self, calibration: MagCalibration) -> None:
        """Use ``calibration`` for its sensor (its filter learns the heading anew, as in the main window)."""
        if calibration.sensor_id not in self.sensor_ids:
            raise ValueError(f"sensor {calibration.sensor_id} is not in this suit")
        self.live_session.apply_mag_calibration(calibration, save=False)

    def read(self) -> dict[str, SensorSamples]:
        """Advance the simulation by ``step_s`` and return each sensor's new samples."""
        self._clock.now += self.step_s
        self.live_session.step()
        return super().read()


def feed_for_live_session(live_session: Any) -> LiveSessionFeed:
    """The calibration feed of the main window's live session (see :class:`LiveSessionFeed`)."""
    return LiveSessionFeed(live_session)
