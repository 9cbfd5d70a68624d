"""The sensor table of the live view: one row per sensor, read from the live session's parts (no Qt).

A :class:`SensorRow` gathers what the sensor panel, the checklist and the status bar say of one
sensor: its rate, drops and latency (the source's statistics over the last 2 s), its battery and
radio link, its magnetometer calibration and how well it still fits the local field, its fusion
flags and why its orientation may be wrong (:mod:`mimucap.core.pipeline.doubt_reasons`). :func:`sensor_rows`
builds the rows from the parts that own each of those (sensors, processing, calibrations, plot
history); the status part publishes them (:mod:`mimucap.session.live.status`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone

from mimucap.core.pipeline import doubt_reasons
from mimucap.core.clinical_names import segment_name
from mimucap.core.device_identity import SensorDevice
from mimucap.core.fusion import FLAG_NAMES
from mimucap.core.magcal.standing import LocalField, Standing, age_s_at
from mimucap.session.live.calibrations import LiveCalibrations
from mimucap.session.live.checklist import sensor_standing
from mimucap.session.live.plot_history import PlotHistory
from mimucap.session.live.processing import LiveProcessing
from mimucap.session.live.sensors import LiveSensors

#: A sensor whose last sample arrived longer ago than this (s) is flagged stale.
STALE_AFTER_S = 1.0
#: Seconds of recent samples the local field is measured over (the sensor panel, the checklist).
FIELD_CHECK_WINDOW_S = 2.0
#: Fusion flags the sensor panel shows: flag name (:data:`FLAG_NAMES`) → label.
FLAG_LABELS = {"rest": "still", "mag_rejected": "magnetic field disturbed", "acc_rejected": "fast movement",
               "uninitialised": "starting", "mag_offset": "magnetometer offset corrected"}


@dataclass(frozen=True)
class SensorRow:
    """One line of the sensor panel.

    ``rate_hz`` samples/s over the last 2 s; ``drops`` sequence gaps; ``latency_ms`` p95 from
    the sample's host time to its arrival in this process; ``battery_pct`` (NaN if unknown);
    ``mag_cal`` ``"calibrated"``, ``"on-board"`` (device fuses itself) or ``"not calibrated"``;
    ``mag_cal_age_s`` since the calibration was made (NaN if none); ``mag_cal_verdict`` its
    verdict (``good``, ``warn``; "" without one); ``mag_field_warning`` says when the local field
    (magnitude, dip) no longer matches the calibration's (""); ``mag_standing`` the
    calibration's standing (:func:`~mimucap.core.magcal.standing.calibration_standing`: verdict,
    device, local field, age; ``None`` without a calibration); ``mag_cal_note`` why a
    calibration stored under its id is not used (another device's, a damaged file:
    ``mag_cal_unreadable``; "");
    ``device`` what the source says of its device (:class:`~mimucap.core.device_identity.SensorDevice`);
    ``local_field`` the field it measures now, corrected by its calibration (``None`` without a
    calibration or enough samples); ``has_magnetometer`` whether it sends a magnetic field;
    ``flags`` fusion flags
    now (``"still"``, ``"magnetic field disturbed"``, ...); ``stale`` no sample for :data:`STALE_AFTER_S`;
    ``state`` the tint name of its segment (``ok``, ``mag_uncalibrated``, ``stale``);
    ``signal_dbm`` the strength of its radio link where the source reports one (SlimeVR), NaN
    otherwise; ``rejections`` packets of this sensor the source refused, by reason
    (:class:`~mimucap.acquisition.rejections.Rejection` value → count, since the source started);
    ``doubt`` why its newest orientation may be wrong, in words ("" when it is trustworthy;
    :mod:`mimucap.core.pipeline.doubt_reasons`).
    """

    sensor_id: str
    segment: str | None
    rate_hz: float
    drops: int
    latency_ms: float
    battery_pct: float
    mag_cal: str
    mag_cal_age_s: float
    flags: tuple[str, ...]
    stale: bool
    state: str
    mag_cal_verdict: str = ""
    mag_field_warning: str = ""
    signal_dbm: float = float("nan")
    rejections: Mapping[str, int] = field(default_factory=dict)
    mag_standing: Standing | None = None
    mag_cal_note: str = ""
    mag_cal_unreadable: bool = False
    device: SensorDevice | None = None
    local_field: LocalField | None = None
    has_magnetometer: bool = False
    doubt: str = ""


def sensor_rows(sensors: LiveSensors, processing: LiveProcessing, calibrations: LiveCalibrations,
                history: PlotHistory, now_s: float) -> list[SensorRow]:
    """One :class:`SensorRow` per known sensor of ``sensors``, in the source's order, at host
    monotonic time ``now_s``."""
    stats = sensors.stats()
    signal = sensors.feed.signal_dbm()
    rows = []
    for sid in sensors.sensor_ids:
        st = stats.get(sid)
        last_seen = float("nan") if st is None else st.last_seen_s
        stale = not (now_s - last_seen <= STALE_AFTER_S)
        calibration = calibrations.magnetometer.get(sid)
        if calibration is not None:
            mag_cal, age = "calibrated", _age_s(calibration.created_utc)
        elif processing.onboard(sid):
            mag_cal, age = "on-board", float("nan")
        else:
            mag_cal, age = "not calibrated", float("nan")
        value = processing.fusion_flags(sid)
        flags = () if value is None else tuple(label for key, label in FLAG_LABELS.items() if value & FLAG_NAMES[key])
        why = doubt_reasons.describe(processing.doubt_bits(sid)) if processing.knows(sid) else ""
        if stale:
            tint = "stale"
        elif mag_cal == "not calibrated":
            tint = "mag_uncalibrated"
        else:
            tint = "ok"
        row = SensorRow(
            mag_cal_verdict="" if calibration is None else str(calibration.quality.get("verdict", "")),
            device=sensors.device_of(sid),
            local_field=None if calibration is None else history.local_field(sid, FIELD_CHECK_WINDOW_S),
            mag_cal_note="" if calibration is not None else calibrations.problems.get(sid, ""),
            mag_cal_unreadable=calibration is None and calibrations.unreadable(sid),
            has_magnetometer=processing.has_magnetometer(sid),
            sensor_id=sid, segment=sensors.sensor_segments.get(sid),
            rate_hz=float("nan") if st is None else st.rate_hz, drops=0 if st is None else st.drops,
            latency_ms=float("nan") if st is None else 1000.0 * st.latency_p95_s,
            battery_pct=sensors.battery_pct(sid),
            mag_cal=mag_cal, mag_cal_age_s=age, flags=flags, stale=stale, state=tint,
            signal_dbm=signal.get(sid, float("nan")),
            rejections={} if st is None else dict(st.rejections), doubt=why)
        if calibration is not None:
            standing = sensor_standing(calibration, row)
            fits = [p.text for p in standing.problems if p.kind == "field"]
            row = replace(row, mag_standing=standing,
                          mag_field_warning="; ".join(fits) + ": calibrate again here" if fits else "")
        rows.append(row)
    return rows


def doubt_warning(rows) -> str:
    """What the status bar says while sensors' orientations are doubtful: why, and the sensors
    (segment and id) for each reason ("" when every orientation is trustworthy)."""
    sensors_of: dict[str, list[str]] = {}
    for row in rows:
        if row.doubt and not row.stale:
            where = f"{segment_name(row.segment)} ({row.sensor_id})" if row.segment else row.sensor_id
            sensors_of.setdefault(row.doubt, []).append(where)
    parts = [f"{why}: {', '.join(sensors)}" for why, sensors in sensors_of.items()]
    return ("Orientation doubtful — " + "; ".join(parts)) if parts else ""


def _age_s(created_utc: str) -> float:
    age = age_s_at(created_utc, datetime.now(timezone.utc))
    return float("nan") if age is None else age
