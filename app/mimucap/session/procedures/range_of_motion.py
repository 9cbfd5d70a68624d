"""The guided range-of-motion (ROM) protocol as a state machine (no Qt).

Steps: every movement of :data:`mimucap.core.analysis.rom.MOVEMENTS` on each side (shoulder
flexion and abduction, elbow flexion, hip flexion and abduction, knee flexion, trunk flexion,
trunk rotation to the left and right). For each step the screen shows the instruction and the
active joint angle; the subject repeats the movement; each repetition's peak is captured as
it happens; after ``repeats`` repetitions the step is done and its peaks and active ROM are
averaged. Whoever drives the protocol (the GUI page, a test with the simulated subject) calls
:meth:`RomProcedure.start_step`, feeds poses with :meth:`RomProcedure.update`, and moves on with
:meth:`RomProcedure.next_step` (or :meth:`RomProcedure.skip_step`).

A repetition is captured online by :class:`mimucap.core.analysis.rom.RepetitionCounter`, the
same rule the ROM of a recording uses.

Every step leaves two markers, ``rom:<movement>:<side>:start`` and ``...:end`` (session time,
s), so that :func:`mimucap.session.recorded.analysis.rom_of_protocol` finds the same movements again in
the recording. Angles in degrees; orientations world ENU, quaternions scalar first.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mimucap.core.analysis import rom as rom_core

STATES = ("ready", "measuring", "step_done", "finished")


@dataclass(frozen=True)
class RomStep:
    """One movement on one side (``left``, ``right``, or ``both`` for trunk flexion)."""

    key: str
    side: str

    @property
    def movement(self) -> rom_core.RomMovement:
        return rom_core.movement(self.key)

    @property
    def title(self) -> str:
        m = self.movement
        if self.key == "trunk_rotation":
            return f"{m.label} to the {self.side}"
        return m.label if self.side == "both" else f"{m.label}, {self.side}"

    @property
    def instruction(self) -> str:
        return self.movement.instruction.format(side=self.side)


#: What the simulated subject does for each movement (``SuitSimulator.set_activity("rom", ...)``):
#: joint, axis and signed peak angle (deg) of a healthy adult's active range, side letter filled in.
SIMULATED_MOVES = {
    "shoulder_flexion": ("shoulder_{s}", "flexion", 165.0),
    "shoulder_abduction": ("shoulder_{s}", "adduction", -160.0),
    "elbow_flexion": ("elbow_{s}", "flexion", 140.0),
    "hip_flexion": ("hip_{s}", "flexion", 110.0),
    "hip_abduction": ("hip_{s}", "adduction", -40.0),
    "knee_flexion": ("knee_{s}", "flexion", 125.0),
    "trunk_flexion": ("lumbar", "flexion", 75.0),
    "trunk_rotation": ("lumbar", "rotation", 40.0),
}


def simulated_activity(step: RomStep, cycles: int = 5) -> dict:
    """Keyword arguments of ``SuitSimulator.set_activity("rom", ...)`` that make the simulated
    subject do ``step`` (trunk rotation to the right turns the other way)."""
    joint, axis, angle = SIMULATED_MOVES[step.key]
    if step.key == "trunk_rotation" and step.side == "right":
        angle = -angle
    return {"joint": joint.format(s=step.side[0]), "axis": axis, "angle_deg": angle, "cycles": cycles}


def default_steps() -> tuple[RomStep, ...]:
    """Every movement, each side (the whole protocol)."""
    return tuple(RomStep(m.key, side) for m in rom_core.MOVEMENTS for side in rom_core.sides_of(m))


class RomProcedure:
    """See the module doc. ``steps`` (default :func:`default_steps`), ``repeats`` per step."""

    def __init__(self, steps: tuple[RomStep, ...] | None = None, repeats: int = 3,
                 min_prominence_deg: float = 10.0) -> None:
        if int(repeats) != repeats or not 1 <= repeats <= 10:
            raise ValueError(f"repeats must be 1..10, got {repeats}")
        self.steps = tuple(steps) if steps is not None else default_steps()
        if not self.steps:
            raise ValueError("a ROM protocol needs at least one step")
        for step in self.steps:
            if step.side not in rom_core.sides_of(step.movement):
                raise ValueError(f"{step.key} has no side {step.side!r}")
        self.repeats = int(repeats)
        self.min_prominence_deg = float(min_prominence_deg)
        self.index = 0
        self.state = "ready"
        self.active_angle_deg = math.nan
        self.markers: list[tuple[float, str]] = []
        self.results: dict[tuple[str, str], rom_core.RomResult] = {}
        self._reps = rom_core.RepetitionCounter(self.min_prominence_deg)
        self._last_t = math.nan

    # -- where we are ----------------------------------------------------------------------
    @property
    def step(self) -> RomStep | None:
        return self.steps[self.index] if self.index < len(self.steps) else None

    @property
    def instruction(self) -> str:
        if self.state == "finished":
            return "The protocol is complete."
        step = self.step
        if self.state == "ready":
            return f"{step.title}: {step.instruction} Press Start when ready."
        if self.state == "step_done":
            return f"{step.title}: done ({self.repeats} repetitions)."
        left = self.repeats - len(self._reps.peaks)
        return f"{step.title}: {step.instruction} ({left} more)"

    @property
    def peaks_deg(self) -> tuple[float, ...]:
        return tuple(self._reps.peaks)

    @property
    def current_peak_deg(self) -> float:
        """Highest angle of the repetition under way (deg; NaN before any)."""
        return self._reps.peak if math.isfinite(self._reps.peak) else math.nan

    # -- actions -----------------------------------------------------------------------------
    def start_step(self, t_s: float) -> None:
        """Begin measuring the current step at session time ``t_s``."""
        if self.state != "ready":
            raise RuntimeError(f"cannot start a step in state {self.state}")
        step = self.step
        self.markers.append((float(t_s), rom_core.rom_marker_label(step.key, step.side, "start")))
        self._reps = rom_core.RepetitionCounter(self.min_prominence_deg)
        self.state = "measuring"

    def update(self, t_s: np.ndarray, angles_deg: dict[str, np.ndarray],
               q_world_from_segment: dict[str, np.ndarray]) -> None:
        """Feed poses (T,) at times ``t_s``: joint-angle columns (T,) deg and segment
        orientations (T, 4). Updates the active angle and captures repetitions; finishes the
        step after ``repeats`` of them."""
        step = self.step
        if step is None:
            return
        series = rom_core.movement_series(step.movement, step.side, angles_deg, q_world_from_segment)
        times = np.atleast_1d(np.asarray(t_s, dtype=float))
        values = np.atleast_1d(series)
        if values.size:
            self.active_angle_deg = float(values[-1])
        if self.state != "measuring":
            return
        for t, value in zip(times, values):
            self._reps.feed(float(value))
            self._last_t = float(t)
            if len(self._reps.peaks) >= self.repeats:
                self._finish_step(float(t))
                break

    def _finish_step(self, t_s: float) -> None:
        step = self.step
        self.markers.append((t_s, rom_core.rom_marker_label(step.key, step.side, "end")))
        self.results[(step.key, step.side)] = rom_core.RomResult(
            step.key, step.side, tuple(self._reps.peaks), tuple(self._reps.excursions), step.movement.reference_deg)
        self.state = "step_done"

    def finish_step_now(self, t_s: float) -> None:
        """End the current step early with the repetitions captured so far (at least one)."""
        if self.state != "measuring":
            raise RuntimeError(f"no step is being measured (state {self.state})")
        if not self._reps.peaks:
            raise ValueError("no repetition captured yet: do the movement at least once")
        self._finish_step(t_s)

    def next_step(self) -> None:
        """Go to the next step (after the current one is done or skipped)."""
        if self.state == "measuring":
            raise RuntimeError("the current step is still being measured: finish or skip it")
        self.index += 1
        self.state = "ready" if self.index < len(self.steps) else "finished"
        self._reps = rom_core.RepetitionCounter(self.min_prominence_deg)
        self.active_angle_deg = math.nan

    def skip_step(self) -> None:
        """Leave the current step without a result (its start marker is withdrawn)."""
        if self.state == "measuring":
            step = self.step
            start = rom_core.rom_marker_label(step.key, step.side, "start")
            self.markers = [m for m in self.markers if m[1] != start]
        self.state = "step_done"
        self.next_step()
