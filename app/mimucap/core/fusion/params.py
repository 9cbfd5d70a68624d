"""Settings of the orientation fusion filter: one frozen dataclass, units beside every field.

The defaults (:data:`DEFAULT_FUSION_PARAMS`) are one parameter set for every sensor and
every recording, not tuned per trial. The two noise terms that grow with the data
(``gyr_scale_noise_sqrt_s``, ``heading_field_error_gain``) and the smoother's own weighting of
the magnetometer (``smoother_*``) are cross-validated on the public BROAD trials (Laidig,
Caruso, Cereatti, Seel, "BROAD - A Benchmark for Robust Inertial Orientation Estimation")
leaving one trial out (``bench/bench_broad_cv.py``). A numba kernel
cannot read a dataclass, so :func:`pack_params`
flattens the settings into a float64 vector whose layout is given by the ``PI_*`` indices.

Noise figures are standard deviations. "Per sample" figures are measurement noises applied
at every sample (the filter's gain therefore depends on the sampling rate, as in any
discrete Kalman filter); "density" figures scale with the square root of the time step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

#: Gyroscope propagation methods: name -> code used by the kernels.
PROPAGATION_METHODS: dict[str, int] = {"taylor3": 0, "rk4": 1, "exact": 2}

DEG = math.pi / 180.0


@dataclass(frozen=True)
class FusionParams:
    """Noise model, disturbance handling and validity limits of the error-state EKF.

    Every field name carries its unit. Angles are radians, rates rad/s, accelerations m/s²,
    magnetic fields µT, times seconds.
    """

    #: Gyroscope propagation: ``"taylor3"`` (coning-corrected two-sample increments and a
    #: third-order exponential), ``"rk4"`` or ``"exact"`` (exponential map of one increment).
    propagation: str = "taylor3"
    #: Gyroscope noise density (rad/s/√Hz): attitude process noise ``σ²·dt``. Far above a MEMS
    #: gyroscope's white noise (0.006 °/s/√Hz in the rest samples of the BROAD trials): it
    #: stands for the errors the model leaves out (the magnetometer's lag, axis misalignment,
    #: drift in motion), so that the filter keeps following the magnetometer.
    gyr_noise_rad_s_sqrt_hz: float = 0.15 * DEG
    #: Gyroscope scale-factor and axis-misalignment noise (√s): attitude process noise
    #: ``(k·‖ω‖)²·dt`` on top of the white noise. A gyroscope whose scale or axes are off by a
    #: fraction ``ε`` turns the estimate by ``ε`` times every angle turned, so the uncertainty
    #: grows with the rotation, not with the time: after a fast turn the magnetometer and the
    #: accelerometer get the weight to pull the estimate back. 0 switches it off.
    gyr_scale_noise_sqrt_s: float = 0.0005
    #: Gyroscope bias random walk (rad/s/√s): bias process noise ``σ²·dt``.
    bias_walk_rad_s_sqrt_s: float = 0.0005 * DEG
    #: Initial standard deviations of tilt, heading (rad) and gyro bias (rad/s).
    init_tilt_std_rad: float = 5.0 * DEG
    init_heading_std_rad: float = 20.0 * DEG
    init_bias_std_rad_s: float = 0.5 * DEG
    #: Largest bias magnitude the filter accepts (rad/s); the estimate is clipped to it.
    bias_max_rad_s: float = 5.0 * DEG

    #: Local gravity (m/s²) used to judge the accelerometer norm.
    gravity_m_s2: float = 9.81
    #: Time constant (s) of the low-pass filter applied to the specific force rotated into the
    #: world frame before it is used as the gravity direction: linear accelerations of a
    #: body that stays in place average out (their integral, the velocity, stays bounded).
    acc_lowpass_tau_s: float = 1.0
    #: Accelerometer noise per sample (m/s²) of that low-passed gravity measurement.
    acc_noise_m_s2: float = 1.0
    #: Extra accelerometer noise per m/s² of ``|‖a_lp‖ − g|`` (dimensionless), ``a_lp`` the
    #: low-passed world-frame specific force: acceleration not yet averaged out down-weights
    #: the gravity correction. Off (0) by default: on the BROAD trials the world-frame
    #: low-pass alone did better (any gain tried raised the error).
    acc_deviation_gain: float = 0.0
    #: Extra accelerometer noise per rad/s of angular rate (m/s² per rad/s): centripetal
    #: acceleration of a sensor away from the rotation centre. Off (0) by default, as above.
    acc_rate_gain_m_s2_per_rad_s: float = 0.0
    #: Samples with ``|‖a‖ − g|`` above this (m/s²) give no gravity correction.
    acc_reject_m_s2: float = 50.0

    #: Heading measurement noise per sample (rad) of the tilt-compensated magnetometer.
    heading_noise_rad: float = 30.0 * DEG
    #: Extra heading noise from the field's quality (dimensionless): a sample whose field
    #: differs from the reference by ``e`` (µT; from the norm and dip deviations, a lower
    #: bound of the disturbance) may turn the horizontal field by up to ``e/‖m_h‖`` (rad),
    #: ``m_h`` its horizontal part; the heading noise standard deviation grows by this
    #: factor times that angle (root sum of squares). 0 switches it off. Chosen by
    #: leave-one-trial-out cross-validation on BROAD (``bench/bench_broad_cv.py``): every fold
    #: chose 4 or 5; the lower serves, since a higher gain trusts the heading later after a new
    #: magnetometer calibration.
    heading_field_error_gain: float = 4.0
    #: What the Rauch-Tung-Striebel smoother's forward pass (:mod:`.offline`) uses in place of
    #: ``heading_field_error_gain`` and ``mag_ref_tau_s`` (:meth:`smoother_pass`); the online
    #: filter does not read them. A field
    #: that differs from the reference (the room's field where the sensor is carried, a steel
    #: object nearby) stays wrong for seconds: its heading errors are correlated, not white. The
    #: causal filter follows such an error only in part (its heading memory lags), while the
    #: smoother, fitting every accepted sample from both sides, follows it fully; and the drift
    #: that distrusting the magnetometer costs is unbounded for the causal filter but bounded in
    #: the smoother by the trusted field before and after. So the smoother weighs a foreign
    #: field down more and holds its reference (10000 s: for a recording's length, the field
    #: where the filter started). Both chosen by leave-one-trial-out cross-validation on BROAD
    #: among the values that keep the smoother within VQF's online error on the trials
    #: ``tests/core/fusion/test_broad_scores.py`` bounds (``bench/bench_broad_cv.py``).
    smoother_heading_field_error_gain: float = 10.0
    smoother_mag_ref_tau_s: float = 10000.0
    #: What the smoother's forward pass uses as ``mag_new_field_s``; 0: it never adopts a new
    #: field (0 rather than infinity because the settings are stored with each recording as
    #: JSON, which has no infinity). A field that changed for good (a uniform disturbance, another room) is turned by
    #: an unknown angle: adopting it as the reference turns the heading by that angle, up to tens
    #: of degrees, and the smoother then carries that error back in time as well, whereas
    #: bridging the change with the gyroscope costs a drift bounded by its bias error.
    smoother_mag_new_field_s: float = 0.0
    #: Magnetic declination (rad, positive when magnetic north lies east of true north): the
    #: world y axis is true north with it, magnetic north with the default 0.
    declination_rad: float = 0.0
    #: The magnetometer is rejected when its norm differs from the reference by more than
    #: this fraction, or its dip angle by more than ``mag_dip_tol_rad``.
    mag_norm_tol: float = 0.15
    mag_dip_tol_rad: float = 12.0 * DEG
    #: After a rejection the field must agree with the reference for this long (s) before
    #: the magnetometer corrects the heading again (a disturbance rarely ends at once).
    mag_settle_s: float = 1.0
    #: Time constant (s) with which accepted samples update the reference norm and dip.
    mag_ref_tau_s: float = 30.0
    #: A new field that stays consistent (within the tolerances) for this long (s) while the
    #: old reference is rejected becomes the new reference (infinite: never).
    mag_new_field_s: float = 20.0
    #: ... provided the sensor turned meanwhile at this mean rate (rad/s) at least: a field
    #: that stays the same while the sensor turns is homogeneous (a new place), whereas a
    #: sensor resting next to a magnet must not adopt the magnet's field.
    mag_new_min_rate_rad_s: float = 20.0 * DEG
    #: A hard-iron offset that appears during the recording (a magnet or a phone fixed to the
    #: sensor) is learned from the field samples and removed (:mod:`.hard_iron`): the time
    #: constant (s) with which the fit forgets old samples (0 switches the tracking off), the
    #: least rms (µT) of the field's variation the offset must explain to be applied, the
    #: largest rms residual (µT) of a fit that counts as a constant offset, and the largest
    #: standard deviation (µT) of an offset that counts as determined.
    mag_offset_tau_s: float = 2.0
    mag_offset_min_uT: float = 3.0
    mag_offset_fit_uT: float = 2.0
    mag_offset_std_uT: float = 0.3

    #: Rest detection: deviations of gyro (rad/s) and accelerometer (m/s²) from their
    #: low-pass values, the low-pass time constant (s), the largest mean rate (rad/s) and the
    #: time (s) these must hold before the sensor counts as resting.
    rest_gyr_dev_rad_s: float = 2.0 * DEG
    rest_acc_dev_m_s2: float = 0.5
    rest_tau_s: float = 0.5
    rest_max_rate_rad_s: float = 5.0 * DEG
    rest_time_s: float = 1.5
    #: Noise per sample (rad/s) of the zero-rate bias measurement applied at rest.
    rest_bias_noise_rad_s: float = 0.5 * DEG

    #: Sample intervals above this (s) are gaps: no rotation is integrated across them and
    #: the attitude uncertainty grows by ``gap_attitude_rate_rad_s · gap``.
    max_gap_s: float = 0.5
    gap_attitude_rate_rad_s: float = 0.5
    #: Validity ranges: a sample channel outside them is skipped and counted.
    gyr_range_rad_s: float = 40.0
    acc_range_m_s2: float = 16.0 * 9.81 * 1.5
    mag_range_uT: float = 2000.0

    def __post_init__(self) -> None:
        if self.propagation not in PROPAGATION_METHODS:
            raise ValueError(
                f"unknown propagation {self.propagation!r}; choose one of "
                f"{sorted(PROPAGATION_METHODS)}"
            )
        if not (isinstance(self.declination_rad, (int, float)) and abs(self.declination_rad) <= math.pi):
            raise ValueError(f"fusion setting declination_rad must be within ±π, got {self.declination_rad!r}")
        for field in fields(self):
            if field.name in ("propagation", "declination_rad"):
                continue
            value = getattr(self, field.name)
            if field.name == "mag_new_field_s" and value == math.inf:
                continue  # never adopt a new field (what the smoother's pass may use)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0.0):
                raise ValueError(f"fusion setting {field.name} must be a finite number >= 0, got {value!r}")
        for name in ("gravity_m_s2", "heading_noise_rad", "acc_noise_m_s2", "rest_tau_s",
                     "max_gap_s", "gyr_range_rad_s", "acc_range_m_s2", "mag_range_uT",
                     "rest_bias_noise_rad_s", "mag_ref_tau_s", "smoother_mag_ref_tau_s", "mag_offset_fit_uT",
                     "mag_offset_std_uT"):
            if getattr(self, name) <= 0.0:
                raise ValueError(f"fusion setting {name} must be > 0")

    def smoother_pass(self) -> "FusionParams":
        """The settings of the smoother's forward pass: these with ``heading_field_error_gain``,
        ``mag_ref_tau_s`` and ``mag_new_field_s`` taken from their ``smoother_`` counterparts
        (``mag_new_field_s`` infinite, never, when ``smoother_mag_new_field_s`` is 0)."""
        return replace(self, heading_field_error_gain=self.smoother_heading_field_error_gain,
                       mag_ref_tau_s=self.smoother_mag_ref_tau_s,
                       mag_new_field_s=self.smoother_mag_new_field_s or math.inf)


#: The one parameter set used for every sensor and trial.
DEFAULT_FUSION_PARAMS = FusionParams()

# Layout of the packed parameter vector read by the numba kernels.
(
    PI_METHOD, PI_GYR_NOISE, PI_GYR_SCALE_NOISE, PI_BIAS_WALK, PI_INIT_TILT, PI_INIT_HEADING, PI_INIT_BIAS,
    PI_BIAS_MAX, PI_GRAVITY, PI_ACC_LP_TAU, PI_ACC_NOISE, PI_ACC_DEV_GAIN, PI_ACC_RATE_GAIN, PI_ACC_REJECT,
    PI_HEADING_NOISE, PI_HEADING_FIELD_GAIN, PI_DECLINATION, PI_MAG_NORM_TOL, PI_MAG_DIP_TOL, PI_MAG_SETTLE, PI_MAG_REF_TAU, PI_MAG_NEW_FIELD, PI_MAG_NEW_MIN_RATE,
    PI_MAG_OFFSET_TAU, PI_MAG_OFFSET_MIN, PI_MAG_OFFSET_FIT, PI_MAG_OFFSET_STD,
    PI_REST_GYR_DEV, PI_REST_ACC_DEV, PI_REST_TAU, PI_REST_MAX_RATE, PI_REST_TIME,
    PI_REST_BIAS_NOISE, PI_MAX_GAP, PI_GAP_RATE, PI_GYR_RANGE, PI_ACC_RANGE, PI_MAG_RANGE,
    PI_USE_ACC, PI_USE_MAG, PI_CORRECT, PI_COUNT,
) = range(42)


def pack_params(params: FusionParams, *, use_acc: bool = True, use_mag: bool = True,
                correct: bool = True) -> np.ndarray:
    """The settings as a float64 vector ``(PI_COUNT,)`` for the kernels.

    ``use_acc`` / ``use_mag`` switch the gravity / heading information off entirely;
    ``correct=False`` keeps them for the initial alignment only and then integrates the
    gyroscope alone (no corrections, no bias estimation).
    """
    p = np.zeros(PI_COUNT)
    p[PI_METHOD] = PROPAGATION_METHODS[params.propagation]
    p[PI_GYR_NOISE] = params.gyr_noise_rad_s_sqrt_hz
    p[PI_GYR_SCALE_NOISE] = params.gyr_scale_noise_sqrt_s
    p[PI_BIAS_WALK] = params.bias_walk_rad_s_sqrt_s
    p[PI_INIT_TILT] = params.init_tilt_std_rad
    p[PI_INIT_HEADING] = params.init_heading_std_rad
    p[PI_INIT_BIAS] = params.init_bias_std_rad_s
    p[PI_BIAS_MAX] = params.bias_max_rad_s
    p[PI_GRAVITY] = params.gravity_m_s2
    p[PI_ACC_LP_TAU] = params.acc_lowpass_tau_s
    p[PI_ACC_NOISE] = params.acc_noise_m_s2
    p[PI_ACC_DEV_GAIN] = params.acc_deviation_gain
    p[PI_ACC_RATE_GAIN] = params.acc_rate_gain_m_s2_per_rad_s
    p[PI_ACC_REJECT] = params.acc_reject_m_s2
    p[PI_HEADING_NOISE] = params.heading_noise_rad
    p[PI_HEADING_FIELD_GAIN] = params.heading_field_error_gain
    p[PI_DECLINATION] = params.declination_rad
    p[PI_MAG_NORM_TOL] = params.mag_norm_tol
    p[PI_MAG_DIP_TOL] = params.mag_dip_tol_rad
    p[PI_MAG_SETTLE] = params.mag_settle_s
    p[PI_MAG_REF_TAU] = params.mag_ref_tau_s
    # "never" as a time no recording reaches: the kernels compiled ahead of time need not
    # compare with infinity as numba's JIT does
    p[PI_MAG_NEW_FIELD] = min(params.mag_new_field_s, 1e30)
    p[PI_MAG_NEW_MIN_RATE] = params.mag_new_min_rate_rad_s
    p[PI_MAG_OFFSET_TAU] = params.mag_offset_tau_s
    p[PI_MAG_OFFSET_MIN] = params.mag_offset_min_uT
    p[PI_MAG_OFFSET_FIT] = params.mag_offset_fit_uT
    p[PI_MAG_OFFSET_STD] = params.mag_offset_std_uT
    p[PI_REST_GYR_DEV] = params.rest_gyr_dev_rad_s
    p[PI_REST_ACC_DEV] = params.rest_acc_dev_m_s2
    p[PI_REST_TAU] = params.rest_tau_s
    p[PI_REST_MAX_RATE] = params.rest_max_rate_rad_s
    p[PI_REST_TIME] = params.rest_time_s
    p[PI_REST_BIAS_NOISE] = params.rest_bias_noise_rad_s
    p[PI_MAX_GAP] = params.max_gap_s
    p[PI_GAP_RATE] = params.gap_attitude_rate_rad_s
    p[PI_GYR_RANGE] = params.gyr_range_rad_s
    p[PI_ACC_RANGE] = params.acc_range_m_s2
    p[PI_MAG_RANGE] = params.mag_range_uT
    p[PI_USE_ACC] = 1.0 if use_acc else 0.0
    p[PI_USE_MAG] = 1.0 if use_mag else 0.0
    p[PI_CORRECT] = 1.0 if correct else 0.0
    return p
