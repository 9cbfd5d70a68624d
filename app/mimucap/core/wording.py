"""Small rules for the numbers and words people read (no Qt): proper plurals, no "-0.0"."""

from __future__ import annotations

import math


def plural(count: int, singular: str, plural_form: str | None = None) -> str:
    """"1 sensor", "2 sensors", "0 markers"; ``plural_form`` for irregular words ("1 analysis",
    "2 analyses")."""
    word = singular if count == 1 else (plural_form or singular + "s")
    return f"{count} {word}"


def fixed(value: float, decimals: int) -> str:
    """``value`` with ``decimals`` decimals, never "-0.0" (a value that rounds to zero has no sign);
    "–" for a value that is not a number."""
    if value is None or not math.isfinite(float(value)):
        return "–"
    text = f"{float(value):.{decimals}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text
