"""What a calibration procedure asks of the subject, as one record for every source (no Qt).

A procedure gives an :class:`Instruction` ("hold still in N-pose", "raise both arms", "turn
sensors S01, S02 once about each axis"); the screen shows its ``text`` to the person, and the
source is told too (:meth:`mimucap.session.live.LiveSession.instruct`): a source of real sensors
has nobody to tell but the person at the screen, the simulated suit's subject does what the
instruction says. No procedure asks which kind of source it has. :data:`RESUME` ends a
procedure's instructions (the simulated subject goes back to its scenario).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

NPOSE = "npose"
TPOSE = "tpose"
TURN_SENSORS = "turn_sensors"
MOVE_JOINT = "move_joint"
PREPARE_TEST = "prepare_test"
PERFORM_TEST = "perform_test"
RESUME_KIND = "resume"
KINDS = (NPOSE, TPOSE, TURN_SENSORS, MOVE_JOINT, PREPARE_TEST, PERFORM_TEST, RESUME_KIND)

#: Magnetometer protocols and how often each one turns the bundle (see core.magcal_guidance).
PROTOCOL_TURNS = {"single_axis": 1, "figure8": 3, "free": 2}

_ARMS_TEXT = {"both": "both arms", "right": "the right arm", "left": "the left arm"}


@dataclass(frozen=True)
class Instruction:
    """One thing the subject is asked to do.

    ``kind``: one of :data:`KINDS`; ``text``: the sentence the screen shows; ``arms``
    (``both``/``left``/``right``) for a T-pose; ``sensor_ids`` and ``protocol``
    (``single_axis``, ``figure8``, ``free``) for turning sensors; ``movement`` (a key of
    :data:`mimucap.core.analysis.rom.MOVEMENTS`) and ``side`` for a range-of-motion movement;
    ``test`` (a clinical test: ``tug``, ``10mwt``, ``2mwt``, ``6mwt``, ``chair-stand``) and
    ``walkway_m`` (its walkway, m; 0: the test's default) for getting ready for a test and doing it.
    """

    kind: str
    text: str
    arms: str = "both"
    sensor_ids: tuple[str, ...] = ()
    protocol: str = "single_axis"
    movement: str = ""
    side: str = ""
    test: str = ""
    walkway_m: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown instruction {self.kind!r}; use one of {', '.join(KINDS)}")
        if self.arms not in _ARMS_TEXT:
            raise ValueError(f"arms must be one of {', '.join(_ARMS_TEXT)}, got {self.arms!r}")
        if self.protocol not in PROTOCOL_TURNS:
            raise ValueError(f"unknown magnetometer protocol {self.protocol!r}; use one of {', '.join(PROTOCOL_TURNS)}")


def npose() -> Instruction:
    return Instruction(NPOSE, "Stand upright, arms hanging at the sides, palms in, and hold still")


def tpose(arms: str = "both") -> Instruction:
    if arms not in _ARMS_TEXT:
        raise ValueError(f"arms must be one of {', '.join(_ARMS_TEXT)}, got {arms!r}")
    return Instruction(TPOSE, f"Raise {_ARMS_TEXT[arms]} sideways to shoulder height, palms down, and hold still",
                       arms=arms)


def turn_sensors(sensor_ids: Sequence[str], protocol: str = "single_axis") -> Instruction:
    names = ", ".join(sensor_ids)
    texts = {
        "single_axis": f"Hold {names} together and turn them one full turn about each of their axes in turn",
        "figure8": f"Hold {names} together and wave them in figure-8 loops in every direction",
        "free": f"Hold {names} together and turn them slowly through every orientation",
    }
    if protocol not in texts:
        raise ValueError(f"unknown magnetometer protocol {protocol!r}; use one of {', '.join(texts)}")
    return Instruction(TURN_SENSORS, texts[protocol], sensor_ids=tuple(sensor_ids), protocol=protocol)


def move_joint(movement: str, side: str, text: str) -> Instruction:
    """Do range-of-motion ``movement`` on ``side`` (``left``, ``right`` or ``both``) as far as
    it goes, repeatedly; ``text`` is the movement's instruction on the screen."""
    return Instruction(MOVE_JOINT, text, movement=movement, side=side)


def prepare_test(test: str, text: str, walkway_m: float = 0.0) -> Instruction:
    """Get ready for clinical test ``test`` (sit on the chair, or stand at the start line) and
    wait for the start signal; ``text`` is what the screen says."""
    return Instruction(PREPARE_TEST, text, test=test, walkway_m=float(walkway_m))


def perform_test(test: str, text: str, walkway_m: float = 0.0) -> Instruction:
    """The start signal of clinical test ``test``: do it now."""
    return Instruction(PERFORM_TEST, text, test=test, walkway_m=float(walkway_m))


def put_sensors_back() -> Instruction:
    """After turning the sensors: put them back on and stand in the N-pose."""
    return Instruction(NPOSE, "Put the sensors back on and stand in the N-pose")


RESUME = Instruction(RESUME_KIND, "Carry on")
