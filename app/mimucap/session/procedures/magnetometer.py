"""The guided magnetometer calibration of one or several sensors held together (no Qt).

:class:`MagcalProcedure` is a state machine driven by :meth:`MagcalProcedure.step` (one call
each time the feed tells ``arrived``, or in a loop in tests): it pulls samples from a feed
(:mod:`mimucap.session.sources.calibration_feed`), tracks the protocol and, when the protocol is
complete, fits every selected sensor (:func:`mimucap.core.magcal.calibrate.calibrate`). Each step tells
its :class:`MagcalStatus` through ``events.status`` (what the wizard shows).

Protocols (:data:`PROTOCOLS`):

* ``"single_axis"`` (default; the best protocol of Choe et al., "Study of calibration method of
  low-cost MEMS magnetometer"): one full turn about each sensor axis. Every
  selected sensor has its own :class:`~mimucap.core.magcal.guidance.SingleAxisGuide`; the
  progress of an axis is the smallest over the sensors (they are held together, so they agree
  up to how they sit in the hand); the axis asked for is the first one not yet done (x, y,
  z), so the page advances by itself, and the recording finishes when all three are done.
* ``"figure8"`` and ``"free"``: no axis guidance; after at least ``min_duration_s`` the
  recording finishes once a preliminary fit of every sensor is good, or once the coverage has
  stopped improving for ``stall_s`` (the result page then says what is missing).

Either way it stops after ``max_duration_s``, and :meth:`finish_now` computes with what was
recorded. Phases: ``"ready"`` → ``"recording"`` → ``"result"`` (``redo`` goes back to
``"ready"``). The instructions (turn these sensors; put them back on) go to the feed
(:mod:`mimucap.session.procedures.instructions`): the person reads them, the simulated subject does them.

Results (:class:`SensorOutcome`) carry the fit, its quality, the verdict and reasons in the
words of the person calibrating ("turn about y again: coverage too low"), and the sensor's
previous calibration with its age. :meth:`accept` stores the calibrations of the sensors
whose verdict is not ``fail`` in a :class:`~mimucap.io.calibration_store.CalibrationStore`, each
with the gyroscope's scale correction its turns gave (:mod:`mimucap.core.magcal.gyro_scale`;
the outcome's ``gyro`` line says it, or why none is applied).

Units: s, µT, m/s², rad/s, sensor frames.
"""

from __future__ import annotations

import datetime as _dt
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from mimucap.core.magcal.calibrate import CalibrationResult, calibrate
from mimucap.core.magcal.fit import EllipsoidFit, FitRefused, FitSettings, fit_ellipsoid
from mimucap.core.magcal.guidance import AXIS_NAMES, GuidanceSettings, GuidanceState, SingleAxisGuide
from mimucap.core.magcal.quality import QualityThresholds
from mimucap.io.calibration_store import CalibrationFileError, CalibrationStore
from mimucap.session.events import EmitterGroup
from mimucap.session.procedures import instructions
from mimucap.session.sources.calibration_feed import CalibrationFeed
from mimucap.session.views.calibration_age import age_days_since, utc_now

PROTOCOLS = ("single_axis", "figure8", "free")
#: Simulated activity performing each protocol, and its number of turns / gestures.
PHASES = ("ready", "recording", "result")


@dataclass(frozen=True)
class MagcalProcedureSettings:
    """Settings of :class:`MagcalProcedure` (defaults in brackets).

    protocol: one of :data:`PROTOCOLS` ["single_axis"]. guidance: single-axis guidance
    settings. fit, thresholds: ellipsoid fit and quality limits of the magnetometer engine.
    min_duration_s: shortest recording before a figure-8/free recording may finish [8 s].
    max_duration_s: the recording stops here whatever the progress [120 s].
    preview_interval_s: recorded seconds between two preliminary fits [1 s].
    stall_s: figure-8/free: finish when the worst coverage condition has not improved by 2 %
        for this long [6 s].
    """

    protocol: str = "single_axis"
    guidance: GuidanceSettings = GuidanceSettings()
    fit: FitSettings = FitSettings()
    thresholds: QualityThresholds = QualityThresholds()
    min_duration_s: float = 8.0
    max_duration_s: float = 120.0
    preview_interval_s: float = 1.0
    stall_s: float = 6.0

    def __post_init__(self) -> None:
        if self.protocol not in PROTOCOLS:
            raise ValueError(f"unknown calibration protocol {self.protocol!r}; use one of {', '.join(PROTOCOLS)}")
        for name in ("min_duration_s", "max_duration_s", "preview_interval_s", "stall_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"magnetometer procedure setting {name} must be a positive number of seconds")
        if self.max_duration_s < self.min_duration_s:
            raise ValueError("max_duration_s must not be shorter than min_duration_s")


@dataclass(frozen=True)
class PreviousCalibration:
    """A sensor's stored calibration: offset (3,) µT, soft iron (3, 3), field µT, date, age
    in days (None if its date is unknown), verdict."""

    offset_uT: np.ndarray
    soft_iron: np.ndarray
    field_uT: float
    created_utc: str
    age_days: float | None
    verdict: str


@dataclass(frozen=True)
class SensorOutcome:
    """Result of one sensor.

    result: the engine's :class:`CalibrationResult`, or None when the fit was refused.
    verdict: "good", "warn" or "fail" (a refused fit fails). advice: what is wrong and what to
    do, in plain words, most important first. previous: the stored calibration, if any.
    """

    sensor_id: str
    result: CalibrationResult | None
    verdict: str
    advice: tuple[str, ...]
    previous: PreviousCalibration | None

    @property
    def acceptable(self) -> bool:
        return self.result is not None and self.verdict != "fail"


@dataclass(frozen=True)
class MagcalStatus:
    """What the wizard page shows after a step.

    phase: see :data:`PHASES`. elapsed_s: recorded time. axis_progress: axis → fraction 0..1
    (single-axis protocol; the smallest over the sensors). axis_to_turn: the axis asked for
    now (None when done or without axis guidance). turning_axis: the axis being turned now
    according to the gyroscopes, or None. message: the instruction for the user.
    samples: sensor id → samples recorded.
    """

    phase: str
    elapsed_s: float
    axis_progress: dict[str, float]
    axis_to_turn: str | None
    turning_axis: str | None
    message: str
    samples: dict[str, int]


class _Recording:
    """Growing per-sensor sample arrays (t (N,), mag (N,3), acc (N,3), gyr (N,3))."""

    def __init__(self) -> None:
        self.columns: list[list[np.ndarray]] = [[], [], [], []]
        self.count = 0

    def add(self, t: np.ndarray, mag: np.ndarray, acc: np.ndarray, gyr: np.ndarray) -> None:
        good = np.all(np.isfinite(mag), axis=1) & np.isfinite(t)
        if np.any(good):
            for column, values in zip(self.columns, (t, mag, acc, gyr)):
                column.append(values[good])
            self.count += int(good.sum())

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if not self.count:
            return np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3))
        if len(self.columns[0]) > 1:
            self.columns = [[np.concatenate(column)] for column in self.columns]
        t, mag, acc, gyr = (column[0] for column in self.columns)
        return t, mag, acc, gyr


def _strip_severity(reason: str) -> str:
    for prefix in ("good: ", "warn: ", "fail: "):
        if reason.startswith(prefix):
            return reason[len(prefix):]
    return reason


def clinician_advice(
    quality_reasons: Sequence[str], guide: GuidanceState | None, refusal: str | None, full_turn_deg: float
) -> tuple[str, ...]:
    """Advice in plain words: unfinished axes first ("turn about y again: it was turned only
    40° of 330°"), then the engine's refusal or its quality reasons with what to do."""
    advice = []
    if guide is not None:
        for axis in guide.axes:
            if not axis.done:
                advice.append(
                    f"turn about {axis.axis} again: it was turned only {axis.swept_deg:.0f}° of the "
                    f"{full_turn_deg:.0f}° needed, so coverage is too low"
                )
    if refusal is not None:
        advice.append(f"no calibration could be computed: {refusal}")
    for reason in quality_reasons:
        text = _strip_severity(reason)
        if "coverage too low" in text and "about its " in text:
            axis = text.split("about its ")[1][0]
            if guide is not None and not guide.axis(axis).done:
                continue  # already said above
            text = f"turn about {axis} again: {text.split(':')[0]}"
        advice.append(text)
    return tuple(advice)


class MagcalProcedure:
    """Guided magnetometer calibration of ``sensor_ids`` (held together) from ``feed``.

    ``store``: where accepted calibrations go and previous ones come from (None: the user's
    default store). ``now``: a clock returning an aware UTC datetime (tests pass a fixed one).
    """

    def __init__(
        self,
        feed: CalibrationFeed,
        sensor_ids: Sequence[str],
        settings: MagcalProcedureSettings = MagcalProcedureSettings(),
        store: CalibrationStore | None = None,
        now: Callable[[], _dt.datetime] = utc_now,
    ) -> None:
        sensor_ids = tuple(dict.fromkeys(sensor_ids))
        if not sensor_ids:
            raise ValueError("choose at least one sensor to calibrate")
        unknown = [s for s in sensor_ids if s not in feed.sensor_ids]
        if unknown:
            raise ValueError(f"unknown sensor(s) {', '.join(unknown)}; the suit has {', '.join(feed.sensor_ids)}")
        self.feed = feed
        self.sensor_ids = sensor_ids
        self.settings = settings
        self.store = store if store is not None else CalibrationStore()
        self._now = now
        self.phase = "ready"
        self.outcomes: dict[str, SensorOutcome] = {}
        #: ``status(MagcalStatus)`` after every :meth:`step`
        self.events = EmitterGroup("status")
        self._reset()

    # -- state -------------------------------------------------------------------------------
    def _reset(self) -> None:
        self._recordings = {s: _Recording() for s in self.sensor_ids}
        self._guides = {s: SingleAxisGuide(self.settings.guidance) for s in self.sensor_ids}
        self._start_t: float | None = None
        self._last_t: float | None = None
        self._preview: dict[str, tuple[int, EllipsoidFit | None]] = {}
        self._next_check_s = self.settings.min_duration_s
        self._best_condition = (math.inf, 0.0)  # (worst condition over sensors, when reached)
        self.outcomes = {}

    @property
    def protocol(self) -> str:
        return self.settings.protocol

    @property
    def elapsed_s(self) -> float:
        """Recorded duration (s)."""
        if self._start_t is None or self._last_t is None:
            return 0.0
        return self._last_t - self._start_t

    def samples(self, sensor_id: str) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Recorded ``t_s`` (N,), ``mag_uT`` (N, 3) and ``acc`` (N, 3) of ``sensor_id``
        (``acc`` None unless every sample has a finite one)."""
        t, mag, acc, _gyr = self._recordings[sensor_id].arrays()
        return t, mag, (acc if acc.shape[0] and np.all(np.isfinite(acc)) else None)

    def guidance(self, sensor_id: str) -> GuidanceState:
        """The single-axis guidance state of one sensor."""
        return self._guides[sensor_id].state

    # -- driving -----------------------------------------------------------------------------
    def start(self) -> None:
        """Begin recording: the subject is asked to turn the sensors by the protocol."""
        self._reset()
        self.phase = "recording"
        self.feed.instruct(instructions.turn_sensors(self.sensor_ids, self.protocol))
        self.feed.read()  # samples before the start do not belong to the calibration

    def redo(self) -> None:
        """Discard the recording and results; back to ``"ready"``."""
        self._reset()
        self.phase = "ready"

    def step(self) -> MagcalStatus:
        """Pull new samples; finishes (computes the results) when the protocol is complete."""
        if self.phase == "recording":
            for sensor_id, block in self.feed.read().items():
                if sensor_id not in self._recordings or block.t_s.shape[0] == 0:
                    continue
                if block.mag_uT is None or block.gyr is None:
                    continue  # a unit without magnetometer or gyroscope cannot be calibrated here
                acc = block.acc if block.acc is not None else np.full_like(block.mag_uT, np.nan)
                self._recordings[sensor_id].add(block.t_s, block.mag_uT, acc, block.gyr)
                self._guides[sensor_id].update(block.t_s, block.gyr, block.acc)
                if self._start_t is None:
                    self._start_t = float(block.t_s[0])
                self._last_t = max(self._last_t or -math.inf, float(block.t_s[-1]))
            if self._complete():
                self.finish_now()
        status = self.status()
        self.events.status.emit(status)
        return status

    def _complete(self) -> bool:
        elapsed = self.elapsed_s
        if elapsed >= self.settings.max_duration_s:
            return True
        if self.protocol == "single_axis":
            return all(g.state.done for g in self._guides.values())
        if elapsed < self._next_check_s:
            return False
        self._next_check_s = elapsed + self.settings.preview_interval_s
        all_good, worst = True, 0.0
        for sensor_id in self.sensor_ids:
            t, mag, acc = self.samples(sensor_id)
            try:
                result = calibrate(mag, sensor_id, acc, self.settings.fit, self.settings.thresholds)
            except FitRefused:
                all_good, worst = False, math.inf
                continue
            all_good = all_good and result.quality.verdict == "good"
            worst = max(worst, result.quality.condition)
        if all_good:
            return True
        if worst < 0.98 * self._best_condition[0]:
            self._best_condition = (worst, elapsed)
        return math.isfinite(worst) and elapsed - self._best_condition[1] >= self.settings.stall_s

    def finish_now(self) -> None:
        """Stop recording and compute every sensor's result (phase ``"result"``)."""
        if self.phase != "recording":
            raise ValueError("the magnetometer calibration is not recording")
        self.feed.instruct(instructions.put_sensors_back())
        now = self._now()
        created = now.strftime("%Y-%m-%dT%H:%M:%SZ")
        outcomes = {}
        for sensor_id in self.sensor_ids:
            t, mag, acc = self.samples(sensor_id)
            gyr = self._recordings[sensor_id].arrays()[3]
            guide = self._guides[sensor_id].state if self.protocol == "single_axis" else None
            result, refusal = None, None
            try:
                result = calibrate(mag, sensor_id, acc, self.settings.fit, self.settings.thresholds,
                                   protocol=self.protocol, created_utc=created,
                                   device_id=self.feed.device(sensor_id).device_id, t_s=t, gyr_raw_rad_s=gyr)
            except FitRefused as error:
                refusal = str(error)
            verdict = "fail" if result is None else result.quality.verdict
            if guide is not None and not guide.done:
                verdict = "fail"  # an axis was not turned: never silently accepted
            reasons = () if result is None else result.quality.reasons
            advice = clinician_advice(reasons, guide, refusal, self.settings.guidance.full_turn_deg)
            outcomes[sensor_id] = SensorOutcome(sensor_id, result, verdict, advice, self._previous(sensor_id, now))
        self.outcomes = outcomes
        self.phase = "result"

    def _previous(self, sensor_id: str, now: _dt.datetime) -> PreviousCalibration | None:
        try:
            old = self.store.lookup(sensor_id, self.feed.device(sensor_id)).calibration
        except (OSError, CalibrationFileError):
            return None
        if old is None:
            return None
        return PreviousCalibration(
            old.offset_uT, old.soft_iron, old.field_uT, old.created_utc, age_days_since(old.created_utc, now),
            str(old.quality.get("verdict", "unknown")),
        )

    def accept(self, sensor_ids: Sequence[str] | None = None) -> list[str]:
        """Store the calibrations of ``sensor_ids`` (default: every acceptable one); returns the
        ids stored. A failed or refused sensor raises ``ValueError`` naming it."""
        if self.phase != "result":
            raise ValueError("there is no magnetometer calibration result to accept")
        wanted = [s for s in self.sensor_ids if self.outcomes[s].acceptable] if sensor_ids is None else list(sensor_ids)
        for sensor_id in wanted:
            outcome = self.outcomes.get(sensor_id)
            if outcome is None:
                raise ValueError(f"sensor {sensor_id} was not calibrated in this run")
            if not outcome.acceptable:
                raise ValueError(f"sensor {sensor_id}: the calibration failed and cannot be stored; "
                                 + (outcome.advice[0] if outcome.advice else "record again"))
        for sensor_id in wanted:
            self.store.save(self.outcomes[sensor_id].result.calibration)
        return wanted

    # -- views -------------------------------------------------------------------------------
    def preview_fit(self, sensor_id: str) -> EllipsoidFit | None:
        """A preliminary fit of the samples so far (None while it cannot be fitted); cached
        until new samples arrive. During the result phase, the final fit."""
        if self.phase == "result":
            outcome = self.outcomes[sensor_id]
            return None if outcome.result is None else outcome.result.fit
        count = self._recordings[sensor_id].count
        cached = self._preview.get(sensor_id)
        if cached is not None and cached[0] == count:
            return cached[1]
        _, mag, _ = self.samples(sensor_id)
        try:
            fit = fit_ellipsoid(mag, self.settings.fit)
        except FitRefused:
            fit = None
        self._preview[sensor_id] = (count, fit)
        return fit

    def status(self) -> MagcalStatus:
        """The current :class:`MagcalStatus`."""
        counts = {s: r.count for s, r in self._recordings.items()}
        progress: dict[str, float] = {}
        axis_to_turn = turning = None
        if self.protocol == "single_axis":
            states = [g.state for g in self._guides.values()]
            for i, axis in enumerate(AXIS_NAMES):
                progress[axis] = min(s.axes[i].progress for s in states)
                if axis_to_turn is None and not all(s.axes[i].done for s in states):
                    axis_to_turn = axis
            turning = states[0].current_axis
        if self.phase == "ready":
            message = "Hold the selected sensors together and press Start"
        elif self.phase == "result":
            failed = [s for s, o in self.outcomes.items() if o.verdict == "fail"]
            message = ("Calibration done: check the results and accept" if not failed
                       else f"Calibration failed for {', '.join(failed)}: see the advice and redo")
        elif self.protocol == "single_axis":
            done = [a for a in AXIS_NAMES if progress[a] >= 1.0]
            lead = f"{', '.join(done)} done. " if done else ""
            message = (f"{lead}Turn the sensors one full turn about their {axis_to_turn} axis, keeping it level "
                       f"({progress[axis_to_turn] * 100:.0f}%)") if axis_to_turn else "All axes done"
            if turning is not None and axis_to_turn is not None and turning != axis_to_turn:
                message += f" — you are turning about {turning}"
        elif self.protocol == "figure8":
            message = "Draw slow figure-8s in the air while tilting and turning the sensors"
        else:
            message = "Turn the sensors slowly in every direction"
        return MagcalStatus(self.phase, self.elapsed_s, progress, axis_to_turn if self.phase == "recording" else None,
                            turning if self.phase == "recording" else None, message, counts)
