"""The simulator's scenarios: activities by name, the demo loop, the magnetometer turns that
begin a session, and the activity sequence of every scenario of
:data:`mimucap.core.simulate.names.SCENARIOS`."""

from __future__ import annotations

from collections.abc import Callable, Iterator

from mimucap.core.simulate.activities import (
    Activity,
    ArmRaise,
    HoldSensors,
    JointExcursion,
    NPose,
    Squat,
    TPose,
    Turn,
)
from mimucap.core.simulate.clinical_tests import CLINICAL_TESTS, clinical_test_activities
from mimucap.core.simulate.names import ACTIVITY_NAMES
from mimucap.core.simulate.walking import Walk


def make_activity(name: str, params: dict | None = None, *, sensor_ids: tuple[str, ...] = (), seed: int = 0) -> Activity:
    """Build an activity by name with keyword ``params``; unknown names or parameters raise
    ``ValueError``. Hand-held activities default to holding ``sensor_ids``."""
    params = dict(params or {})
    factories: dict[str, Callable[..., Activity]] = {
        "npose": NPose, "tpose": TPose, "walk": Walk, "turn": Turn, "arm_raise": ArmRaise, "squat": Squat,
        "rom": JointExcursion,
    }
    try:
        if name in factories:
            return factories[name](**params)
        if name.startswith("mag_") and name[4:] in ("single_axis", "figure8", "tumble"):
            params["sensor_ids"] = tuple(params.get("sensor_ids") or sensor_ids)
            return HoldSensors(name[4:], seed=seed, **params)
    except TypeError as error:
        raise ValueError(f"activity {name!r}: {error}") from None
    raise ValueError(f"unknown activity {name!r}; use one of {', '.join(ACTIVITY_NAMES + ('demo',))}")


def demo_cycle() -> list[Activity]:
    """One loop of the demo: N-pose 3 s, T-pose 3 s, N-pose 2 s, walk 8 s, turn 180°, walk
    back 8 s, turn 180°, two squats, two forward arm raises (about 50 s)."""
    return [
        NPose(3.0), TPose(3.0, arms="both"), NPose(2.0), Walk(8.0), Turn(turns=1, angle_deg=180.0, pause_s=0.5),
        Walk(8.0), Turn(turns=1, angle_deg=-180.0, pause_s=0.5), Squat(cycles=2), ArmRaise(cycles=2),
    ]




def _demo_loop() -> Iterator[Activity]:
    while True:
        yield from demo_cycle()


def magcal_turns(sensor_ids: tuple[str, ...] = (), seed: int = 0) -> HoldSensors:
    """The magnetometer turns of a session's start: every unit (``sensor_ids``; all if empty)
    taken off the body, held together and turned one full turn about its x, then y, then z axis
    (the single-axis protocol of Choe, Zhao, Qiu and So, "Study of calibration method of
    low-cost MEMS magnetometer"), about 26 s; the units are put back by the next activity."""
    turns = HoldSensors("single_axis", sensor_ids=tuple(sensor_ids), turns=1, seed=seed)
    turns.duration_s = turns.path.duration_s
    return turns


def _after_magcal_turns(activities: Iterator[Activity], turns: HoldSensors) -> Iterator[Activity]:
    """``turns``, then ``activities``; a first N-pose of fixed length is lengthened by the time
    the units take to be put back on the body, so that it still holds its full still time."""
    yield turns
    first = next(activities, None)
    if first is None:
        return
    if isinstance(first, NPose) and first.duration_s is not None:
        first.duration_s += turns.blend_out_s
    yield first
    yield from activities


def scenario_activities(name: str, params: dict | None = None, *, sensor_ids: tuple[str, ...] = (),
                        seed: int = 0, with_magcal_turns: bool = False) -> Iterator[Activity]:
    """The activities of a scenario in order (an endless iterator for ``demo``).

    ``demo`` loops :func:`demo_cycle`; ``bodycal`` is N-pose 3 s, T-pose 3 s (``params`` go to
    the T-pose), then N-pose; any activity name is that activity alone, preceded by 1 s of
    N-pose unless it is ``npose``. With ``with_magcal_turns`` the scenario begins with
    :func:`magcal_turns` of ``sensor_ids``. Parameters are checked here, before anything runs.
    """
    activities = _scenario(name, params, sensor_ids, seed)
    if with_magcal_turns:
        return _after_magcal_turns(activities, magcal_turns(sensor_ids, seed))
    return activities


def _scenario(name: str, params: dict | None, sensor_ids: tuple[str, ...], seed: int) -> Iterator[Activity]:
    if name == "demo":
        if params:
            raise ValueError("the demo scenario takes no parameters")
        return _demo_loop()
    if name in CLINICAL_TESTS:
        return iter(clinical_test_activities(name, params, seed))
    if name == "bodycal":
        try:
            tpose = TPose(3.0, **(params or {}))
        except TypeError as error:
            raise ValueError(f"scenario 'bodycal': {error}") from None
        return iter([NPose(3.0), tpose, NPose()])
    activity = make_activity(name, params, sensor_ids=sensor_ids, seed=seed)
    activity.duration_s = None
    if name == "npose":
        return iter([activity])
    return iter([NPose(1.0, sway_deg=0.0 if name.startswith("mag_") else 0.3), activity])
