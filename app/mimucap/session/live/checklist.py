"""What to check before recording, from the live session's state (no Qt).

:func:`recording_checklist` gives four items, each ``ok`` or not with a line of text:

1. **Sensors streaming**: every sensor assigned to a segment has sent a sample within
   :data:`~mimucap.session.live.sensor_rows.STALE_AFTER_S` (and at least one sensor is assigned);
2. **Drops**: no assigned sensor lost more than :data:`MAX_DROP_FRACTION` of its packets;
3. **Magnetometers**: every assigned sensor's magnetometer is calibrated (or the device fuses
   on board), and each calibration's standing
   (:func:`~mimucap.core.magcal.standing.calibration_standing`: its verdict, the device it was
   made on, whether the local field still fits it, its age) is not "not good"; a sensor whose
   stored calibration belongs to another device is named as not calibrated, with that reason;
4. **Body calibration**: an N/T-pose calibration is applied, and its verdict is not "poor".

The live session publishes the list with its status (event ``checklist``); the main window
shows it next to the Record button and asks for a confirmation before recording while an item
is not ok. :func:`magnetometer_readiness` is what a recording stores of the same judgement.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mimucap.core.clinical_names import sensor_name
from mimucap.core.magcal.standing import MAX_AGE_H, calibration_standing
from mimucap.session.views.calibration_age import describe_age, quality_word

#: A sensor losing more than this fraction of its packets is flagged.
MAX_DROP_FRACTION = 0.01
#: A magnetometer calibration older than this (hours) is flagged (the standing's limit).
MAG_CAL_MAX_AGE_H = MAX_AGE_H
#: How the checklist groups the calibrations that are not good, by problem kind
#: (:data:`~mimucap.core.magcal.standing.PROBLEM_KINDS`).
PROBLEM_GROUPS = {"verdict": "poor calibration", "device": "made on another device",
                  "field": "the local field no longer fits", "age": f"older than {MAX_AGE_H:.0f} h"}
#: Sensors named in one line before "and N more" (the line stays short in the session panel).
MAX_NAMED = 2


@dataclass(frozen=True)
class CheckItem:
    """One line of the checklist: ``key`` (``streaming``, ``drops``, ``magnetometers``,
    ``body``), ``title`` (what is checked), ``ok``, ``text`` (what was found)."""

    key: str
    title: str
    ok: bool
    text: str


def _first_few(texts: list[str], separator: str = ", ") -> str:
    """The first :data:`MAX_NAMED` of ``texts`` and how many more: "a, b and 4 more"."""
    more = len(texts) - MAX_NAMED
    return separator.join(texts[:MAX_NAMED]) + (f" and {more} more" if more > 0 else "")


def _names(sensors: list[tuple[str, str]], total: int | None = None) -> str:
    """"Pelvis sensor (S01), Left thigh sensor (S05) and 4 more"; "all 10" when every one of
    ``total`` sensors is meant."""
    if total is not None and len(sensors) == total and total > MAX_NAMED:
        return f"all {total}"
    return _first_few([sensor_name(segment, sid) for sid, segment in sensors])


def _age_text(age_s: float) -> str:
    return describe_age(age_s / 86400.0 if math.isfinite(age_s) else None)


def recording_checklist(live, rows=None) -> list[CheckItem]:
    """The checklist of ``live`` (a :class:`~mimucap.session.live.live_session.LiveSession`) now; ``rows``:
    its :meth:`~mimucap.session.live.live_session.LiveSession.sensor_rows` when the caller has them already."""
    rows = live.sensor_rows() if rows is None else rows
    stats = live.feed.stats()
    assigned = [(row.sensor_id, row.segment) for row in rows if row.segment is not None]
    by_id = {row.sensor_id: row for row in rows}
    items = []

    if not assigned:
        items.append(CheckItem("streaming", "Sensors streaming", False,
                               "no sensor is assigned to a segment (Session → Assign Sensors)"))
    else:
        silent = [(sid, seg) for sid, seg in assigned if by_id[sid].stale]
        items.append(CheckItem(
            "streaming", "Sensors streaming", not silent,
            f"all {len(assigned)} assigned sensors send data" if not silent else
            f"{len(silent)} of {len(assigned)} send nothing: {_names(silent)}"))

    lossy = []
    for sid, seg in assigned:
        st = stats.get(sid)
        if st is not None and st.drop_fraction > MAX_DROP_FRACTION:
            lossy.append((sid, seg, st.drop_fraction))
    lossy.sort(key=lambda item: -item[2])
    total_drops = sum(by_id[sid].drops for sid, _seg in assigned)
    items.append(CheckItem(
        "drops", "Drops", not lossy,
        (f"{total_drops} packets lost in all" if total_drops else "no packet lost") if not lossy else
        _first_few([f"{sensor_name(seg, sid)} lost {100 * fraction:.1f} %" for sid, seg, fraction in lossy], "; ")))

    uncalibrated, not_used, unreadable, ages, verdicts, unverified = [], [], [], [], set(), []
    groups: dict[str, list[str]] = {kind: [] for kind in PROBLEM_GROUPS}
    for sid, seg in assigned:
        row = by_id[sid]
        if row.mag_cal == "on-board":
            continue
        calibration = live.mag_calibrations.get(sid)
        if calibration is None:
            group = unreadable if row.mag_cal_unreadable else not_used if row.mag_cal_note else uncalibrated
            group.append((sid, seg))
            continue
        standing = sensor_standing(calibration, row)
        verdicts.add(standing.verdict)
        ages.append(row.mag_cal_age_s)
        for kind in PROBLEM_GROUPS:
            found = [p.text for p in standing.problems if p.kind == kind]
            if found and kind == "field":   # the figures, sensor by sensor
                groups[kind].append(f"{sensor_name(seg, sid)} {', '.join(found)}")
            elif found:
                groups[kind].append(sensor_name(seg, sid))
        if any(w.kind == "device" for w in standing.warnings):
            unverified.append((sid, seg))
    problems = []
    if uncalibrated:
        problems.append(f"not calibrated: {_names(uncalibrated, len(assigned))}")
    if not_used:
        problems.append(f"not calibrated, the stored calibration is another device's: {_names(not_used)}")
    if unreadable:
        problems.append(f"not calibrated, the stored calibration is unreadable: {_names(unreadable)}")
    for kind, label in PROBLEM_GROUPS.items():
        if groups[kind]:
            problems.append(f"{label}: " + _first_few(groups[kind], "; " if kind == "field" else ", "))
    if not assigned:
        mag_text, mag_ok = "no sensor assigned", False
    elif problems:
        mag_text, mag_ok = "; ".join(problems), False
    elif ages:
        finite = [a for a in ages if math.isfinite(a)]
        oldest = _age_text(max(finite)) if finite else "date unknown"
        mag_text = f"{len(ages)} calibrated, the oldest {oldest}; quality {', '.join(sorted(quality_word(v) for v in verdicts))}"
        if unverified:
            mag_text += f"; device not verified: {_names(unverified)}"
        mag_ok = True
    else:
        mag_text, mag_ok = "the sensors fuse on board", True
    items.append(CheckItem("magnetometers", "Magnetometer calibration", mag_ok, mag_text))

    body = live.body_calibration
    if body is None:
        items.append(CheckItem("body", "Body calibration", False, "not done (Calibrate → Body…)"))
    else:
        verdict = body.quality.verdict
        items.append(CheckItem("body", "Body calibration", verdict != "poor", f"done, quality {quality_word(verdict)}"))
    return items


def sensor_standing(calibration, row):
    """The standing of the calibration applied to the sensor of ``row`` (a
    :class:`~mimucap.session.live.sensor_rows.SensorRow`): its device, its local field and its age as the
    row gives them (:func:`~mimucap.core.magcal.standing.calibration_standing`)."""
    return calibration_standing(calibration, row.sensor_id, device=row.device, field=row.local_field,
                                age_s=row.mag_cal_age_s)


def magnetometer_readiness(live, rows=None) -> dict[str, dict]:
    """What a recording stores of its magnetometers' readiness when it starts: sensor id →
    the standing of its calibration (:meth:`~mimucap.core.magcal.standing.Standing.to_json`),
    or ``{"level": "not calibrated", "problems": [why]}``, for every sensor with a
    magnetometer that does not fuse on board."""
    rows = live.sensor_rows() if rows is None else rows
    found: dict[str, dict] = {}
    for row in rows:
        if row.mag_cal == "on-board":
            continue
        calibration = live.mag_calibrations.get(row.sensor_id)
        if calibration is not None:
            found[row.sensor_id] = sensor_standing(calibration, row).to_json()
        elif row.has_magnetometer:
            found[row.sensor_id] = {"level": "not calibrated",
                                    "problems": [row.mag_cal_note] if row.mag_cal_note else []}
    return found

