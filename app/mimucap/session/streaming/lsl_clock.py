"""The Lab Streaming Layer's clock beside the session's (no Qt).

A live session and its recordings run on the host's monotonic clock (``time.monotonic``, s).
LSL stamps every sample with ``pylsl.local_clock()`` (s, liblsl's steady clock; LabRecorder
writes those stamps, corrected to one clock, into its XDF). Both are monotonic clocks of the
same machine, so they differ by a constant: :func:`lsl_offset_s` measures it, and a recording
stores it (``lsl_clock`` of the session metadata, :func:`recording_lsl_clock`), so that an instant
at session time ``t`` (s) is at LSL time ``t + lsl_clock["session_start_lsl_s"]`` in a
LabRecorder XDF of the same minutes.

pylsl is optional (``pip install 'mimucap[lsl]'``): :func:`load_pylsl` imports it or raises
:class:`LslMissing`, whose message says how to install it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

#: How to get Lab Streaming Layer support, for every message that lacks it.
INSTALL_HINT = ("Lab Streaming Layer needs the pylsl package (liblsl comes inside its wheels): "
                "pip install 'mimucap[lsl]', or pip install pylsl pyxdf")

#: Readings of the two clocks :func:`lsl_offset_s` brackets; the narrowest bracket wins.
OFFSET_READINGS = 7


class LslMissing(ValueError):
    """pylsl cannot be imported (not installed, or its liblsl not loadable): the message says
    how to install it."""


def load_pylsl():
    """The ``pylsl`` module; :class:`LslMissing` naming :data:`INSTALL_HINT` when it is absent."""
    try:
        import pylsl
    except (ImportError, RuntimeError, OSError) as error:  # pylsl raises RuntimeError without liblsl
        raise LslMissing(f"{INSTALL_HINT} ({error})") from None
    return pylsl


def lsl_available() -> bool:
    """Whether pylsl can be imported."""
    try:
        load_pylsl()
    except LslMissing:
        return False
    return True


def lsl_offset_s(pylsl=None, clock: Callable[[], float] = time.monotonic) -> float:
    """``pylsl.local_clock() − clock()`` (s): each LSL reading bracketed by two readings of
    ``clock``, the middle of the narrowest of :data:`OFFSET_READINGS` brackets (a few µs)."""
    pylsl = pylsl or load_pylsl()
    best_width, best = float("inf"), 0.0
    for _ in range(OFFSET_READINGS):
        before = clock()
        lsl_s = pylsl.local_clock()
        after = clock()
        if after - before < best_width:
            best_width, best = after - before, lsl_s - 0.5 * (before + after)
    return best


def recording_lsl_clock(start_host_s: float, clock: Callable[[], float] = time.monotonic) -> dict[str, Any] | None:
    """What a recording that starts at host time ``start_host_s`` (s, on ``clock``) stores of the
    LSL clock (session metadata ``lsl_clock``): ``offset_s`` (LSL clock − host clock, s) and
    ``session_start_lsl_s`` (the LSL time of session time 0, s); ``None`` without pylsl."""
    try:
        offset = lsl_offset_s(clock=clock)
    except LslMissing:
        return None
    return {"offset_s": offset, "session_start_lsl_s": float(start_host_s) + offset,
            "note": "LSL time of an instant = its session time + session_start_lsl_s (pylsl.local_clock)"}
