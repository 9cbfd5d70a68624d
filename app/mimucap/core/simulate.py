"""Simulated sensor suit with ground truth: the public entry point of the simulator.

The sensor error model lives in :mod:`mimucap.core.simulate_sensors`, the single-sensor
magnetometer-calibration motions in :mod:`mimucap.core.simulate_calibration`; this module
gathers the public names.
"""

from __future__ import annotations

from mimucap.core.simulate_calibration import PROTOCOLS, CalibrationMotion, calibration_motion
from mimucap.core.simulate_sensors import (
    ERROR_PRESETS,
    GRAVITY_MPS2,
    IDEAL_SENSOR,
    EarthField,
    MagneticDisturbance,
    SensorErrorModel,
    error_model,
)

__all__ = [
    "PROTOCOLS", "CalibrationMotion", "calibration_motion", "ERROR_PRESETS", "GRAVITY_MPS2",
    "IDEAL_SENSOR", "EarthField", "MagneticDisturbance", "SensorErrorModel", "error_model",
]
