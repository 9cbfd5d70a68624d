"""The live pipeline the main window shows: sensor data in, skeleton frames out (no Qt).

:class:`LivePipeline` is driven by the GUI's timers (one thread): :meth:`LivePipeline.step`
pulls whatever arrived since the last call, and :meth:`LivePipeline.frame` gives the newest
figure to draw as ``(frame_id, FigureGeometry)`` (scene frame, metres; see
:mod:`mimucap.session.figure`).

This module's first source is the in-process :class:`~mimucap.core.simulate.SuitSimulator`
advanced by the wall clock; the skeleton follows the simulator's *true* segment orientations
(``q_world_from_segment``, world ENU, scalar-first), labelled ``"simulator truth"`` by
:attr:`LivePipeline.pose_source`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mimucap.acquisition.source_spec import SimulatedSpec, parse_source_spec
from mimucap.core import skeleton
from mimucap.core.simulate import SimulationConfig, SuitSimulator
from mimucap.session.events import EmitterGroup
from mimucap.session.figure import FigureBuilder, FigureGeometry

#: Longest wall-clock gap (s) simulated at once: after a stall the simulation skips ahead
#: instead of computing a long backlog on the GUI thread.
MAX_STEP_S = 0.25


@dataclass(frozen=True)
class LiveSettings:
    """Settings of the live pipeline.

    Attributes:
        display_mode: ``"world"`` (heading shown) or ``"body"`` (figure faces the camera).
        time_scale: simulated seconds per wall-clock second (1 = real time).
    """

    display_mode: str = "world"
    time_scale: float = 1.0


class LivePipeline:
    """Newest skeleton pose from a live source, as figure geometry for the 3D view.

    Args:
        config: the simulated suit's configuration (scenario, sensors, rate, height, seed).
        clock: a monotonic clock in seconds (tests pass a fake one).

    Events (``self.events``): ``frame(frame_id)`` after :meth:`step` produced a new pose.
    """

    def __init__(self, config: SimulationConfig = SimulationConfig(), clock: Callable[[], float] = time.monotonic) -> None:
        self.config = config
        self.simulator = SuitSimulator(config)
        self.model = self.simulator.model
        self.height_m = float(config.height_m)
        self.builder = FigureBuilder(self.model, self.height_m)
        self.events = EmitterGroup("frame")
        self._clock = clock
        self._last_wall: float | None = None
        self.display_mode = "world"
        self._q_world_from_segment: dict[str, np.ndarray] | None = None
        self._root_m: np.ndarray | None = None
        self._t_s = float("nan")
        self._frame_id = 0
        self._geometry: tuple[object, FigureGeometry] | None = None

    # -- state -------------------------------------------------------------------------------
    @property
    def pose_source(self) -> str:
        """What drives the figure: ``"simulator truth"`` here."""
        return "simulator truth"

    @property
    def time_s(self) -> float:
        """Session time (s) of the newest pose (NaN before the first)."""
        return self._t_s

    @property
    def q_world_from_segment(self) -> dict[str, np.ndarray] | None:
        """Newest segment orientations, segment → ``(4,)`` (world ENU, scalar first)."""
        return self._q_world_from_segment

    def segment_states(self) -> dict[str, str]:
        """Segment → state of its sensor, for tinting: ``"ok"``, ``"mag_uncalibrated"``,
        ``"stale"``; segments without a sensor are absent (shown as ``"no_sensor"``).

        The simulator's truth is exact, so every worn sensor's segment is ``"ok"``.
        """
        return {self.simulator.mounting[s].segment: "ok" for s in self.simulator.sensor_ids}

    def set_display_mode(self, mode: str) -> None:
        """``"world"`` or ``"body"`` (see :mod:`mimucap.session.figure`)."""
        self.builder.display_alpha(mode, np.array([1.0, 0, 0, 0]), 0.0)  # validates
        self.display_mode = mode
        self._geometry = None

    # -- driving -----------------------------------------------------------------------------
    def step(self) -> bool:
        """Advance the simulation to the wall clock; True when a new pose arrived."""
        now = self._clock()
        if self._last_wall is None:
            self._last_wall = now
            elapsed = 1.0 / self.config.rate_hz
        else:
            elapsed = min(max(now - self._last_wall, 0.0), MAX_STEP_S)
            self._last_wall = now
        return self.advance(elapsed)

    def advance(self, duration_s: float) -> bool:
        """Simulate ``duration_s`` more seconds; True when a new pose arrived."""
        block = self.simulator.advance(duration_s)
        truth = block.truth
        if truth.t_s.shape[0] == 0:
            return False
        self._q_world_from_segment = {name: q[-1] for name, q in truth.q_world_from_segment.items()}
        self._root_m = truth.root_position_m[-1]
        self._t_s = float(truth.t_s[-1])
        self._frame_id += 1
        self._geometry = None
        self.events.frame.emit(self._frame_id)
        return True

    def frame(self) -> tuple[object, FigureGeometry] | None:
        """``(frame_id, geometry)`` of the newest pose, or None before the first one.

        ``frame_id`` changes with every new pose and with the display mode.
        """
        if self._q_world_from_segment is None:
            return None
        frame_id = (self._frame_id, self.display_mode)
        if self._geometry is None or self._geometry[0] != frame_id:
            poses = skeleton.forward_kinematics(self.model, self._q_world_from_segment, self.height_m, self._root_m)
            geometry = self.builder.build(poses, mode=self.display_mode, heading_ref_rad=None)
            self._geometry = (frame_id, geometry)
        return self._geometry


def pipeline_for_source(spec: str) -> tuple[LivePipeline, str]:
    """A live pipeline for source ``spec`` and the label the status bar shows for it.

    ``simulated[:SCENARIO]`` runs the simulated ten-sensor suit (scenario ``demo`` by default).
    """
    parsed = parse_source_spec(spec)
    if not isinstance(parsed, SimulatedSpec):
        raise ValueError(f"source {spec!r}: this build shows live data from the simulated suit only (simulated[:SCENARIO])")
    return LivePipeline(SimulationConfig(scenario=parsed.scenario)), f"simulated:{parsed.scenario}"
