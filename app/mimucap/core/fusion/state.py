"""Filter state of the orientation EKF for S sensors, and its per-sample diagnostic flags.

The state of sensor ``s`` is

* ``q_world_from_sensor[s]`` (4,): orientation, scalar-first Hamilton quaternion, world = ENU;
* ``bias_rad_s[s]`` (3,): gyroscope bias in the sensor frame (rad/s);
* ``cov[s]`` (6, 6): covariance of the error state ``[δθ_world (rad), δb (rad/s)]`` where the
  true orientation is ``exp(δθ) ⊗ q`` (error expressed in the world frame);
* ``aux[s]`` (:data:`AUX_COUNT`,): bookkeeping (last time stamp, previous gyro sample,
  low-pass values for rest detection, the low-passed world-frame specific force, magnetic
  reference and candidate, counters, the hard-iron offset and its fit), laid out
  by the ``AX_*`` indices.

Arrays, not objects, because the numba kernels update them in place.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

# Per-sample flag bits (uint8) reported by the filter.
FLAG_REST = 1  #: the sensor was detected at rest (gyro bias updated)
FLAG_MAG_REJECTED = 2  #: magnetometer present but rejected as disturbed
FLAG_ACC_REJECTED = 4  #: accelerometer present but rejected (strong motion)
FLAG_SKIPPED = 8  #: gyroscope sample missing, out of range or time stamp not increasing
FLAG_MAG_MISSING = 16  #: magnetometer sample NaN / out of range / absent
FLAG_ACC_MISSING = 32  #: accelerometer sample NaN / out of range / absent
FLAG_UNINITIALISED = 64  #: no orientation yet (waiting for a valid accelerometer sample)
FLAG_MAG_OFFSET = 128  #: a hard-iron offset learned in the recording was removed from the magnetometer sample

FLAG_NAMES = {
    "rest": FLAG_REST,
    "mag_rejected": FLAG_MAG_REJECTED,
    "acc_rejected": FLAG_ACC_REJECTED,
    "skipped": FLAG_SKIPPED,
    "mag_missing": FLAG_MAG_MISSING,
    "acc_missing": FLAG_ACC_MISSING,
    "uninitialised": FLAG_UNINITIALISED,
    "mag_offset": FLAG_MAG_OFFSET,
}

# Layout of the auxiliary state vector. New entries go at the end: the state a recording stored
# with an older layout is a prefix of today's (``core.pipeline.settings.state_from_dict`` pads it with zeros).
(
    AX_INIT, AX_T_LAST, AX_HAVE_PREV, AX_GYR_PREV_X, AX_GYR_PREV_Y, AX_GYR_PREV_Z,
    AX_GLP_X, AX_GLP_Y, AX_GLP_Z, AX_ALP_X, AX_ALP_Y, AX_ALP_Z, AX_REST_T, AX_LP_INIT,
    AX_MAG_REF_OK, AX_MAG_NORM_REF, AX_MAG_DIP_REF, AX_MAG_CAND_NORM, AX_MAG_CAND_DIP,
    AX_MAG_CAND_T, AX_MAG_CAND_ROT, AX_MAG_GOOD_T, AX_AWLP_INIT, AX_AWLP_X, AX_AWLP_Y, AX_AWLP_Z,
    AX_N_SAMPLES, AX_N_SKIPPED, AX_N_REST, AX_N_MAG_REJECTED, AX_N_ACC_REJECTED,
    AX_N_MAG_MISSING, AX_N_ACC_MISSING, AX_N_MAG_NEW_REF, AX_N_MAG_OFFSET, AX_N_MAG_OFFSET_NEW,
    # hard-iron offset (:mod:`.hard_iron`): in use or not, the offset (µT, sensor frame), the
    # time since the last decision (s), then the fit's forgetting sums: weight, Σy², Σa·y
    # (HI_UNKNOWNS) and Σa·aᵀ (packed triangle)
    AX_HI_ON, AX_HI_O, AX_HI_O_Y, AX_HI_O_Z, AX_HI_T, AX_HI_W, AX_HI_YY, AX_HI_G,
) = range(44)
#: Unknowns of the hard-iron fit: the offset (3) and two constants of the field.
HI_UNKNOWNS = 5
AX_HI_H = AX_HI_G + HI_UNKNOWNS
AUX_COUNT = AX_HI_H + HI_UNKNOWNS * (HI_UNKNOWNS + 1) // 2

#: Counter name -> aux index (counts over every sample fed so far).
COUNTER_INDEX = {
    "samples": AX_N_SAMPLES,
    "skipped": AX_N_SKIPPED,
    "rest": AX_N_REST,
    "mag_rejected": AX_N_MAG_REJECTED,
    "acc_rejected": AX_N_ACC_REJECTED,
    "mag_missing": AX_N_MAG_MISSING,
    "acc_missing": AX_N_ACC_MISSING,
    "mag_new_reference": AX_N_MAG_NEW_REF,
    "mag_offset": AX_N_MAG_OFFSET,
    "mag_new_offset": AX_N_MAG_OFFSET_NEW,
}


@dataclass
class FusionState:
    """Mutable filter state of ``S`` sensors (arrays with the sensor index first)."""

    q_world_from_sensor: np.ndarray  # (S, 4)
    bias_rad_s: np.ndarray  # (S, 3)
    cov: np.ndarray  # (S, 6, 6)
    aux: np.ndarray  # (S, AUX_COUNT)

    @classmethod
    def new(cls, n_sensors: int) -> "FusionState":
        """An uninitialised state: the first valid accelerometer sample sets the orientation."""
        if n_sensors < 1:
            raise ValueError(f"need at least one sensor, got {n_sensors}")
        q = np.zeros((n_sensors, 4))
        q[:, 0] = 1.0
        return cls(q, np.zeros((n_sensors, 3)), np.zeros((n_sensors, 6, 6)),
                   np.zeros((n_sensors, AUX_COUNT)))

    @property
    def n_sensors(self) -> int:
        return self.q_world_from_sensor.shape[0]

    def copy(self) -> "FusionState":
        return FusionState(self.q_world_from_sensor.copy(), self.bias_rad_s.copy(),
                           self.cov.copy(), self.aux.copy())

    def counters(self, sensor: int = 0) -> dict[str, int]:
        """Counts of samples, skipped samples, rest samples and rejections of one sensor."""
        return _decode_counters(self.aux[sensor])

    def all_counters(self) -> "SensorCounters":
        """Every sensor's :meth:`counters` as they are now (decoded when read)."""
        return SensorCounters(self.aux)

    def initialised(self, sensor: int = 0) -> bool:
        return bool(self.aux[sensor, AX_INIT] > 0.0)

    def magnetic_reference(self, sensor: int = 0) -> tuple[float, float] | None:
        """Learned reference ``(norm_uT, dip_rad)`` (dip positive downwards) or ``None``."""
        if self.aux[sensor, AX_MAG_REF_OK] <= 0.0:
            return None
        return float(self.aux[sensor, AX_MAG_NORM_REF]), float(self.aux[sensor, AX_MAG_DIP_REF])

    def magnetic_offset(self, sensor: int = 0) -> np.ndarray | None:
        """The hard-iron offset (µT, sensor frame, (3,)) removed from the magnetometer's samples
        now (:mod:`.hard_iron`), or ``None`` when the calibration is used as it is."""
        if self.aux[sensor, AX_HI_ON] <= 0.0:
            return None
        return self.aux[sensor, AX_HI_O:AX_HI_O + 3].copy()

    def attitude_std_rad(self, sensor: int = 0) -> np.ndarray:
        """Standard deviations (3,) of the world-frame attitude error (rad): x, y tilt, z heading."""
        return np.sqrt(np.clip(np.diag(self.cov[sensor])[:3], 0.0, None))


def _decode_counters(aux_row: np.ndarray) -> dict[str, int]:
    row = aux_row.tolist()  # one conversion instead of one numpy scalar per counter
    return {name: int(row[index]) for name, index in COUNTER_INDEX.items()}


class SensorCounters(Sequence):
    """One counter dict per sensor (what :meth:`FusionState.counters` gives), from a copy of the
    ``aux`` rows ``(S, AUX_COUNT)`` taken at construction and decoded only when read: the live
    session fuses every sensor 60 times a second and rarely looks at the counts."""

    def __init__(self, aux: np.ndarray) -> None:
        self._aux = np.array(aux, dtype=np.float64)  # a copy: later updates do not show

    def __len__(self) -> int:
        return len(self._aux)

    def __getitem__(self, sensor):
        if isinstance(sensor, slice):
            return [self[s] for s in range(*sensor.indices(len(self)))]
        return _decode_counters(self._aux[sensor])


def decode_flags(flags: np.ndarray) -> dict[str, np.ndarray]:
    """Boolean arrays (same shape as ``flags``) for every flag name of :data:`FLAG_NAMES`."""
    flags = np.asarray(flags)
    return {name: (flags & bit) != 0 for name, bit in FLAG_NAMES.items()}
