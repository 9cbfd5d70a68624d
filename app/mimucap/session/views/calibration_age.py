"""How old a calibration is, in the words the windows use ("3 days ago"), how good it is ("fair"),
and a moment in local date and time ("28 Nov 2026, 09:14") (no Qt).

Ages are computed from a calibration's ``created_utc`` (ISO 8601, UTC) against an aware UTC
``now``; they are read in the magnetometer wizard, the sensor table and the checklist alike.
"""

from __future__ import annotations

import datetime as _dt

from mimucap.core.wording import plural
from mimucap.io.library import parse_utc

#: A calibration's verdict (magnetometer: good/warn/fail; body: good/acceptable/poor) as people read it.
QUALITY_WORDS = {"good": "good", "warn": "fair", "acceptable": "fair", "fail": "poor", "poor": "poor"}


def quality_word(verdict: str | None) -> str:
    """A calibration's verdict in words (:data:`QUALITY_WORDS`); "quality unknown" without one."""
    if not verdict:
        return "quality unknown"
    return QUALITY_WORDS.get(verdict, verdict)


def utc_now() -> _dt.datetime:
    """The wall clock now, an aware UTC datetime."""
    return _dt.datetime.now(_dt.timezone.utc)


def age_days_since(created_utc: str, now: _dt.datetime) -> float | None:
    """Days (≥ 0) from ``created_utc`` to ``now``; ``None`` when the date cannot be read."""
    created = parse_utc(created_utc)
    if created is None:
        return None
    return max((now - created).total_seconds() / 86400.0, 0.0)


def describe_age(age_days: float | None) -> str:
    """"3 days ago", "5 hours ago", "just now" or "date unknown"."""
    if age_days is None:
        return "date unknown"
    hours = age_days * 24.0
    if hours < 1.0:
        return "just now" if hours < 1.0 / 60.0 else f"{plural(round(hours * 60.0), 'minute')} ago"
    if age_days < 2.0:
        return f"{plural(round(hours), 'hour')} ago"
    return f"{plural(round(age_days), 'day')} ago"


def local_time_text(iso_utc: str) -> str:
    """An ISO 8601 time (UTC when it names no zone) as the local date and time people read
    ("28 Nov 2026, 09:14"); the text itself when it is not one, "not recorded" when empty."""
    moment = parse_utc(iso_utc)
    if moment is None:
        return str(iso_utc) or "not recorded"
    return moment.astimezone().strftime("%d %b %Y, %H:%M")
