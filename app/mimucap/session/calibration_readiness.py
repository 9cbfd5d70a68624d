"""The standing of the magnetometer calibrations applied to a recording (no Qt).

A command that processes a session (``bodycal``, ``angles``, ``export``, ``gait``, ``report``)
applies a magnetometer calibration to each sensor: the one the recording stores, one given on
the command line, or the one the user's calibration store holds for the sensor's device. Each is
judged by :func:`~mimucap.core.magcal_standing.calibration_standing`, as the live view judges
it, against the recording: the device the recording says the sensor was
(:meth:`~mimucap.io.session.Session.devices`), the local field of the recording's own samples corrected by the
calibration (the whole recording: its median magnitude, and its dip while the sensor is still),
and the calibration's age at the time the recording was made (:func:`recorded_at`).
"""

from __future__ import annotations

from collections.abc import Mapping
from datetime import datetime, timezone

from mimucap.core.device_identity import SensorDevice
from mimucap.core.magcal import MagCalibration
from mimucap.core.magcal_standing import Standing, age_s_at, calibration_standing, local_field
from mimucap.io.session import Session

def recorded_at(session: Session) -> datetime | None:
    """When the recording was made (its start, else the file's creation), aware UTC; ``None``
    when the session does not say."""
    recording = session.metadata.get("recording")
    for text in ((recording or {}).get("started_utc") if isinstance(recording, Mapping) else None,
                 session.metadata.get("created_utc")):
        if not text:
            continue
        try:
            when = datetime.fromisoformat(str(text).replace("Z", "+00:00"))
        except ValueError:
            continue
        return when if when.tzinfo is not None else when.replace(tzinfo=timezone.utc)
    return None


def session_standing(session: Session, sensor_id: str, calibration: MagCalibration,
                     devices: Mapping[str, SensorDevice] | None = None,
                     window_s: tuple[float, float] | None = None) -> Standing:
    """The standing of ``calibration`` applied to ``sensor_id`` of ``session`` (see the module
    docstring); ``devices``: ``session.devices()``, when the caller has them already;
    ``window_s`` the part of the recording (s) whose local field counts (the whole recording
    when None; a body calibration is judged on its poses, so that a disturbance later in the
    recording does not make its N-pose headings suspect)."""
    stream = session.sensors[sensor_id]
    devices = session.devices() if devices is None else devices
    field = None
    if stream.mag_uT is not None:
        rows = slice(None)
        if window_s is not None:
            rows = (stream.t_s >= window_s[0]) & (stream.t_s <= window_s[1])
        acc = None if stream.acc is None else stream.acc[rows]
        gyr = None if stream.gyr is None else stream.gyr[rows]
        field = local_field(acc, gyr, calibration.apply(stream.mag_uT[rows], sensor_id))
    when = recorded_at(session)
    age = None if when is None else age_s_at(calibration.created_utc, when)
    return calibration_standing(calibration, sensor_id, device=devices.get(sensor_id), field=field, age_s=age)


def session_standings(session: Session, calibrations: Mapping[str, MagCalibration],
                      window_s: tuple[float, float] | None = None) -> dict[str, Standing]:
    """Sensor → the standing of the calibration applied to it, for every sensor of
    ``calibrations`` that the session holds (``window_s``: see :func:`session_standing`)."""
    devices = session.devices()
    return {sid: session_standing(session, sid, calibration, devices, window_s)
            for sid, calibration in calibrations.items() if sid in session.sensors}
