"""Settings of one simulation of the sensor suit, and where its units are worn.

Sensors: ``S01``..``S10`` on the ten segments of ``ten_segment`` (pelvis, thorax,
upper_arm_l/r, forearm_l/r, thigh_l/r, shank_l/r); ``S11``..``S15`` add head, hand_l/r and
foot_l/r (``fifteen_segment``); ``S16`` is a second unit on the thorax (upper back) and
``S17`` a second unit on the pelvis (right side), for redundancy checks. ``n_sensors`` ≤ 10
uses the ten-segment model, more the fifteen-segment one (17: the full suit). Each unit sits
on the skin of its segment (see :data:`SENSOR_PLACEMENTS`) with a uniformly random but known
mounting rotation ``q_segment_from_sensor``.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from mimucap.core import skeleton
from mimucap.core.device_identity import simulated_device_id
from mimucap.core.simulate.magnetic_field import EarthField, MagneticDisturbance
from mimucap.core.simulate.names import ROOM_NAMES, SCENARIOS
from mimucap.core.simulate.scenarios import scenario_activities
from mimucap.core.simulate.sensor_errors import SensorErrorModel, error_model

#: Where each unit is worn: (sensor id, segment, position along the segment as a fraction of
#: its length from the proximal joint, outward surface normal in the segment frame).
SENSOR_PLACEMENTS: tuple[tuple[str, str, float, tuple[float, float, float]], ...] = (
    ("S01", "pelvis", 0.5, (-1.0, 0.0, 0.0)),       # sacrum
    ("S02", "thorax", 0.6, (1.0, 0.0, 0.0)),        # sternum
    ("S03", "upper_arm_l", 0.5, (0.0, 0.0, -1.0)),  # lateral upper arm
    ("S04", "upper_arm_r", 0.5, (0.0, 0.0, 1.0)),
    ("S05", "forearm_l", 0.7, (0.0, 0.0, -1.0)),    # lateral forearm near the wrist
    ("S06", "forearm_r", 0.7, (0.0, 0.0, 1.0)),
    ("S07", "thigh_l", 0.5, (0.0, 0.0, -1.0)),      # lateral thigh
    ("S08", "thigh_r", 0.5, (0.0, 0.0, 1.0)),
    ("S09", "shank_l", 0.4, (0.0, 0.0, -1.0)),      # lateral shank
    ("S10", "shank_r", 0.4, (0.0, 0.0, 1.0)),
    ("S11", "head", 0.6, (-1.0, 0.0, 0.0)),         # back of the head
    ("S12", "hand_l", 0.3, (0.0, 0.0, -1.0)),       # back of the hand (palms face in at N-pose)
    ("S13", "hand_r", 0.3, (0.0, 0.0, 1.0)),
    ("S14", "foot_l", 0.5, (0.0, 1.0, 0.0)),        # top of the foot
    ("S15", "foot_r", 0.5, (0.0, 1.0, 0.0)),
    ("S16", "thorax", 0.7, (-1.0, 0.0, 0.0)),       # upper back (second thorax unit)
    ("S17", "pelvis", 0.5, (0.0, 0.0, 1.0)),        # right side of the pelvis (second pelvis unit)
)
MAX_SENSORS = len(SENSOR_PLACEMENTS)
#: Error-model fields that describe the link, not the unit: they leave the suit the same.
_LINK_SETTINGS = ("drop_probability",)


def default_assignment(sensor_ids: Iterable[str]) -> dict[str, str]:
    """Sensor id → segment as the suit comes assigned: one sensor per segment, the first unit
    worn on it (:data:`SENSOR_PLACEMENTS` order); a second unit on a segment (``S16`` on the
    thorax, ``S17`` on the pelvis) is worn but assigned to none (assign it by hand to drive its
    segment instead)."""
    wanted = set(sensor_ids)
    assignment: dict[str, str] = {}
    for sensor_id, segment, _along, _normal in SENSOR_PLACEMENTS:
        if sensor_id in wanted and segment not in assignment.values():
            assignment[sensor_id] = segment
    return assignment


def suit_fingerprint(seed: int, errors: SensorErrorModel | str) -> str:
    """Eight hex digits naming the suit whose units ``seed`` and ``errors`` draw (the link's
    settings, e.g. the drop probability, do not change the units)."""
    model = asdict(error_model(errors))
    for name in _LINK_SETTINGS:
        model.pop(name, None)
    text = json.dumps({"seed": int(seed) & 0xFFFFFFFF, "errors": model}, sort_keys=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:8]


@dataclass(frozen=True)
class SimulationConfig:
    """Settings of one simulation (defaults give the ten-sensor demo at 100 Hz).

    ``scenario``: one of :data:`SCENARIOS` (``demo`` loops N-pose, T-pose, walking, turning,
    squats and arm raises; ``bodycal`` N-pose 3 s, T-pose 3 s, N-pose; an activity name runs
    that activity); ``scenario_params`` keyword parameters of that activity (e.g.
    ``{"arms": "right"}`` for ``tpose``, ``{"sensor_ids": ["S01", "S02"]}`` for
    ``mag_single_axis``); ``duration_s`` for :func:`mimucap.core.simulate.suit.simulate_session`; ``n_sensors`` 1..17;
    ``rate_hz`` 10..1000; ``seed`` makes everything reproducible; ``errors`` a
    :class:`SensorErrorModel` or preset name (``default``, ``ideal``, ``mpu9250``, ``bno055``);
    ``drop_probability`` overrides the error model's when not None; ``earth_field``;
    ``disturbances`` local field episodes; ``height_m`` subject height; ``model`` skeleton
    model name (default by ``n_sensors``); ``random_mounting`` False mounts every unit aligned
    with its segment; ``magcal_turns`` True begins the scenario with the magnetometer turns of
    every unit held together (:func:`mimucap.core.simulate.scenarios.magcal_turns`), as a session
    that carries its own calibration does; ``room`` the room preset
    (:mod:`mimucap.core.simulate.rooms`: ``clean``, the earth field alone; ``clinic``, a
    reinforced floor and a steel bed beside the walkway; ``treadmill``, walking on a treadmill),
    whose field each unit measures at its own position.
    """

    scenario: str = "demo"
    duration_s: float = 30.0
    n_sensors: int = 10
    rate_hz: float = 100.0
    seed: int = 0
    errors: SensorErrorModel | str = "default"
    drop_probability: float | None = None
    earth_field: EarthField = EarthField()
    disturbances: tuple[MagneticDisturbance, ...] = ()
    height_m: float = 1.75
    model: str | None = None
    scenario_params: Mapping[str, Any] = field(default_factory=dict)
    random_mounting: bool = True
    magcal_turns: bool = False
    room: str = "clean"

    def __post_init__(self) -> None:
        if self.room not in ROOM_NAMES:
            raise ValueError(f"unknown room {self.room!r}; use one of {', '.join(ROOM_NAMES)}")
        if self.scenario not in SCENARIOS:
            raise ValueError(f"unknown scenario {self.scenario!r}; use one of {', '.join(SCENARIOS)}")
        if int(self.n_sensors) != self.n_sensors or not 1 <= self.n_sensors <= MAX_SENSORS:
            raise ValueError(
                f"number of sensors must be 1..{MAX_SENSORS} (10: ten-segment suit, 15: fifteen-segment suit, "
                f"16/17: plus second units on thorax and pelvis), got {self.n_sensors}"
            )
        if not 10.0 <= self.rate_hz <= 1000.0:
            raise ValueError(f"sample rate must be 10..1000 Hz, got {self.rate_hz}")
        if not math.isfinite(self.duration_s) or self.duration_s < 0:
            raise ValueError(f"duration must be >= 0 s, got {self.duration_s}")
        if not 0.5 <= self.height_m <= 2.5:
            raise ValueError(f"subject height must be 0.5..2.5 m, got {self.height_m}")
        if self.model is not None and self.model not in skeleton.MODEL_NAMES:
            raise ValueError(f"unknown skeleton model {self.model!r}; use one of {', '.join(skeleton.MODEL_NAMES)}")
        error_model(self.errors)
        # Build the scenario's activities once: unknown or bad parameters fail here.
        scenario_activities(self.scenario, dict(self.scenario_params), sensor_ids=self.sensor_ids)
        unknown = [s for s in self.scenario_params.get("sensor_ids", ()) if s not in self.sensor_ids]
        if unknown:
            raise ValueError(f"unknown sensor id(s) {', '.join(unknown)}; the suit has {', '.join(self.sensor_ids)}")
        if self.drop_probability is not None and not 0.0 <= self.drop_probability < 0.9:
            raise ValueError(f"drop probability must be in [0, 0.9), got {self.drop_probability}")

    @property
    def model_name(self) -> str:
        if self.model is not None:
            return self.model
        return "ten_segment" if self.n_sensors <= 10 else "fifteen_segment"

    @property
    def sensor_ids(self) -> tuple[str, ...]:
        return tuple(p[0] for p in SENSOR_PLACEMENTS[: self.n_sensors])

    def device_ids(self) -> dict[str, str]:
        """Sensor id → device id of each unit (:mod:`mimucap.core.device_identity`: the suit is
        named by :func:`suit_fingerprint` of the random seed and the error model)."""
        suit = suit_fingerprint(self.seed, self.errors)
        return {sid: simulated_device_id(suit, sid) for sid in self.sensor_ids}

    def error_settings(self) -> SensorErrorModel:
        """The resolved error model (with ``drop_probability`` applied)."""
        model = error_model(self.errors)
        if self.drop_probability is not None:
            model = replace(model, drop_probability=float(self.drop_probability))
        return model


@dataclass(frozen=True)
class SensorMounting:
    """How a unit is worn: ``segment``, ``q_segment_from_sensor`` (4,), ``position_in_segment_m``
    (3,) from the segment's proximal joint in the segment frame."""

    sensor_id: str
    segment: str
    q_segment_from_sensor: np.ndarray
    position_in_segment_m: np.ndarray
