"""The checklist before recording flags what a recording would miss, sensor by sensor."""

from __future__ import annotations

import math
from types import SimpleNamespace

from mimucap.acquisition.stats import SensorStats
from mimucap.session.live.sensor_rows import SensorRow
from mimucap.session.live.checklist import MAG_CAL_MAX_AGE_H, recording_checklist


def _row(sid, segment, stale=False, mag_cal="calibrated", age_s=600.0, drops=0):
    return SensorRow(sid, segment, 100.0, drops, 5.0, math.nan, mag_cal, age_s, (), stale, "ok")


def _live(rows, drops=None, verdicts=None, body=None):
    drops = drops or {}
    stats = {r.sensor_id: SensorStats(r.sensor_id, "src", 1000, drops.get(r.sensor_id, 0), 100.0, 0.01, 0.02, 0.0)
             for r in rows}
    calibrations = {r.sensor_id: SimpleNamespace(quality={"verdict": (verdicts or {}).get(r.sensor_id, "good")})
                    for r in rows if r.mag_cal == "calibrated"}
    return SimpleNamespace(sensor_rows=lambda: rows, feed=SimpleNamespace(stats=lambda: stats),
                           mag_calibrations=calibrations, body_calibration=body)


def _by_key(items):
    return {item.key: item for item in items}


def test_a_ready_session_passes_every_item():
    body = SimpleNamespace(quality=SimpleNamespace(verdict="good"))
    items = _by_key(recording_checklist(_live([_row("1", "pelvis"), _row("2", "thigh_r", age_s=7200.0),
                                               _row("3", None, stale=True)], body=body)))
    assert all(item.ok for item in items.values()), items
    assert items["streaming"].text == "all 2 assigned sensors send data"  # an unassigned sensor does not count
    assert items["magnetometers"].text == "2 calibrated, the oldest 2 hours ago; quality good"
    assert items["body"].text == "done, quality good"


def test_each_problem_is_named_by_the_sensors_segment():
    rows = [_row("1", "pelvis", stale=True), _row("2", "thigh_r", mag_cal="not calibrated", age_s=math.nan),
            _row("3", "shank_r", age_s=(MAG_CAL_MAX_AGE_H + 1) * 3600.0), _row("4", "thigh_l"),
            _row("5", "upper_arm_l", mag_cal="on-board", age_s=math.nan)]
    items = _by_key(recording_checklist(_live(rows, drops={"4": 50}, verdicts={"4": "fail"},
                                              body=SimpleNamespace(quality=SimpleNamespace(verdict="poor")))))
    assert not any(item.ok for item in items.values())
    assert items["streaming"].text == "1 of 5 send nothing: Pelvis sensor (1)"
    assert items["drops"].text == "Left thigh sensor (4) lost 4.8 %"
    assert items["magnetometers"].text == ("not calibrated: Right thigh sensor (2); poor calibration: Left thigh sensor (4); "
                                           "older than 24 h: Right shank sensor (3)")
    assert items["body"].text == "done, quality poor"


def test_nothing_assigned_and_no_body_calibration():
    items = _by_key(recording_checklist(_live([_row("1", None)])))
    assert not items["streaming"].ok and "Assign Sensors" in items["streaming"].text
    assert not items["magnetometers"].ok and not items["body"].ok and "Calibrate → Body" in items["body"].text


def test_long_lists_name_the_first_two_and_count_the_rest():
    segments = ("pelvis", "thorax", "thigh_l", "thigh_r", "shank_l")
    rows = [_row(str(k), segment, stale=k < 4, mag_cal="not calibrated", age_s=math.nan)
            for k, segment in enumerate(segments)]
    items = _by_key(recording_checklist(_live(rows, drops={str(k): 10 * (k + 1) for k in range(5)})))
    assert items["streaming"].text == "4 of 5 send nothing: Pelvis sensor (0), Thorax sensor (1) and 2 more"
    assert items["drops"].text == "Left shank sensor (4) lost 4.8 %; Right thigh sensor (3) lost 3.8 % and 2 more"  # 10 of 1010 is not over 1 %
    assert items["magnetometers"].text == "not calibrated: all 5"
