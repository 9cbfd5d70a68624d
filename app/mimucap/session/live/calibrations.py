"""The live session's calibrations part: the magnetometer calibration of each sensor, kept per
device, and the body calibration (no Qt).

Magnetometer calibrations are data that persist, kept per device in a
:class:`~mimucap.io.calibration_store.CalibrationStore`: each sensor the source brings gets the
calibration stored for the device the source says it is
(:meth:`~mimucap.io.calibration_store.CalibrationStore.lookup`), and no other: another suit
numbered alike takes none, and :attr:`LiveCalibrations.problems` says why. A calibration made in
the wizard is applied to the sensor's filter at once and saved there for that device. A sensor
whose device changes (another node answering to the same id) loses a calibration made on
another device. The calibrations are applied to the filters of the processing part
(:class:`~mimucap.session.live.processing.LiveProcessing`), which is what the orientations
are computed with; nothing else keeps a copy.

The body calibration (:class:`~mimucap.core.bodycal.BodyCalibration`: sensor → segment
rotations) drives the figure once applied. Neither may change while a recording runs (a
recording is computed with the calibrations it started with): :meth:`LiveCalibrations.lock_while_recording`.

Events (``events``, :class:`~mimucap.session.events.EmitterGroup`):

* ``magnetometer(sensor_ids)``: the magnetometer calibrations of these sensors were applied,
  loaded from the store or dropped;
* ``body(calibration_or_None)``: a body calibration was applied, or cleared (``None``).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

from mimucap.core import bodycal, skeleton
from mimucap.core.device_identity import describe_device
from mimucap.core.magcal.model import MagCalibration
from mimucap.io.calibration_store import CalibrationFileError, CalibrationStore
from mimucap.session.events import EmitterGroup
from mimucap.session.live.processing import LiveProcessing
from mimucap.session.live.sensors import LiveSensors
from mimucap.session.recorded.stored_processing import check_body_calibration_fits
from mimucap.session.views.skeleton_figure import bodycal_heading


class LiveCalibrations:
    """The calibrations of the sensors of ``sensors``, applied to ``processing``'s filters, for
    skeleton ``model``; ``store``: where magnetometer calibrations are kept (``None``: in memory
    only)."""

    def __init__(self, sensors: LiveSensors, processing: LiveProcessing, model: skeleton.SkeletonModel,
                 store: CalibrationStore | None) -> None:
        self._sensors = sensors
        self._processing = processing
        self.model = model
        self.store = store
        self.events = EmitterGroup("magnetometer", "body")
        #: sensor → why a magnetometer calibration stored under its id is not used (a damaged
        #: file, another device's calibration)
        self.problems: dict[str, str] = {}
        #: the body calibration that drives the figure, or ``None``
        self.body: bodycal.BodyCalibration | None = None
        #: sensors whose calibration in use was loaded from the store (a change of device drops it)
        self._stored: set[str] = set()
        #: sensors of :attr:`problems` whose stored file could not be read
        self._unreadable: set[str] = set()
        self._recording = False

    # -- magnetometers -------------------------------------------------------------------------
    @property
    def magnetometer(self) -> dict[str, MagCalibration]:
        """Sensor id → the magnetometer calibration its filter applies."""
        return self._processing.mag_calibrations

    def unreadable(self, sensor_id: str) -> bool:
        """Whether the calibration stored for ``sensor_id`` could not be read."""
        return sensor_id in self._unreadable

    def load_stored(self, sensor_ids: Iterable[str]) -> None:
        """Apply the stored magnetometer calibration of each sensor of ``sensor_ids`` not
        calibrated yet, its device's; a sensor whose source has not said which device it is
        waits for it. Why one stored under its id is not used is kept in :attr:`problems`."""
        loaded = self._load_stored(sensor_ids)
        if loaded:
            self.events.magnetometer.emit(tuple(loaded))

    def _load_stored(self, sensor_ids: Iterable[str]) -> list[str]:
        """:meth:`load_stored` without the event; returns the sensors that got a calibration."""
        loaded: list[str] = []
        if self.store is None:
            return loaded
        for sensor_id in sensor_ids:
            device = self._sensors.device_of(sensor_id)
            if sensor_id in self.magnetometer or sensor_id in self.problems or not device.settled:
                continue
            try:
                found = self.store.lookup(sensor_id, device)
            except (CalibrationFileError, OSError, ValueError) as error:
                self.problems[sensor_id] = str(error)
                self._unreadable.add(sensor_id)
                continue
            if found.calibration is not None:
                self._processing.set_mag_calibration(found.calibration)
                self._stored.add(sensor_id)
                loaded.append(sensor_id)
            elif found.note:
                self.problems[sensor_id] = found.note
        return loaded

    def follow_devices(self, changed: Iterable[str]) -> None:
        """The source says something new of the devices of the ``changed`` sensors: a sensor
        whose device became known gets its device's stored calibration; one whose device changed
        loses a calibration loaded for, or made on, another device."""
        changed = list(changed)
        for sensor_id in changed:
            calibration = self.magnetometer.get(sensor_id)
            now = self._sensors.device_of(sensor_id).device_id
            made_on = None if calibration is None else calibration.device_id
            if calibration is not None and (sensor_id in self._stored
                                            or (made_on is not None and now is not None and made_on != now)):
                self._processing.clear_mag_calibration(sensor_id)
                self._stored.discard(sensor_id)
            self.problems.pop(sensor_id, None)
            self._unreadable.discard(sensor_id)
        self._load_stored(changed)
        self.events.magnetometer.emit(tuple(changed))

    def apply_magnetometer(self, calibration: MagCalibration, save: bool = True) -> None:
        """Use ``calibration`` for its sensor from now on (its filter learns the heading anew,
        :meth:`mimucap.core.pipeline.chain.SensorChain.set_mag_calibration`) and keep it in the
        store (``save``) for the next start. ``ValueError`` while locked, or when it was made
        on another device than the sensor's."""
        self._refuse_while_locked("changing a magnetometer calibration")
        sensor_id = calibration.sensor_id
        device = self._sensors.device_of(sensor_id).device_id
        if calibration.device_id is None and device is not None:
            calibration = replace(calibration, device_id=device)   # made here, on this device
        elif calibration.device_id is not None and device is not None and calibration.device_id != device:
            raise ValueError(f"sensor {sensor_id}: this magnetometer calibration was made on "
                             f"{describe_device(calibration.device_id)}, and the sensor is "
                             f"{describe_device(device)}: calibrate it here")
        self._processing.set_mag_calibration(calibration)
        self._stored.discard(sensor_id)
        self.problems.pop(sensor_id, None)
        self._unreadable.discard(sensor_id)
        if save and self.store is not None:
            self.store.save(calibration)
        self.events.magnetometer.emit((sensor_id,))

    # -- the body ----------------------------------------------------------------------------
    def apply_body(self, calibration: bodycal.BodyCalibration) -> None:
        """Drive the figure through ``calibration`` (sensor → segment rotations) from now on;
        ``ValueError`` while locked or when the model lacks one of its segments."""
        self._refuse_while_locked("applying a body calibration")
        check_body_calibration_fits(calibration, self.model)
        self.body = calibration
        self.events.body.emit(calibration)

    def clear_body(self) -> None:
        """Drive the figure by each sensor's axes again."""
        self._refuse_while_locked("clearing the body calibration")
        self.body = None
        self.events.body.emit(None)

    @property
    def heading_ref_rad(self) -> float | None:
        """The heading the body display mode turns to face the camera: the N-pose's."""
        return None if self.body is None else bodycal_heading(self.body)

    # -- while recording ---------------------------------------------------------------------
    def lock_while_recording(self, recording: bool) -> None:
        """Refuse every change while ``recording`` (until called again with False)."""
        self._recording = bool(recording)

    def _refuse_while_locked(self, what: str) -> None:
        if self._recording:
            raise ValueError(f"stop recording before {what}: a recording is computed with the calibrations "
                             "it started with")
