"""The guided N-pose / T-pose body calibration (no Qt).

:class:`BodycalProcedure` is a state machine driven by :meth:`BodycalProcedure.step` (one
call each time the feed tells ``arrived``, or a loop in tests; each step tells its
:class:`BodycalStatus` through ``events.status``). It pulls sensor orientations
(``q_world_from_sensor``, world ENU, scalar-first) from a feed
(:mod:`mimucap.session.sources.calibration_feed`) and walks through two pose pages:

1. **N-pose**: standing upright, arms hanging. The page waits until every mapped sensor is
   still (the *stillness meter*: the largest angle any sensor turned within the last
   ``meter_window_s``) and no sensor's orientation is still settling (for seconds after a new
   magnetometer calibration the filter converges on the newly calibrated field; a pose captured
   then would make every joint angle doubtful), then counts down ``hold_s`` while the averaged
   window fills. If any
   sensor turns more than ``still_limit_deg`` from its window mean, the capture restarts with a
   message naming the sensor.
2. **T-pose**: the chosen arm(s) raised sideways to the horizontal. The page waits until each
   raised arm's sensor turned at least ``raise_min_deg`` from its N-pose orientation, then
   captures a still window the same way.

Then :func:`mimucap.core.bodycal.calibrate_npose_tpose` computes the sensor-to-segment
rotations from the two windows and the arm movement in between (phase ``"result"``), each
sensor's N-pose orientation taken from the still window's mean accelerometer and calibrated
magnetometer where the feed can give it (``feed.static_orientation``: what the orientation
filter converges to, free of the transient its heading may still carry shortly after a new
magnetometer calibration), or
refuses (phase ``"refused"`` with the reason). The result carries the magnetometer calibrations
the feed's pipeline applied (``feed.magnetometer_calibrations()``), with which its rotations
hold (:mod:`mimucap.session.recorded.calibration_choice`); sensors whose orientation the pipeline doubted
between the N-pose and the end of the T-pose are recorded in it
(:func:`~mimucap.core.bodycal.with_doubtful_sensors`: its joint angles are then doubtful). A pose that is not held still within
``pose_timeout_s`` is refused as well ("the subject kept moving in the N-pose"). Each page's
instruction goes to the feed (:mod:`mimucap.session.procedures.instructions`): the person reads it, and the
simulated subject of the simulated suit does it.

The **functional** method (``method="functional"``), for a subject who cannot raise the arms:
the same still page (standing upright, stillness meter, averaged window), then a **movement**
page: walk a few steps, or, seated, bend both elbows a few times, for ``movement_s`` seconds.
:func:`mimucap.core.functional_bodycal.calibrate_functional`, the code of ``mimucap bodycal
--method functional``, then finds the knees' and elbows' axes and the walking direction in the
movement; its verdict grades every axis (:meth:`BodycalProcedure.quality_figures`).

Samples of the sensors are put on a common time base (that of the sensor with the most
samples, each other sensor's nearest sample: within half a sample period at the common rate).
Units: s, degrees for the figures shown.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mimucap.core import rotation as rot
from mimucap.core.bodycal import (
    ARM_SEGMENTS,
    DEFAULT_SETTINGS,
    BodyCalibration,
    BodyCalSettings,
    CalibrationRefused,
    calibrate_npose_tpose,
    check_mapping,
    segment_orientations,
    with_doubtful_sensors,
)
from mimucap.core.clinical_names import sensor_name
from mimucap.core.functional_bodycal import calibrate_functional
from mimucap.core.pipeline.doubt_reasons import NO_ORIENTATION, SETTLING, describe
from mimucap.core.pipeline.segments import segments_from_sensors
from mimucap.core.skeleton import SkeletonModel
from mimucap.session.events import EmitterGroup
from mimucap.session.procedures import instructions
from mimucap.session.sources.calibration_feed import DOUBT_EXTRA, CalibrationFeed
from mimucap.session.recorded.calibration_choice import with_magnetometers
from mimucap.session.procedures.instructions import Instruction

PHASES = ("ready", "npose", "tpose", "movement", "result", "refused")
ARMS = ("both", "right", "left")
#: The calibration methods: N-pose then T-pose, or standing still then walking (no T-pose).
METHODS = ("npose-tpose", "functional")
#: Doubts that pass while the subject stands still: the still page waits for them to clear.
TRANSIENT_DOUBTS = SETTLING | NO_ORIENTATION


@dataclass(frozen=True)
class BodycalProcedureSettings:
    """Settings of :class:`BodycalProcedure` (defaults in brackets).

    hold_s: length of each averaged pose window [2 s]. still_limit_deg: a sensor turning
    more than this from its window mean restarts the capture [2°; the engine refuses above
    3°]. meter_window_s: span of the stillness meter [0.5 s]. raise_min_deg: an arm sensor
    turned this far from the N-pose counts as raised [60°]. pose_timeout_s: a pose not
    captured within this time is refused [30 s]. movement_s: length of the functional
    method's movement (walking, or bending the elbows) [10 s: a few strides or flexions].
    engine: the body-calibration limits of the N/T-pose method.
    """

    hold_s: float = 2.0
    still_limit_deg: float = 2.0
    meter_window_s: float = 0.5
    raise_min_deg: float = 60.0
    pose_timeout_s: float = 30.0
    movement_s: float = 10.0
    engine: BodyCalSettings = DEFAULT_SETTINGS

    def __post_init__(self) -> None:
        for name in ("hold_s", "still_limit_deg", "meter_window_s", "raise_min_deg", "pose_timeout_s", "movement_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"body calibration setting {name} must be a positive number")


@dataclass(frozen=True)
class BodycalStatus:
    """What the page shows after a step.

    phase: see :data:`PHASES`. pose: "npose"/"tpose"/"movement" while capturing, else None.
    meter_deg: the stillness meter (largest recent turn of any sensor, deg; NaN before data).
    still: meter below the limit. capturing: the averaged window (or the movement) is filling.
    countdown_s: seconds of the window still to fill (None when not capturing).
    message: the instruction. restarts: captures restarted by movement on this page.
    settling_sensor: the sensor whose orientation the still page waits to settle ("" if none).
    """

    phase: str
    pose: str | None
    meter_deg: float
    still: bool
    capturing: bool
    countdown_s: float | None
    message: str
    restarts: int
    settling_sensor: str = ""


class _Track:
    """Growing orientation samples of one sensor: t (N,), q (N, 4), and the times (s) and
    reasons of the samples whose orientation the pipeline doubted (:mod:`mimucap.core.pipeline.doubt_reasons`)."""

    def __init__(self) -> None:
        self.t_parts: list[np.ndarray] = []
        self.q_parts: list[np.ndarray] = []
        self.doubtful: list[tuple[np.ndarray, np.ndarray]] = []
        #: The reasons of the newest sample (0: none).
        self.latest_reasons = 0

    def add(self, t: np.ndarray, q: np.ndarray, reasons: np.ndarray | None = None) -> None:
        good = np.isfinite(t) & np.all(np.isfinite(q), axis=1)
        if np.any(good):
            self.t_parts.append(t[good])
            self.q_parts.append(q[good])
        if reasons is not None and np.any(reasons):
            self.doubtful.append((t[reasons != 0], reasons[reasons != 0]))
        if t.shape[0]:
            self.latest_reasons = int(reasons[-1]) if reasons is not None else 0

    def doubt_between(self, start_s: float, end_s: float) -> int:
        """The reasons of the samples from ``start_s`` to ``end_s`` (s), combined (0: none)."""
        found = 0
        for t, reasons in self.doubtful:
            inside = (t >= start_s) & (t <= end_s)
            if np.any(inside):
                found |= int(np.bitwise_or.reduce(reasons[inside]))
        return found

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.t_parts:
            return np.zeros(0), np.zeros((0, 4))
        if len(self.t_parts) > 1:
            self.t_parts, self.q_parts = [np.concatenate(self.t_parts)], [np.concatenate(self.q_parts)]
        return self.t_parts[0], self.q_parts[0]

    def since(self, t0: float) -> np.ndarray:
        t, q = self.arrays()
        return q[np.searchsorted(t, t0):]


class _Fields:
    """Growing accelerometer and raw magnetometer samples of one sensor: t (N,), acc and mag
    (N, 3), rows with both channels finite."""

    def __init__(self) -> None:
        self.parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def add(self, t: np.ndarray, acc: np.ndarray | None, mag: np.ndarray | None) -> None:
        if acc is None or mag is None:
            return
        good = np.isfinite(t) & np.all(np.isfinite(acc), axis=1) & np.all(np.isfinite(mag), axis=1)
        if np.any(good):
            self.parts.append((t[good], acc[good], mag[good]))

    def window(self, start_s: float, end_s: float) -> tuple[np.ndarray, np.ndarray]:
        """acc and mag (K, 3) of the samples within ``[start_s, end_s]``."""
        if not self.parts:
            return np.zeros((0, 3)), np.zeros((0, 3))
        t = np.concatenate([p[0] for p in self.parts])
        inside = (t >= start_s) & (t <= end_s)
        return (np.concatenate([p[1] for p in self.parts])[inside],
                np.concatenate([p[2] for p in self.parts])[inside])


def _spread_deg(q: np.ndarray) -> float:
    """Largest angle (deg) of the rows of ``q`` (K, 4) from their mean (0 for < 2 rows)."""
    if q.shape[0] < 2:
        return 0.0
    mean = rot.average(q)
    return float(np.degrees(np.max(rot.angle_between(mean, q))))


class BodycalProcedure:
    """Guided N-pose/T-pose calibration, or standing still then walking (``method``, one of
    :data:`METHODS`).

    ``feed``: the sample source. ``mapping``: segment → sensor id (checked). ``arms``:
    ``"both"``, ``"right"`` or ``"left"`` (which arm(s) do the T-pose; not used by the
    functional method). ``height_m``: the subject's height (m), used for the skeleton shown with
    the result.
    """

    def __init__(
        self,
        feed: CalibrationFeed,
        mapping: Mapping[str, str],
        arms: str = "both",
        height_m: float = 1.75,
        settings: BodycalProcedureSettings = BodycalProcedureSettings(),
        method: str = "npose-tpose",
    ) -> None:
        if arms not in ARMS:
            raise ValueError(f"arms must be one of {', '.join(ARMS)}, got {arms!r}")
        if method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
        if not (math.isfinite(height_m) and 0.5 <= height_m <= 2.5):
            raise ValueError(f"subject height must be 0.5..2.5 m, got {height_m}")
        self.mapping = check_mapping(mapping, list(feed.sensor_ids))
        sides = () if method == "functional" else ("left", "right") if arms == "both" else (arms,)
        self.arm_sensors: dict[str, str] = {}
        for side in sides:
            segment = next((s for s in ARM_SEGMENTS[side] if s in self.mapping), None)
            if segment is None:
                raise ValueError(f"the {side} arm has no sensor in the mapping (map upper_arm_{side[0]})")
            self.arm_sensors[side] = self.mapping[segment]
        self.feed = feed
        self.arms = arms
        self.method = method
        self.height_m = float(height_m)
        self.settings = settings
        self.phase = "ready"
        self.calibration: BodyCalibration | None = None
        self.refusal: str | None = None
        #: ``status(BodycalStatus)`` after every :meth:`step`
        self.events = EmitterGroup("status")
        self._sensors = tuple(dict.fromkeys(self.mapping.values()))
        self._reset()

    def _reset(self) -> None:
        self._tracks = {s: _Track() for s in self._sensors}
        self._fields = {s: _Fields() for s in self._sensors}
        self.npose_static: dict[str, np.ndarray] = {}
        self._now: float | None = None
        self._page_start: float | None = None
        self._window_start: float | None = None
        self._restarts = 0
        self._message = ""
        self._worst_motion: tuple[str, float] = ("", 0.0)
        self._settling = ""
        self.windows: dict[str, tuple[float, float]] = {}
        self.npose_mean: dict[str, np.ndarray] = {}
        self.calibration = None
        self.refusal = None

    # -- driving -----------------------------------------------------------------------------
    def start(self) -> None:
        """Start (or restart) with the N-pose page."""
        self._reset()
        self.feed.read()  # older samples do not belong to this calibration
        self._enter("npose")

    redo = start

    def _enter(self, pose: str) -> None:
        self.phase = pose
        self._page_start = None
        self._window_start = None
        self._restarts = 0
        self._worst_motion = ("", 0.0)
        self._settling = ""
        self.feed.instruct(self._instruction_of(pose))
        self._message = self.instruction(pose)

    def _instruction_of(self, pose: str) -> Instruction:
        if pose == "movement":
            return instructions.walk()
        return instructions.npose() if pose == "npose" else instructions.tpose(self.arms)

    def instruction(self, pose: str) -> str:
        """The instruction of the ``"npose"``, ``"tpose"`` or ``"movement"`` page."""
        return self._instruction_of(pose).text

    def step(self) -> BodycalStatus:
        """Pull new samples and advance the capture."""
        if self.phase in ("npose", "tpose", "movement"):
            for sensor_id, block in self.feed.read().items():
                if sensor_id in self._tracks and block.q_world_from_sensor is not None and block.t_s.shape[0]:
                    reasons = (block.extra or {}).get(DOUBT_EXTRA)
                    self._tracks[sensor_id].add(block.t_s, block.q_world_from_sensor, reasons)
                    if self.phase == "npose":
                        self._fields[sensor_id].add(block.t_s, block.acc, block.mag_uT)
                    self._now = max(self._now if self._now is not None else -math.inf, float(block.t_s[-1]))
            if self._now is not None:
                if self._page_start is None:
                    self._page_start = self._now
                self._advance_capture()
        status = self.status()
        self.events.status.emit(status)
        return status

    def _meter(self) -> tuple[float, str]:
        """Largest recent turn (deg) of any sensor over the meter window, and that sensor."""
        t0 = self._now - self.settings.meter_window_s
        worst = (0.0, "")
        for sensor_id, track in self._tracks.items():
            q = track.since(t0)
            if q.shape[0] == 0:
                return math.nan, sensor_id
            worst = max(worst, (_spread_deg(q), sensor_id))
        return worst

    def _worn(self, sensor_id: str) -> str:
        """The sensor in words, where it is worn: "left thigh sensor (S07)"."""
        segment = next((seg for seg, sid in self.mapping.items() if sid == sensor_id), None)
        name = sensor_name(segment, sensor_id)
        return name[:1].lower() + name[1:]

    def _settling_sensor(self) -> str:
        """The first sensor whose newest orientation carries a :data:`TRANSIENT_DOUBTS` reason ("" if none)."""
        return next((sensor_id for sensor_id in self._sensors
                     if self._tracks[sensor_id].latest_reasons & TRANSIENT_DOUBTS), "")

    def _arms_raised(self) -> bool:
        for sensor_id in self.arm_sensors.values():
            t, q = self._tracks[sensor_id].arrays()
            if q.shape[0] == 0:
                return False
            angle = math.degrees(float(rot.angle_between(self.npose_mean[sensor_id], q[-1])))
            if angle < self.settings.raise_min_deg:
                return False
        return True

    def _advance_capture(self) -> None:
        s = self.settings
        pose = self.phase
        if pose == "movement":
            if self._now - self.windows["npose"][1] >= s.movement_s:
                self._compute()
            return
        if self._window_start is None:
            meter, sensor = self._meter()
            ready = math.isfinite(meter) and meter <= s.still_limit_deg
            if pose == "tpose" and not self._arms_raised():
                ready = False
            elif not ready and math.isfinite(meter):
                self._worst_motion = max(self._worst_motion, (sensor, meter), key=lambda x: x[1])
            elif ready and pose == "npose" and (settling := self._settling_sensor()):
                ready = False
                self._settling = settling
                self._message = (f"Keep standing still: the {self._worn(settling)}'s orientation is still "
                                 f"settling (it takes a few seconds after a magnetometer calibration)")
            if ready:
                self._window_start = self._now
        else:
            worst_sensor, worst = "", 0.0
            for sensor_id, track in self._tracks.items():
                spread = _spread_deg(track.since(self._window_start))
                if spread > worst:
                    worst_sensor, worst = sensor_id, spread
            if worst > s.still_limit_deg:
                self._restarts += 1
                self._worst_motion = max(self._worst_motion, (worst_sensor, worst), key=lambda x: x[1])
                self._message = (f"Movement detected: sensor {worst_sensor} turned {worst:.1f}°. "
                                 f"Hold still — the capture restarts")
                self._window_start = None
            elif self._now - self._window_start >= s.hold_s:
                self._captured(pose, (self._window_start, self._now))
                return
        if self._window_start is None and self._now - self._page_start > s.pose_timeout_s:
            name = "N-pose" if pose == "npose" else "T-pose"
            sensor, angle = self._worst_motion
            if pose == "npose" and self._settling and self._settling_sensor():
                reason = (f"the {self._worn(self._settling)}'s orientation did not settle within {s.pose_timeout_s:.0f} s "
                          f"of standing still; check its magnetometer calibration and redo the calibration")
            elif pose == "tpose" and not self._arms_raised():
                reason = (f"the arm(s) were not raised sideways within {s.pose_timeout_s:.0f} s: raise "
                          f"{'both arms' if self.arms == 'both' else 'the ' + self.arms + ' arm'} to shoulder height")
            else:
                moved = f" (sensor {sensor} turned up to {angle:.1f}°)" if sensor else ""
                reason = (f"the subject kept moving during the {name}{moved}: no {s.hold_s:g} s still "
                          f"window in {s.pose_timeout_s:.0f} s; stand still and redo the calibration")
            self._refuse(reason)

    def _captured(self, pose: str, window: tuple[float, float]) -> None:
        self.windows[pose] = window
        if pose == "npose":
            for sensor_id, track in self._tracks.items():
                t, q = track.arrays()
                part = q[(t >= window[0]) & (t <= window[1])]
                self.npose_mean[sensor_id] = rot.average(part)
                acc, mag = self._fields[sensor_id].window(*window)
                if acc.shape[0]:
                    try:
                        static = self.feed.static_orientation(sensor_id, acc, mag)
                    except ValueError:
                        static = None  # a vertical or disturbed field: the filter's mean stays
                    if static is not None:
                        self.npose_static[sensor_id] = static
            self._fields = {s: _Fields() for s in self._sensors}
            self._enter("movement" if self.method == "functional" else "tpose")
        else:
            self._compute()

    def _refuse(self, reason: str) -> None:
        self.refusal = reason
        self.phase = "refused"
        self._message = f"Calibration refused: {reason}"
        self.feed.instruct(instructions.npose())

    def _common_time_base(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        reference = max(self._sensors, key=lambda s: self._tracks[s].arrays()[0].shape[0])
        t_ref = self._tracks[reference].arrays()[0]
        start = self.windows["npose"][0]
        t_ref = t_ref[t_ref >= start]
        q = {}
        for sensor_id in self._sensors:
            t, qs = self._tracks[sensor_id].arrays()
            index = np.clip(np.searchsorted(t, t_ref), 1, t.shape[0] - 1)
            nearer_left = (t_ref - t[index - 1]) <= (t[index] - t_ref)
            q[sensor_id] = qs[np.where(nearer_left, index - 1, index)]
        return t_ref, q

    def _compute(self) -> None:
        t, q = self._common_time_base()
        still = self.windows["npose"]
        try:
            if self.method == "functional":
                # the movement from the first sample after the still window (they must not overlap)
                after = t[t > still[1]]
                if after.shape[0] < 2:
                    raise CalibrationRefused("no movement was recorded after standing still")
                self.windows["movement"] = (float(after[0]), float(after[-1]))
                calibration = calibrate_functional(t, q, self.mapping, still, self.windows["movement"],
                                                   still_orientations=self.npose_static)
            else:
                calibration = calibrate_npose_tpose(
                    t, q, self.mapping, still, self.windows["tpose"],
                    arms=self.arms, settings=self.settings.engine, npose_orientations=self.npose_static,
                )
        except CalibrationRefused as refusal:
            self._refuse(refusal.reason)
            return
        start, end = self.windows["npose"][0], self.windows["movement" if self.method == "functional" else "tpose"][1]
        doubtful = {sensor_id: describe(bits) for sensor_id in self.mapping.values()
                    if sensor_id in self._tracks and (bits := self._tracks[sensor_id].doubt_between(start, end))}
        calibration = with_doubtful_sensors(calibration, doubtful)
        # It holds with the magnetometer calibrations its orientations were computed with.
        self.calibration = with_magnetometers(calibration, self.feed.magnetometer_calibrations(),
                                              origin="made live (standing still, then walking)"
                                              if self.method == "functional" else "made live (N-pose and T-pose)")
        self.phase = "result"
        self._message = f"Calibration {self.calibration.quality.verdict}: check the figure and accept"
        self.feed.instruct(instructions.npose())

    # -- views -------------------------------------------------------------------------------
    def status(self) -> BodycalStatus:
        """The current :class:`BodycalStatus`."""
        meter, still, capturing, countdown = math.nan, False, False, None
        pose = self.phase if self.phase in ("npose", "tpose", "movement") else None
        if pose == "movement" and self._now is not None:
            left = self.settings.movement_s - (self._now - self.windows["npose"][1])
            return BodycalStatus(self.phase, pose, math.nan, False, True, max(left, 0.0), self._message, 0)
        if pose is not None and self._now is not None:
            meter, _ = self._meter()
            still = math.isfinite(meter) and meter <= self.settings.still_limit_deg
            if self._window_start is not None:
                capturing = True
                countdown = max(self.settings.hold_s - (self._now - self._window_start), 0.0)
                if not self._message.startswith("Movement"):
                    self._message = self.instruction(pose)
        settling = self._settling if pose == "npose" and not capturing and self._settling_sensor() else ""
        return BodycalStatus(self.phase, pose, meter, still, capturing, countdown, self._message, self._restarts,
                             settling)

    def npose_segment_orientations(self, model: SkeletonModel | None = None) -> dict[str, np.ndarray]:
        """The calibrated N-pose: segment → ``q_world_from_segment`` (4,) from the N-pose means
        and the result, by the pipeline's own step (:func:`mimucap.core.pipeline.segments.segments_from_sensors`);
        every segment of ``model`` (those without a sensor follow their parent), or the
        calibrated segments without one. Only in phase ``"result"``."""
        if self.calibration is None:
            raise ValueError("no body calibration result yet")
        if model is None:
            return segment_orientations(self.calibration, self.npose_mean)
        return segments_from_sensors(model, self.npose_mean, self.calibration, {}) or {}

    def quality_figures(self) -> list[tuple[str, str]]:
        """(label, value) pairs for the result page: arm raise/rotation angles, axis tilt,
        left/right agreement, stillness; after the functional method, how well the movement
        defined each axis (its verdict and why, in clinical words)."""
        if self.calibration is None:
            return []
        quality = self.calibration.quality
        rows = [(axis.name, f"{axis.verdict}: {axis.detail}") for axis in getattr(quality, "axes", ())]
        for arm in quality.arms:
            rows.append((f"{arm.side} arm raised", f"{arm.raise_angle_deg:.0f}° (about 90° expected)"))
            rows.append((f"{arm.side} arm rotation", f"{arm.rotation_angle_deg:.0f}°"))
            rows.append((f"{arm.side} arm axis tilt", f"{arm.axis_tilt_deg:.1f}° from horizontal"))
        if quality.left_right_disagreement_deg is not None:
            rows.append(("left/right agreement", f"{quality.left_right_disagreement_deg:.1f}° apart"))
        if quality.stillness:
            worst = max(quality.stillness, key=lambda s: s.max_deviation_deg)
            rows.append(("stillness", f"largest sway {worst.max_deviation_deg:.1f}° ({worst.sensor}, {worst.pose})"))
        return rows
