"""The calibrations a recording's result is computed with, and where each came from (no Qt).

A body calibration's rotations ``q_segment_from_sensor`` hold only with the magnetometer
calibrations its N-pose orientations were computed with: a sensor's heading comes from its
calibrated field, so the same sensor fused with another calibration (or with its raw field)
turns every one of its segment's orientations about the vertical by a constant, while joint
angles, which compare two segments, may stay plausible. A body calibration therefore carries
those magnetometer calibrations (``details["magnetometer"]``: sensor id → the calibration's
JSON, :func:`with_magnetometers`), and whoever applies it applies them with it.

:func:`applied_calibrations` is the one place that chooses what a recording is processed with,
for the review, the exports, the analysis and every command alike:

* the body calibration given (``mimucap ... --calibration CAL.json``), else the one the session
  stores (made in the window, or imported with an MVNX file), else none;
* per sensor with a magnetometer, the first of: a magnetometer calibration file given
  (``--mag-calibration``), the one the body calibration was made with, the one the recording
  applied live, and, for a session that does not record its live processing (``mimucap
  simulate``, an import, an older file), the user's calibration store (where ``mimucap magcal
  fit --save`` and the wizard keep them), which gives a sensor only its own device's
  calibration (:meth:`~mimucap.io.calibration_store.CalibrationStore.lookup`, the device the
  session says the sensor was). A recording made in the window says exactly what its live view
  applied, so today's store never changes it.

Each calibration applied is judged as the live view judges it
(:mod:`mimucap.session.recorded.calibration_readiness`: verdict, device, the recording's local field,
age), so that a command can name one that is not good with its figures.

Every choice is said (:attr:`AppliedCalibrations.magnetometer_origin`, ``notes``) so that the
files and the screen can tell what they hold (:mod:`mimucap.session.recorded.provenance`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path

from mimucap.core import bodycal
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.magcal.standing import Standing
from mimucap.io.calibration_store import (
    CalibrationFileError, CalibrationStore, calibrations_from_json, calibrations_to_json, read_calibration_file,
)
from mimucap.io.session import Session
from mimucap.session.recorded.calibration_readiness import session_standings
from mimucap.session.recorded.stored_processing import recorded_processing
from mimucap.session.views.calibration_age import local_time_text

#: Where a body calibration keeps the magnetometer calibrations it was made with, and when it was made.
MAGNETOMETER_DETAIL = "magnetometer"
CREATED_DETAIL = "created_utc"
ORIGIN_DETAIL = "origin"


def utc_now_text() -> str:
    """Now, ISO 8601 UTC to the second (when a calibration is made)."""
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def with_magnetometers(calibration: bodycal.BodyCalibration, mag_calibrations: Mapping[str, MagCalibration] | None,
                       created_utc: str | None = None, origin: str | None = None) -> bodycal.BodyCalibration:
    """``calibration`` carrying the magnetometer calibrations of its sensors that its N-pose
    orientations were computed with (``mag_calibrations``: sensor → calibration, sensors it
    does not calibrate left out; None for orientations that came from elsewhere, e.g. a
    table), when it was made (ISO 8601 UTC; now when not given and not already said) and where
    (``origin``, kept when None)."""
    details = dict(calibration.details)
    sensors = set(calibration.sensors.values())
    if mag_calibrations is not None:
        details[MAGNETOMETER_DETAIL] = calibrations_to_json({sid: cal for sid, cal in sorted(mag_calibrations.items())
                                                             if sid in sensors})
    details[CREATED_DETAIL] = created_utc or details.get(CREATED_DETAIL) or utc_now_text()
    if origin is not None:
        details[ORIGIN_DETAIL] = origin
    return replace(calibration, details=details)


def body_magnetometers(calibration: bodycal.BodyCalibration, origin: str) -> dict[str, MagCalibration] | None:
    """Sensor → the magnetometer calibration ``calibration`` was made with; ``None`` when it
    does not say (made before calibrations carried them). ``ValueError`` naming ``origin``
    when one is malformed."""
    section = calibration.details.get(MAGNETOMETER_DETAIL)
    if section is None:
        return None
    return calibrations_from_json(section, origin, f"body calibration entry '{MAGNETOMETER_DETAIL}'")


def body_created_utc(calibration: bodycal.BodyCalibration) -> str:
    """When ``calibration`` was made (ISO 8601), '' when it does not say."""
    return str(calibration.details.get(CREATED_DETAIL) or "")


@dataclass(frozen=True)
class AppliedCalibrations:
    """What a recording is processed with (see the module doc).

    ``body`` the body calibration or None, ``body_origin`` where it came from ('' without one);
    ``magnetometer`` sensor → calibration applied, ``magnetometer_origin`` sensor → where it
    came from; ``raw_field`` sensors with a magnetometer fused with their raw field; ``onboard``
    sensors whose device sends its own orientation (its fusion handles its magnetometer); ``notes``
    sentences about choices a reader should know (a body calibration made with another
    magnetometer calibration than the recording applied live, ...); ``standings`` sensor → how
    its calibration stands against the recording (:class:`~mimucap.core.magcal.standing.Standing`);
    ``store_notes`` sensor → why a calibration stored under its label was not used (another
    device's, or a device that cannot be checked).
    """

    body: bodycal.BodyCalibration | None = None
    body_origin: str = ""
    magnetometer: Mapping[str, MagCalibration] = field(default_factory=dict)
    magnetometer_origin: Mapping[str, str] = field(default_factory=dict)
    raw_field: tuple[str, ...] = ()
    onboard: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    standings: Mapping[str, Standing] = field(default_factory=dict)
    store_notes: Mapping[str, str] = field(default_factory=dict)

    def lines(self) -> list[str]:
        """One line per sensor with a magnetometer: where its calibration came from and how it
        stands against the recording."""
        found = [f"magnetometer {sid}: {self.magnetometer_origin[sid]}"
                 + (f"; {self.standings[sid].summary()}" if sid in self.standings else "") for sid in self.magnetometer]
        found += [f"magnetometer {sid}: not calibrated (raw field used)"
                  + (f": {self.store_notes[sid]}" if sid in self.store_notes else "") for sid in self.raw_field]
        found += [f"magnetometer {sid}: the device fuses on board" for sid in self.onboard]
        return found

    def not_good(self) -> list[str]:
        """Sensors whose applied magnetometer calibration is not good for this recording (its
        verdict, device, local field or age: :mod:`mimucap.session.recorded.calibration_readiness`)."""
        return [sid for sid, standing in self.standings.items() if not standing.good]


def read_magnetometer_files(paths: Sequence[str | Path], session: Session) -> dict[str, tuple[MagCalibration, str]]:
    """Sensor → (calibration, file) of magnetometer calibration files given for ``session``;
    ``ValueError`` naming the file when it cannot be read or names a sensor the session lacks."""
    found: dict[str, tuple[MagCalibration, str]] = {}
    for name in paths:
        path = Path(name)
        calibration = read_calibration_file(path, "--mag-calibration")
        if calibration.sensor_id not in session.sensors:
            raise ValueError(f"--mag-calibration {path}: sensor {calibration.sensor_id} is not in the session "
                             f"(it has {', '.join(session.sensors)})")
        found[calibration.sensor_id] = (calibration, str(path))
    return found


def _same(a: MagCalibration, b: MagCalibration) -> bool:
    return (a.created_utc == b.created_utc and bool((a.offset_uT == b.offset_uT).all())
            and bool((a.soft_iron == b.soft_iron).all()))


def _when(created_utc: str | None) -> str:
    """A calibration's time in local date and time ("unknown date" without one)."""
    return local_time_text(created_utc) if created_utc else "unknown date"


def applied_calibrations(session: Session, *, body: bodycal.BodyCalibration | None = None, body_origin: str = "",
                         mag_files: Sequence[str | Path] = (), origin: str = "the session",
                         store: CalibrationStore | None = None, stored_body: bool = True) -> AppliedCalibrations:
    """The calibrations ``session`` is processed with (the order of the module doc).

    ``body``: a body calibration given (``body_origin`` says where from, e.g. the file), else
    the session's own unless ``stored_body`` is False (sensor orientations for a new body
    calibration); ``mag_files``: magnetometer calibration files given; ``origin`` names the
    session in messages; ``store``: the user's calibration store (default location when None),
    read only for a session that does not record its live processing."""
    recorded = recorded_processing(session, origin=origin)
    if body is None and stored_body:
        body = recorded.body_calibration
        if body is not None:
            body_origin = str(body.details.get(ORIGIN_DETAIL) or "recorded with the session")
    own = None if body is None else body_magnetometers(body, body_origin or origin)
    made_with = set() if own is None else set(body.sensors.values())  # the sensors it says it was made with
    files = read_magnetometer_files(mag_files, session)
    recorded_live = isinstance(session.metadata.get("pipeline"), Mapping)
    store = store if store is not None else (None if recorded_live else CalibrationStore())
    devices = session.devices()
    store_notes: dict[str, str] = {}
    chosen: dict[str, MagCalibration] = {}
    origins: dict[str, str] = {}
    raw: list[str] = []
    onboard: list[str] = []
    notes: list[str] = []
    for sensor_id, stream in session.sensors.items():
        if stream.q_world_from_sensor is not None:
            onboard.append(sensor_id)  # the pipeline takes the device's orientation as it is
            continue
        if stream.mag_uT is None:
            continue
        if sensor_id in files:
            chosen[sensor_id], origins[sensor_id] = files[sensor_id]
            continue
        usual: tuple[MagCalibration, str] | None = None
        if sensor_id in recorded.mag_calibrations:
            usual = (recorded.mag_calibrations[sensor_id], "recorded with the session")
        elif store is not None:
            try:
                found = store.lookup(sensor_id, devices[sensor_id])  # only this device's own calibration
            except CalibrationFileError as error:
                raise ValueError(str(error)) from None
            if found.calibration is not None:
                usual = (found.calibration, f"stored ({store.path_for(sensor_id, found.calibration.device_id)})")
            elif found.note:
                store_notes[sensor_id] = found.note
        if sensor_id in made_with and sensor_id not in own:
            raw.append(sensor_id)  # made with this sensor's raw field
            if usual is not None:
                notes.append(f"{sensor_id}: the body calibration was made with its raw magnetic field, so the "
                             f"magnetometer calibration {usual[1]} is not applied")
        elif sensor_id in made_with:
            chosen[sensor_id] = own[sensor_id]
            if usual is not None and _same(own[sensor_id], usual[0]):
                origins[sensor_id] = f"{usual[1]}, the one the body calibration was made with"
            else:
                origins[sensor_id] = f"the one the body calibration was made with ({body_origin or 'stored with it'})"
                if usual is not None:
                    notes.append(f"{sensor_id}: the body calibration was made with another magnetometer calibration "
                                 f"(of {_when(own[sensor_id].created_utc)}) than the one {usual[1]} "
                                 f"(of {_when(usual[0].created_utc)}); its own is applied")
        elif usual is not None:
            chosen[sensor_id], origins[sensor_id] = usual
        else:
            raw.append(sensor_id)
    return AppliedCalibrations(body, body_origin if body is not None else "", chosen, origins, tuple(raw),
                               tuple(onboard), tuple(notes), session_standings(session, chosen), store_notes)
