"""Online guidance for the single-axis magnetometer-calibration protocol.

The best protocol of Choe, Zhao, Qiu, So ("Study of calibration method of low-cost MEMS
magnetometer") turns the sensor one full turn about each of its three axes. A
:class:`SingleAxisGuide` is fed blocks of gyroscope samples (rad/s, sensor frame, with their
times ``t_s`` in s) and optionally accelerometer samples (specific force, m/s², sensor frame:
it points up at rest). It tells which sensor axis is being turned, how many degrees have
been swept about each axis, whether that axis is roughly horizontal (the best case: the
large vertical part of the field then sweeps a full circle), the progress per axis, and a
message for a wizard ("x done, now turn about y"); ``done`` becomes true once every axis has
swept at least ``full_turn_deg``.

How (settings in :class:`GuidanceSettings`):

* The gyroscope bias is tracked while the sensor is still by a first-order filter; it starts
  at the given bias (default zero). Real MEMS gyros are several °/s off (4.5 °/s on the
  sunsided MPU-6050), which would otherwise add tens of degrees per turn. Stillness is judged
  on whole windows of ``still_min_s``: every sample's ``|ω − bias|`` below ``still_rate_dps``
  (and ``|acc|`` near gravity) *and* each axis's standard deviation over the window below
  ``still_std_dps``, with the means of its two halves within half of that. The second test
  matters for a sensor held in the hand: between turns the hand sways it by a few degrees at a
  few °/s, slowly enough to pass the rate test, and a turn starts with a slow ramp; a reading
  that only holds a bias is constant up to the sensor's noise (0.13 °/s per axis on that
  MPU-6050), the sway and the ramp are not (a moving-variance stillness test, as compared by
  Skog, Händel, Nilsson and Rantakokko, "Zero-velocity detection—An algorithm evaluation"). A
  bias learnt from a sway of 4 °/s would be subtracted through the next 5-s turn and lose 20°
  of it. Only a window found still moves the estimate, by its mean, so the start of a turn
  never does.
* A sample counts as a turn about axis ``i`` when the bias-corrected rate is at least
  ``min_rate_dps`` and its ``i`` component carries at least ``dominance`` of it (the rotation
  axis is within ``acos(dominance)`` of the sensor axis). It adds the whole angle turned
  (rate × dt, signed by the ``i`` component), not just its ``i`` component: a person turns
  about roughly the axis, and a full turn about an axis 25° off still carries the field round
  a whole cone for the ellipsoid fit, where its ``i`` component would count only 326°.
* A turn starts and ends slowly. Once a sample reaches ``min_rate_dps``, the slow samples
  about the same axis just before it (down to ``still_rate_dps``, below which the sensor may
  be still) count too, and so do those after it until the rate falls that low again: a
  smooth full turn in 15 s would otherwise lose 15° at each end and never reach 330°.
* The swept angle of an axis is the range (max − min) of the running angle about it: turning
  back and forth over the same sector does not count twice, and a full circle in either
  direction counts once.
* The axis is horizontal when its angle to the accelerometer's up direction is within
  ``horizontal_max_elevation_deg`` of 90°; per axis the guide reports the fraction of turning
  time spent horizontal.

Feeding the samples in blocks gives exactly the result of one call with all of them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

AXIS_NAMES = ("x", "y", "z")
STANDARD_GRAVITY_MPS2 = 9.80665


@dataclass(frozen=True)
class GuidanceSettings:
    """Settings of :class:`SingleAxisGuide` (defaults in brackets).

    full_turn_deg: swept angle that completes an axis [330].
    min_rate_dps: slower motion is not a turn [15 °/s].
    dominance: share of the rate the turned axis must carry (cosine of the largest angle
        between rotation axis and sensor axis) [0.85, i.e. within 32°].
    still_rate_dps: below this bias-corrected rate the sensor may be still [8 °/s].
    still_std_dps: a still window's gyroscope standard deviation, per axis, stays below this
        (a few times a MEMS gyro's noise, well below a hand's sway), and the means of its
        halves differ by less than half of it [0.5 °/s].
    still_min_s: length of the still windows that update the bias [0.5 s].
    bias_time_constant_s: time constant of the bias filter while still [1.0 s].
    still_acc_tolerance: with an accelerometer, stillness also needs ``|acc|`` within this
        fraction of standard gravity [0.05].
    horizontal_max_elevation_deg: an axis at most this far above/below the horizontal plane
        counts as horizontal [30°].
    max_gap_s: a time step longer than this (a gap in the stream) is not integrated [0.25 s].
    current_axis_hold_s: the axis being turned is reported until this long after its last
        turning sample [1.0 s].
    """

    full_turn_deg: float = 330.0
    min_rate_dps: float = 15.0
    dominance: float = 0.85
    still_rate_dps: float = 8.0
    still_std_dps: float = 0.5
    still_min_s: float = 0.5
    bias_time_constant_s: float = 1.0
    still_acc_tolerance: float = 0.05
    horizontal_max_elevation_deg: float = 30.0
    max_gap_s: float = 0.25
    current_axis_hold_s: float = 1.0

    def __post_init__(self) -> None:
        positive = (
            "full_turn_deg", "min_rate_dps", "still_rate_dps", "still_std_dps", "still_min_s",
            "bias_time_constant_s", "still_acc_tolerance", "horizontal_max_elevation_deg",
            "max_gap_s", "current_axis_hold_s",
        )
        for name in positive:
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"guidance setting {name} must be a positive number, got {value}")
        if not 0.5 <= self.dominance < 1.0:
            raise ValueError(f"guidance setting dominance must be in [0.5, 1), got {self.dominance}")


@dataclass(frozen=True)
class AxisProgress:
    """Progress of one sensor axis.

    axis: "x", "y" or "z". swept_deg: angle range covered about it (≥ 0). progress: swept
    over the full-turn angle, capped at 1. done: the axis has its full turn. turning_s: time
    spent turning about it. horizontal_fraction: share of that time with the axis roughly
    horizontal, ``None`` without accelerometer samples or before any turn.
    """

    axis: str
    swept_deg: float
    progress: float
    done: bool
    turning_s: float
    horizontal_fraction: float | None


@dataclass(frozen=True)
class GuidanceState:
    """Snapshot of the guide: per-axis progress, the axis turned now (or ``None``), whether it
    is roughly horizontal now (``None`` if unknown), ``done``, the gyroscope bias estimate
    (3,) rad/s and a message for the user."""

    axes: tuple[AxisProgress, AxisProgress, AxisProgress]
    current_axis: str | None
    current_axis_horizontal: bool | None
    done: bool
    gyro_bias_rad_s: np.ndarray
    message: str

    def axis(self, name: str) -> AxisProgress:
        """Progress of axis ``"x"``, ``"y"`` or ``"z"``."""
        return self.axes[AXIS_NAMES.index(name)]


class SingleAxisGuide:
    """Tracks the single-axis calibration protocol from gyroscope (and accelerometer) blocks.

    ``update(t_s (N,), gyr_rad_s (N, 3), acc_mps2 (N, 3) | None)`` continues from the
    previous block and returns the :class:`GuidanceState`; :attr:`state` gives it at any time.
    """

    def __init__(
        self, settings: GuidanceSettings = GuidanceSettings(), gyro_bias_rad_s: ArrayLike | None = None
    ) -> None:
        self.settings = settings
        bias = np.zeros(3) if gyro_bias_rad_s is None else np.asarray(gyro_bias_rad_s, dtype=np.float64)
        if bias.shape != (3,) or not np.all(np.isfinite(bias)):
            raise ValueError("gyro_bias_rad_s must be 3 finite numbers (rad/s)")
        self._bias = [float(v) for v in bias]
        self._last_t: float | None = None
        self._window_reset()
        self._angle = [0.0, 0.0, 0.0]
        self._low = [0.0, 0.0, 0.0]
        self._high = [0.0, 0.0, 0.0]
        self._turning_s = [0.0, 0.0, 0.0]
        self._horizontal_s = [0.0, 0.0, 0.0]
        self._acc_seen = False
        self._current = -1
        # A turn in progress (axis of the last sample at or above min_rate, until the rate falls
        # to where the sensor may be still) and the slow motion about one axis that may be the
        # start of the next turn (axis, angle in rad).
        self._turn_axis = -1
        self._ramp_axis = -1
        self._ramp_angle = 0.0
        self._current_t = -math.inf
        self._current_horizontal: bool | None = None

    def update(self, t_s: ArrayLike, gyr_rad_s: ArrayLike, acc_mps2: ArrayLike | None = None) -> GuidanceState:
        """Feed one block of samples; returns the state after it."""
        t = np.asarray(t_s, dtype=np.float64).reshape(-1)
        gyr = np.asarray(gyr_rad_s, dtype=np.float64)
        if gyr.shape != (len(t), 3):
            raise ValueError(f"gyroscope block must have shape ({len(t)}, 3), got {gyr.shape}")
        acc = None
        if acc_mps2 is not None:
            acc = np.asarray(acc_mps2, dtype=np.float64)
            if acc.shape != (len(t), 3):
                raise ValueError(f"accelerometer block must have shape ({len(t)}, 3), got {acc.shape}")
        s = self.settings
        deg = math.pi / 180.0
        min_rate = s.min_rate_dps * deg
        still_rate = s.still_rate_dps * deg
        still_var = (s.still_std_dps * deg) ** 2
        sin_horizontal = math.sin(s.horizontal_max_elevation_deg * deg)
        bias = self._bias
        for k in range(len(t)):
            tk = float(t[k])
            gx, gy, gz = float(gyr[k, 0]), float(gyr[k, 1]), float(gyr[k, 2])
            if not (math.isfinite(tk) and math.isfinite(gx) and math.isfinite(gy) and math.isfinite(gz)):
                continue
            up = None
            acc_ok = True
            if acc is not None:
                ax, ay, az = float(acc[k, 0]), float(acc[k, 1]), float(acc[k, 2])
                norm = math.sqrt(ax * ax + ay * ay + az * az)
                if math.isfinite(norm) and norm > 0:
                    up = (ax / norm, ay / norm, az / norm)
                    self._acc_seen = True
                    acc_ok = abs(norm - STANDARD_GRAVITY_MPS2) <= s.still_acc_tolerance * STANDARD_GRAVITY_MPS2
            last = self._last_t
            self._last_t = tk
            if last is None:
                continue
            dt = tk - last
            if not 0.0 < dt <= s.max_gap_s:
                self._window_reset()
                self._turn_axis = self._ramp_axis = -1
                continue
            wx, wy, wz = gx - bias[0], gy - bias[1], gz - bias[2]
            rate = math.sqrt(wx * wx + wy * wy + wz * wz)
            if rate < still_rate and acc_ok:
                self._window_add(dt, wx, wy, wz)
                if self._window_s >= s.still_min_s:
                    self._window_close(still_var)
            else:
                self._window_reset()
            w = (wx, wy, wz)
            axis = max(range(3), key=lambda i: abs(w[i]))
            if rate < still_rate or abs(w[axis]) < s.dominance * rate:
                # The sensor may be still, or turns about no one axis: a turn is over.
                self._turn_axis = self._ramp_axis = -1
                continue
            step = math.copysign(rate, w[axis]) * dt
            if rate < min_rate:
                # A turn's slow start or end: counted once the turn about this axis is under
                # way (the end) or gets under way (the start, held back until then).
                if self._ramp_axis != axis:
                    self._ramp_axis, self._ramp_angle = axis, 0.0
                if self._turn_axis == axis:
                    self._add_angle(axis, step)
                else:
                    self._ramp_angle += step
                continue
            if self._ramp_axis == axis and self._turn_axis != axis:
                self._add_angle(axis, self._ramp_angle)
            self._ramp_axis, self._ramp_angle = axis, 0.0
            self._turn_axis = axis
            self._add_angle(axis, step)
            self._turning_s[axis] += dt
            self._current = axis
            self._current_t = tk
            if up is not None:
                horizontal = abs(up[axis]) <= sin_horizontal
                self._current_horizontal = horizontal
                if horizontal:
                    self._horizontal_s[axis] += dt
            else:
                self._current_horizontal = None
        return self.state

    def _add_angle(self, axis: int, step: float) -> None:
        """Advance the running angle (rad) about ``axis`` by ``step`` and its range."""
        angle = self._angle[axis] + step
        self._angle[axis] = angle
        self._low[axis] = min(self._low[axis], angle)
        self._high[axis] = max(self._high[axis], angle)

    def _window_reset(self) -> None:
        """Start a new stillness window (sums of the bias-corrected rates, rad/s)."""
        self._window_s = 0.0
        self._window_n = 0
        self._window_sum = [0.0, 0.0, 0.0]
        self._window_sq = [0.0, 0.0, 0.0]
        self._window_half = None  # (count, sums) of the first half of the window

    def _window_add(self, dt: float, wx: float, wy: float, wz: float) -> None:
        if self._window_half is None and self._window_s >= 0.5 * self.settings.still_min_s:
            self._window_half = (self._window_n, list(self._window_sum))
        self._window_s += dt
        self._window_n += 1
        for i, w in enumerate((wx, wy, wz)):
            self._window_sum[i] += w
            self._window_sq[i] += w * w

    def _window_close(self, still_var: float) -> None:
        """A full window: if every axis varied no more than noise, move the bias towards the
        window's mean rate (first-order filter, time constant ``bias_time_constant_s``).

        Varied no more than noise: the standard deviation is below ``still_std_dps`` and the
        means of the window's two halves differ by less than half of it. The second test
        catches the start of a slow turn, whose rate climbs too smoothly for the first (over
        0.5 s a ramp of 2 °/s² has a standard deviation of 0.29 °/s, but halves 0.5 °/s apart).
        """
        n = self._window_n
        means = [v / n for v in self._window_sum]
        # The sums are of rates already corrected by the current bias, so the means are small
        # and the variance from sums loses no precision worth speaking of.
        still = all(self._window_sq[i] / n - means[i] * means[i] <= still_var for i in range(3))
        if still and self._window_half is not None and 0 < self._window_half[0] < n:
            n1, sums1 = self._window_half
            limit = 0.5 * math.sqrt(still_var)
            still = all(abs((self._window_sum[i] - sums1[i]) / (n - n1) - sums1[i] / n1) <= limit for i in range(3))
        if still:
            gain = min(1.0, self._window_s / self.settings.bias_time_constant_s)
            for i in range(3):
                self._bias[i] += gain * means[i]
        self._window_reset()

    @property
    def state(self) -> GuidanceState:
        """The current :class:`GuidanceState`."""
        s = self.settings
        axes = []
        for i, name in enumerate(AXIS_NAMES):
            swept = math.degrees(self._high[i] - self._low[i])
            horizontal = None
            if self._acc_seen and self._turning_s[i] > 0:
                horizontal = self._horizontal_s[i] / self._turning_s[i]
            axes.append(
                AxisProgress(
                    axis=name,
                    swept_deg=swept,
                    progress=min(1.0, swept / s.full_turn_deg),
                    done=swept >= s.full_turn_deg,
                    turning_s=self._turning_s[i],
                    horizontal_fraction=horizontal,
                )
            )
        current = None
        horizontal_now = None
        if self._current >= 0 and self._last_t is not None:
            if self._last_t - self._current_t <= s.current_axis_hold_s:
                current = AXIS_NAMES[self._current]
                horizontal_now = self._current_horizontal
        done = all(a.done for a in axes)
        return GuidanceState(
            axes=(axes[0], axes[1], axes[2]),
            current_axis=current,
            current_axis_horizontal=horizontal_now,
            done=done,
            gyro_bias_rad_s=np.array(self._bias),
            message=_message(axes, current, horizontal_now, s.full_turn_deg),
        )


def _message(axes: list[AxisProgress], current: str | None, horizontal: bool | None, full: float) -> str:
    done_names = [a.axis for a in axes if a.done]
    if len(done_names) == 3:
        return "x, y and z done: the calibration can be computed"
    pending = next(a.axis for a in axes if not a.done)
    if current is not None:
        progress = axes[AXIS_NAMES.index(current)]
        if not progress.done:
            text = f"turning about {current}: {progress.swept_deg:.0f}° of {full:.0f}°"
            if horizontal is False:
                text += f"; hold the {current} axis level"
            return text
    if done_names:
        return f"{', '.join(done_names)} done, now turn about {pending}"
    return f"turn the sensor one full turn about its {pending} axis"


def guide_single_axis(
    t_s: ArrayLike,
    gyr_rad_s: ArrayLike,
    acc_mps2: ArrayLike | None = None,
    settings: GuidanceSettings = GuidanceSettings(),
    gyro_bias_rad_s: ArrayLike | None = None,
) -> GuidanceState:
    """Offline form: the state after feeding a whole recording to a fresh guide."""
    return SingleAxisGuide(settings, gyro_bias_rad_s).update(t_s, gyr_rad_s, acc_mps2)
