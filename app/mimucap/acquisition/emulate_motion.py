"""The emulators' default motion: the simulated suit (:mod:`mimucap.core.simulate.suit`).

Wraps :class:`~mimucap.core.simulate.suit.SuitSimulator` as a
:class:`~mimucap.acquisition.emulate_common.MotionSource`. The emulators inject their own
loss and clock errors, so the simulator's own sample drops are switched off. A suit has at
most 17 units; more emulated nodes repeat them (node ``i`` sends unit ``i mod 17``).
"""

from __future__ import annotations

import numpy as np

from mimucap.core.simulate.config import MAX_SENSORS, SimulationConfig
from mimucap.core.simulate.suit import SuitSimulator


class SimulatorMotion:
    """Measurements of the simulated suit, ``advance(n)`` samples at a time."""

    def __init__(self, n_sensors: int, rate_hz: float, scenario: str = "demo", seed: int = 0) -> None:
        self.n_sensors = min(int(n_sensors), MAX_SENSORS)
        self.simulator = SuitSimulator(SimulationConfig(
            scenario=scenario, duration_s=0.0, n_sensors=self.n_sensors, rate_hz=rate_hz, seed=seed,
            drop_probability=0.0))
        self.sensor_ids = self.simulator.sensor_ids

    def advance(self, n_samples: int) -> dict[str, np.ndarray]:
        block = self.simulator.advance_samples(n_samples)
        samples = [block.samples[sid] for sid in self.sensor_ids]
        channels = {name: np.stack([getattr(s, name) for s in samples])
                    for name in ("acc", "gyr", "mag_uT")}
        if samples[0].q_world_from_sensor is not None:
            channels["q_world_from_sensor"] = np.stack([s.q_world_from_sensor for s in samples])
        return channels
