"""Evaluation of the gait analysis against an independent reference (no Qt): the gaitmap
example's optical reference, or the simulated suit's truth. Used by ``bench/bench_gait.py``
and the tests; the analysis itself never sees a reference.

Matching: a detected analysed stride matches a reference stride of the same foot when both of
its initial contacts lie within ``tolerance_s`` of the reference's. Unmatched reference
strides are *missed*, unmatched detected strides inside the reference's walking time are
*extra*. Errors: detected minus reference (IC: the contact ending the stride; FC: the
toe-off; stride length: m).

The gaitmap walk is also evaluated as other sensors would have recorded it
(:data:`GAITMAP_VARIANTS`): resampled to another rate (band-limited polyphase resampling of the
raw samples) and/or with the sensor turned on the foot (a fixed rotation of the raw
accelerometer and gyroscope samples about the foot's mediolateral and vertical axes); the
reference events and heel positions stay as measured, and the analysis finds the sensor's axes
in its samples (:func:`mimucap.core.analysis.sagittal.axes_from_data`).

The simulated suit runs the real pipeline: the session is written *without* its truth, the
body calibration is computed from the simulated N-pose/T-pose by
:func:`mimucap.core.bodycal.calibrate_npose_tpose` on the sensors' own orientation output, and
the review (:func:`mimucap.session.recorded.review.load_review`) and analysis run on that file. Truth
gait events come from the simulator's per-foot contact state (``SuitTruth.foot_contact``: a
foot is on the floor while its sole's heel or toe is, :mod:`mimucap.core.simulate.gait_design`),
truth stride lengths from the ankle's displacement between mid-stances (forward kinematics of
the true segment orientations).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np

from mimucap.core import bodycal, rotation, skeleton
from mimucap.core.analysis.gait import GaitAnalysis, GaitInput, analyse_gait
from mimucap.core.analysis.sagittal import axes_from_data
from mimucap.core.analysis.strides import Stride
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import SimulationResult, simulate_session
from mimucap.io.gaitmap import FootImu, ReferenceStride, read_foot_imu_csv, read_gaitmap_reference
from mimucap.io.session import Marker, session_from_simulation, write_session
from mimucap.session.recorded.analysis import SessionAnalysis, analyse_review
from mimucap.session.recorded.review import load_review

#: N-pose and T-pose windows (s) of the simulator's ``demo`` and ``bodycal`` scenarios.
DEMO_NPOSE_S = (0.5, 2.5)
DEMO_TPOSE_S = (4.6, 5.9)
#: Seconds trimmed from each end of a simulated walk: walking is blended in and out there.
WALK_TRIM_S = 1.2


@dataclass(frozen=True)
class EventErrors:
    """Figures of one evaluation: errors (s, m) of matched strides, and counts."""

    ic_errors_s: np.ndarray
    fc_errors_s: np.ndarray
    length_errors_m: np.ndarray
    n_reference: int
    n_detected: int
    missed: int
    extra: int

    def summary(self) -> dict[str, float]:
        """Median and 95th percentile of |IC| and |FC| error (ms), stride-length error mean,
        SD and mean absolute (cm), and the counts."""
        def pct(values, q):
            return float(np.percentile(np.abs(values), q)) * 1000.0 if values.size else math.nan
        lengths = self.length_errors_m[np.isfinite(self.length_errors_m)] * 100.0
        return {
            "ic_median_ms": pct(self.ic_errors_s, 50), "ic_p95_ms": pct(self.ic_errors_s, 95),
            "fc_median_ms": pct(self.fc_errors_s, 50), "fc_p95_ms": pct(self.fc_errors_s, 95),
            "length_mean_cm": float(lengths.mean()) if lengths.size else math.nan,
            "length_sd_cm": float(lengths.std(ddof=1)) if lengths.size > 1 else math.nan,
            "length_mae_cm": float(np.abs(lengths).mean()) if lengths.size else math.nan,
            "n_reference": self.n_reference, "n_detected": self.n_detected,
            "missed": self.missed, "extra": self.extra,
        }


def compare(detected: list[Stride], reference: list[ReferenceStride], tolerance_s: float = 0.15,
            windows: list[tuple[float, float]] | None = None) -> EventErrors:
    """Match analysed ``detected`` strides to ``reference`` strides (module doc); *extra*
    strides are counted inside ``windows`` (s; default: from the first to the last reference
    contact) shrunk by the tolerance, so that a stride at a window's edge whose reference
    counterpart falls just outside is not counted."""
    analysed = [s for s in detected if s.analysed]
    used: set[int] = set()
    ic, fc, length = [], [], []
    missed = 0
    for r in reference:
        candidates = [i for i, s in enumerate(analysed) if i not in used and s.side == r.side
                      and abs(s.ic_s - r.pre_ic) <= tolerance_s and abs(s.next_ic_s - r.ic) <= tolerance_s]
        if not candidates:
            missed += 1
            continue
        i = min(candidates, key=lambda k: abs(analysed[k].next_ic_s - r.ic))
        used.add(i)
        s = analysed[i]
        ic.append(s.next_ic_s - r.ic)
        fc.append(s.fc_s - r.tc)
        length.append(s.stride_length_m - r.length_m)
    if windows is None:
        windows = [(min(r.pre_ic for r in reference), max(r.ic for r in reference))] if reference else []
    extra = sum(1 for i, s in enumerate(analysed) if i not in used
                and any(a + tolerance_s <= s.ic_s and s.next_ic_s <= b - tolerance_s for a, b in windows))
    return EventErrors(np.asarray(ic), np.asarray(fc), np.asarray(length), len(reference), len(analysed), missed, extra)


def straight_reference(reference: list[ReferenceStride], max_turn_deg: float = 45.0) -> list[ReferenceStride]:
    """The reference strides whose own (optical) heading change is at most ``max_turn_deg``."""
    return [r for r in reference if not (abs(r.heading_change_deg) > max_turn_deg)]


# -- the gaitmap walk as other sensors would record it ---------------------------------------
#: Sample rate (Hz) of the gaitmap example's IMU file.
GAITMAP_RATE_HZ = 204.8


@dataclass(frozen=True)
class ImuVariant:
    """A way of recording the gaitmap walk: ``rate_hz`` the sample rate (None: as recorded),
    ``turn_ml_deg`` and ``turn_vertical_deg`` how far the sensor is turned on the foot about
    the foot's mediolateral axis (pitch) and then about the vertical (yaw), in degrees."""

    name: str
    rate_hz: float | None = None
    turn_ml_deg: float = 0.0
    turn_vertical_deg: float = 0.0


GAITMAP_VARIANTS = (
    ImuVariant("as recorded (204.8 Hz)"),
    ImuVariant("resampled to 102.4 Hz", rate_hz=102.4),
    ImuVariant("resampled to 100 Hz", rate_hz=100.0),
    ImuVariant("turned +20° ML, +10° vertical", turn_ml_deg=20.0, turn_vertical_deg=10.0),
    ImuVariant("turned -30° ML, -15° vertical", turn_ml_deg=-30.0, turn_vertical_deg=-15.0),
    ImuVariant("turned +45° ML, -20° vertical", turn_ml_deg=45.0, turn_vertical_deg=-20.0),
    ImuVariant("turned -45° ML, +20° vertical", turn_ml_deg=-45.0, turn_vertical_deg=20.0),
    ImuVariant("102.4 Hz, turned +40° ML", rate_hz=102.4, turn_ml_deg=40.0),
    ImuVariant("100 Hz, turned -40° ML, +15° vertical", rate_hz=100.0, turn_ml_deg=-40.0, turn_vertical_deg=15.0),
)


def imu_variant(imu: FootImu, rate_hz: float, variant: ImuVariant) -> FootImu:
    """The samples of ``imu`` (recorded at ``rate_hz``, gaitmap foot sensor frame: y to the
    left, z up) as ``variant`` records them. Turning: ``v_turned = q_sensor_from_turned⁻¹ v``
    with ``q_sensor_from_turned`` = yaw about z after pitch about y. Resampling: polyphase
    with scipy's anti-aliasing FIR (``resample_poly``), the rate ratio as a fraction."""
    from scipy.signal import resample_poly

    q_sensor_from_turned = rotation.multiply(
        rotation.from_axis_angle(np.array([0.0, 0.0, 1.0]), math.radians(variant.turn_vertical_deg)),
        rotation.from_axis_angle(np.array([0.0, 1.0, 0.0]), math.radians(variant.turn_ml_deg)))
    q_turned_from_sensor = rotation.conjugate(q_sensor_from_turned)
    acc, gyr = rotation.rotate(q_turned_from_sensor, imu.acc), rotation.rotate(q_turned_from_sensor, imu.gyr)
    t_s = imu.t_s
    if variant.rate_hz is not None and variant.rate_hz != rate_hz:
        ratio = Fraction(variant.rate_hz / rate_hz).limit_denominator(1000)
        if abs(float(ratio) * rate_hz - variant.rate_hz) > 1e-6 * variant.rate_hz:
            raise ValueError(f"cannot resample {rate_hz} Hz to {variant.rate_hz} Hz by a ratio of small integers")
        acc = resample_poly(acc, ratio.numerator, ratio.denominator, axis=0)
        gyr = resample_poly(gyr, ratio.numerator, ratio.denominator, axis=0)
        t_s = imu.t_s[0] + np.arange(acc.shape[0]) / variant.rate_hz
    return FootImu(imu.side, t_s, acc, gyr)


def gaitmap_variant_analysis(folder: str | Path, variant: ImuVariant) -> tuple[GaitAnalysis, list[ReferenceStride]]:
    """The gaitmap walk recorded as ``variant`` and analysed as ``mimucap gait`` does (the
    sensors' axes found in their samples), with the reference strides."""
    base = Path(folder)
    feet = read_foot_imu_csv(base / "imu_sample.csv", GAITMAP_RATE_HZ, "deg/s")
    inputs = []
    for side, recorded in feet.items():
        imu = imu_variant(recorded, GAITMAP_RATE_HZ, variant)
        rate_hz = variant.rate_hz or GAITMAP_RATE_HZ
        inputs.append(GaitInput.from_axes(side, "foot", side, imu.t_s, imu.acc, imu.gyr,
                                          axes_from_data(imu.acc, imu.gyr, rate_hz)))
    return analyse_gait(inputs), read_gaitmap_reference(base)


# -- the simulated suit ----------------------------------------------------------------------
def _contacts(t: np.ndarray, contact: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Initial and final contact times (s): each between the last sample before the change and
    the first after it, at the midpoint (the samples bound the instant, they do not time it)."""
    on = contact > 0.5
    rises = np.flatnonzero(~on[:-1] & on[1:]) + 1
    falls = np.flatnonzero(on[:-1] & ~on[1:]) + 1
    return 0.5 * (t[rises - 1] + t[rises]), 0.5 * (t[falls - 1] + t[falls])


def walk_windows(markers: list[tuple[float, str]], end_s: float) -> list[tuple[float, float]]:
    """Steady-walking windows of a simulation (its ``walk`` phases, :mod:`mimucap.core.phase_markers`, trimmed)."""
    from mimucap.core import phase_markers

    windows = []
    for i, (start, label) in enumerate(markers):
        if phase_markers.is_phase(label, phase_markers.WALK):
            stop = markers[i + 1][0] if i + 1 < len(markers) else end_s
            if stop - start > 2 * WALK_TRIM_S:
                windows.append((start + WALK_TRIM_S, stop - WALK_TRIM_S))
    return windows


def simulated_reference(result: SimulationResult) -> list[ReferenceStride]:
    """Reference strides of a simulation inside its steady walking (module doc)."""
    truth = result.truth
    t = np.asarray(truth.t_s, dtype=float)
    model = skeleton.load_model(result.model_name)
    fk = skeleton.forward_kinematics(model, truth.q_world_from_segment, result.height_m, truth.root_position_m)
    windows = walk_windows(result.markers, float(t[-1]))
    strides = []
    for column, side in ((0, "left"), (1, "right")):
        ics, fcs = _contacts(t, truth.foot_contact[:, column])
        ankle = fk[f"shank_{side[0]}"].distal_m
        for k in range(len(ics) - 1):
            pre_ic, ic = ics[k], ics[k + 1]
            tc = fcs[(fcs > pre_ic) & (fcs < ic)]
            after = fcs[fcs > ic]
            if tc.size != 1 or not after.size:
                continue
            if not any(a <= pre_ic and ic <= b for a, b in windows):
                continue
            mid_a = np.searchsorted(t, 0.5 * (pre_ic + tc[0]))
            mid_b = np.searchsorted(t, 0.5 * (ic + after[0]))
            length = float(np.hypot(*(ankle[mid_b, :2] - ankle[mid_a, :2])))
            strides.append(ReferenceStride(len(strides), side, float(pre_ic), float(tc[0]), float(ic),
                                           float(t[mid_a]), float(t[mid_b]), length, 0.0))
    return strides


def simulated_analysis(config: SimulationConfig, folder: str | Path,
                       markers: tuple[tuple[float, str], ...] = ()) -> tuple[SimulationResult, SessionAnalysis]:
    """Simulate ``config`` (a scenario that starts with the N-pose/T-pose of ``demo``),
    calibrate, write the session without truth (plus ``markers`` (t_s, label), as a user would
    set them) to ``folder`` and analyse it (module doc)."""
    result = simulate_session(config)
    session = session_from_simulation(result, include_truth=False)
    session.markers = sorted(session.markers + [Marker(float(t), label) for t, label in markers], key=lambda m: m.t_s)
    grid_sensor = next(iter(session.sensors.values()))
    t = grid_sensor.t_s
    q = {}
    for sensor_id, stream in session.sensors.items():
        if stream.q_world_from_sensor is None:
            raise ValueError("the simulated evaluation needs sensors with on-board orientation (errors='bno055')")
        index = np.clip(np.searchsorted(stream.t_s, t), 0, len(stream.t_s) - 1)
        q[sensor_id] = stream.q_world_from_sensor[index]
    mapping = {stream.segment: sensor_id for sensor_id, stream in session.sensors.items() if stream.segment}
    calibration = bodycal.calibrate_npose_tpose(t, q, mapping, DEMO_NPOSE_S, DEMO_TPOSE_S)
    session.calibrations["body"] = calibration.to_dict()
    path = Path(folder) / f"simulated_{config.scenario}_{config.n_sensors}.h5"
    write_session(path, session)
    return result, analyse_review(load_review(path))
