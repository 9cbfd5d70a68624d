"""The rotation-protocol study (sections 2–3 of Choe, Zhao, Qiu,
So, "Study of calibration method of low-cost MEMS magnetometer"): which hand motion calibrates best?

Design, as in that study: one magnetometer with fixed hard and soft iron; every protocol is
repeated over several trials; each trial is fitted; the fitted ellipsoid centre and radii
are compared with a *reference fit* of the same sensor from a long, dense recording; the
root-mean-square error over trials (and over the three components) is reported per
protocol, together with the time the protocol takes. Protocols: figure-8 with 1–5 gestures
(Choe et al.'s Table 1) and the single-axis protocol with 1–3 turns about each sensor axis
(their Table 2).

* :func:`evaluate_protocols` does the comparison for any trials (simulated or real).
* :func:`simulate_study` builds the trials with :func:`mimucap.core.simulate.calibration_motion`:
  MPU-9250-like errors (AK8963: 0.6 µT noise, 0.15 µT/LSB) in a 49.3 µT field (the study's),
  the reference being a 50-s tumbling recording of the same sensor.
* :func:`format_tables` prints the two tables.

Units: µT (sensor frame), seconds.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mimucap.core.magcal.fit import Ellipsoid, FitRefused, FitSettings, fit_ellipsoid
from mimucap.core.magcal.quality import assess_quality
from mimucap.core.simulate.hand_held import calibration_motion
from mimucap.core.simulate.magnetic_field import EarthField
from mimucap.core.simulate.sensor_errors import error_model

FloatArray = NDArray[np.float64]

#: The field strength of Choe et al.'s study (µT).
STUDY_FIELD_UT = 49.3


@dataclass(frozen=True)
class StudyProtocol:
    """One protocol of the study: ``protocol`` ("figure8" or "single_axis") and ``turns``."""

    protocol: str
    turns: int

    @property
    def key(self) -> str:
        """Name used in tables and folders, e.g. ``"figure8-3"``."""
        return f"{self.protocol}-{self.turns}"


#: The study's protocols: figure-8 ×1..5 (Table 1) and single-axis ×1..3 (Table 2).
STUDY_PROTOCOLS: tuple[StudyProtocol, ...] = tuple(
    [StudyProtocol("figure8", n) for n in range(1, 6)] + [StudyProtocol("single_axis", n) for n in range(1, 4)]
)


@dataclass(frozen=True)
class Trial:
    """One recording of a protocol: raw samples ``mag_uT`` (N, 3), its duration (s) if known."""

    mag_uT: FloatArray
    duration_s: float | None = None


@dataclass(frozen=True)
class ProtocolResult:
    """Outcome of one protocol over its trials.

    key: e.g. "figure8-3". trials: number of trials; refused: fits refused. centres, radii:
    (k, 3) fitted centres and ascending radii of the k accepted fits (µT). centre_rmse_uT,
    radii_rmse_uT: RMS over accepted trials and components of the difference with the
    reference (NaN if every fit was refused). duration_s: mean duration (NaN if unknown).
    verdicts: (good, warn, fail) counts of the accepted fits. example_mag_uT, example_fit:
    the samples (N, 3) and fitted :class:`Ellipsoid` of the first accepted trial (``None`` if
    none), for figures.
    """

    key: str
    trials: int
    refused: int
    centres: FloatArray
    radii: FloatArray
    centre_rmse_uT: float
    radii_rmse_uT: float
    duration_s: float
    verdicts: tuple[int, int, int]
    example_mag_uT: FloatArray | None = None
    example_fit: Ellipsoid | None = None


@dataclass(frozen=True)
class StudyResult:
    """The study: reference centre and radii (µT), field, noise description, per-protocol
    results, and the reference :class:`Ellipsoid`."""

    reference_centre_uT: FloatArray
    reference_radii_uT: FloatArray
    field_uT: float
    description: str
    protocols: tuple[ProtocolResult, ...]
    reference: Ellipsoid | None = None

    def result(self, key: str) -> ProtocolResult:
        """The :class:`ProtocolResult` of protocol ``key`` (e.g. ``"single_axis-1"``)."""
        for item in self.protocols:
            if item.key == key:
                return item
        raise KeyError(f"no protocol {key!r} in the study")


def _rmse(values: FloatArray, reference: FloatArray) -> float:
    if len(values) == 0:
        return float("nan")
    return float(np.sqrt(np.mean((values - reference) ** 2)))


def evaluate_protocols(
    trials: Mapping[str, Sequence[Trial]],
    reference_mag_uT: FloatArray,
    settings: FitSettings = FitSettings(),
    description: str = "",
) -> StudyResult:
    """Fit every trial of every protocol and compare with the reference fit.

    trials: protocol key → its trials. reference_mag_uT: (M, 3) samples of a dense recording
    of the same sensor (a refused reference fit raises :class:`FitRefused`).
    """
    reference = fit_ellipsoid(reference_mag_uT, settings)
    ref_centre = reference.ellipsoid.centre
    ref_radii = reference.ellipsoid.radii
    results = []
    for key, items in trials.items():
        centres, radii, durations = [], [], []
        verdicts = [0, 0, 0]
        refused = 0
        example: tuple[FloatArray, Ellipsoid] | None = None
        for trial in items:
            if trial.duration_s is not None:
                durations.append(trial.duration_s)
            try:
                fit = fit_ellipsoid(trial.mag_uT, settings)
            except FitRefused:
                refused += 1
                continue
            quality = assess_quality(fit, trial.mag_uT)
            verdicts[("good", "warn", "fail").index(quality.verdict)] += 1
            centres.append(fit.ellipsoid.centre)
            radii.append(fit.ellipsoid.radii)
            if example is None:
                example = (np.asarray(trial.mag_uT, dtype=np.float64), fit.ellipsoid)
        centres_array = np.array(centres).reshape(-1, 3)
        radii_array = np.array(radii).reshape(-1, 3)
        results.append(
            ProtocolResult(
                key=key,
                trials=len(items),
                refused=refused,
                centres=centres_array,
                radii=radii_array,
                centre_rmse_uT=_rmse(centres_array, ref_centre),
                radii_rmse_uT=_rmse(radii_array, ref_radii),
                duration_s=float(np.mean(durations)) if durations else float("nan"),
                verdicts=(verdicts[0], verdicts[1], verdicts[2]),
                example_mag_uT=None if example is None else example[0],
                example_fit=None if example is None else example[1],
            )
        )
    return StudyResult(
        reference_centre_uT=ref_centre,
        reference_radii_uT=ref_radii,
        field_uT=reference.field_uT,
        description=description,
        protocols=tuple(results),
        reference=reference.ellipsoid,
    )


@dataclass(frozen=True)
class StudySettings:
    """Settings of :func:`simulate_study` (defaults in brackets).

    trials: trials per protocol [10]. seed: draws the sensor and every trial [0].
    field_uT: field magnitude [49.3, as in the study]. dip_deg: field inclination [60].
    errors: sensor error preset of :mod:`mimucap.core.simulate.sensor_errors` (``ERROR_PRESETS``) ["mpu9250"].
    rate_hz: sample rate [100]. reference_periods: 10-s tumbling periods of the reference
    recording [5]. protocols: the protocols compared [:data:`STUDY_PROTOCOLS`].
    """

    trials: int = 10
    seed: int = 0
    field_uT: float = STUDY_FIELD_UT
    dip_deg: float = 60.0
    errors: str = "mpu9250"
    rate_hz: float = 100.0
    reference_periods: int = 5
    protocols: tuple[StudyProtocol, ...] = STUDY_PROTOCOLS

    def __post_init__(self) -> None:
        if not 1 <= self.trials <= 1000:
            raise ValueError(f"trials must be from 1 to 1000, got {self.trials}")
        if not 1 <= self.reference_periods <= 5:
            raise ValueError(f"reference_periods must be from 1 to 5, got {self.reference_periods}")


def simulate_study(settings: StudySettings = StudySettings()) -> StudyResult:
    """Run the study on simulated trials of one MPU-9250-like sensor (see module docstring)."""
    model = error_model(settings.errors)
    field = EarthField(magnitude_uT=settings.field_uT, dip_deg=settings.dip_deg)
    # The reference recording draws the sensor (its true hard and soft iron); every trial
    # re-uses that sensor with its own hand motion and noise.
    reference = calibration_motion(
        "tumble", settings.reference_periods, rate_hz=settings.rate_hz, seed=settings.seed,
        errors=model, earth_field=field, sensor_id="study",
    )

    def motion(protocol: str, turns: int, seed: int):
        return calibration_motion(
            protocol, turns, rate_hz=settings.rate_hz, seed=seed, errors=model, earth_field=field,
            sensor_id="study", mag_A=reference.mag_A, mag_b_uT=reference.mag_b_uT,
        )

    trials: dict[str, list[Trial]] = {}
    for index, item in enumerate(settings.protocols):
        trials[item.key] = []
        for trial in range(settings.trials):
            trial_seed = settings.seed * 100_003 + 1 + index * 1_000 + trial
            recording = motion(item.protocol, item.turns, trial_seed)
            duration = float(len(recording.t_s) / recording.rate_hz)
            trials[item.key].append(Trial(mag_uT=recording.mag_uT, duration_s=duration))
    description = (
        f"{settings.trials} simulated trials per protocol, {settings.errors} sensor errors "
        f"(noise {model.mag_noise_uT:g} µT, step {model.mag_lsb_uT:g} µT), field "
        f"{settings.field_uT:g} µT at {settings.dip_deg:g}° dip, seed {settings.seed}; "
        f"reference: {settings.reference_periods * 10} s of tumbling"
    )
    return evaluate_protocols(trials, reference.mag_uT, FitSettings(field_uT=settings.field_uT), description)


_TABLE_TITLES = {
    "figure8": "Table 1: figure-8 protocol (turns = figure-8 gestures)",
    "single_axis": "Table 2: single-axis protocol (turns about each sensor axis)",
}


def format_tables(result: StudyResult) -> str:
    """The study as plain-text tables (one per protocol family), like the study's Tables 1–2."""
    lines = [f"Rotation-protocol study: {result.description}".rstrip(": ")]
    centre = ", ".join(f"{v:.2f}" for v in result.reference_centre_uT)
    radii = ", ".join(f"{v:.2f}" for v in result.reference_radii_uT)
    lines.append(f"reference fit: centre ({centre}) µT, radii ({radii}) µT")
    families: dict[str, list[ProtocolResult]] = {}
    for item in result.protocols:
        family, _, _ = item.key.rpartition("-")
        families.setdefault(family or item.key, []).append(item)
    header = f"{'turns':>5}  {'duration_s':>10}  {'centre_RMSE_uT':>14}  {'radii_RMSE_uT':>13}  {'refused':>7}  {'good/warn/fail':>14}"
    for family, items in families.items():
        lines.append("")
        lines.append(_TABLE_TITLES.get(family, f"Protocol {family}"))
        lines.append(header)
        for item in items:
            turns = item.key.rpartition("-")[2]
            verdicts = "/".join(str(v) for v in item.verdicts)
            lines.append(
                f"{turns:>5}  {item.duration_s:>10.1f}  {item.centre_rmse_uT:>14.3f}  "
                f"{item.radii_rmse_uT:>13.3f}  {item.refused:>3}/{item.trials:<3}  {verdicts:>14}"
            )
    return "\n".join(lines)
