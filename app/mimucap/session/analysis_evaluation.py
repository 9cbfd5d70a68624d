"""Evaluation of the gait analysis against an independent reference (no Qt): the gaitmap
example's optical reference, or the simulated suit's truth. Used by ``bench/bench_gait.py``
and the tests; the analysis itself never sees a reference.

Matching: a detected analysed stride matches a reference stride of the same foot when both of
its initial contacts lie within ``tolerance_s`` of the reference's. Unmatched reference
strides are *missed*, unmatched detected strides inside the reference's walking time are
*extra*. Errors: detected minus reference (IC: the contact ending the stride; FC: the
toe-off; stride length: m).

The simulated suit runs the real pipeline: the session is written *without* its truth, the
body calibration is computed from the simulated N-pose/T-pose by
:func:`mimucap.core.bodycal.calibrate_npose_tpose` on the sensors' own orientation output, and
the review (:func:`mimucap.session.review.load_review`) and analysis run on that file. Truth
gait events come from the simulator's per-foot contact state (``SuitTruth.foot_contact``),
truth stride lengths from the ankle's displacement between mid-stances (forward kinematics of
the true segment orientations).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mimucap.core import bodycal, skeleton
from mimucap.core.analysis.strides import Stride
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.suit import SimulationResult, simulate_session
from mimucap.io.gait_csv import ReferenceStride
from mimucap.io.session import Marker, session_from_simulation, write_session
from mimucap.session.analysis import SessionAnalysis, analyse_review
from mimucap.session.review import load_review

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


# -- the simulated suit ----------------------------------------------------------------------
def _contacts(t: np.ndarray, contact: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    on = contact > 0.5
    rises = np.flatnonzero(~on[:-1] & on[1:]) + 1
    falls = np.flatnonzero(on[:-1] & ~on[1:]) + 1
    return t[rises], t[falls]


def walk_windows(markers: list[tuple[float, str]], end_s: float) -> list[tuple[float, float]]:
    """Steady-walking windows of a simulation (its ``walk`` phases, :mod:`mimucap.core.phases`, trimmed)."""
    from mimucap.core import phases

    windows = []
    for i, (start, label) in enumerate(markers):
        if phases.is_phase(label, phases.WALK):
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
