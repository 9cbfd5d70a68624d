"""A clinical test's result as people read it, and kept across visits (no Qt).

* :func:`result_rows`: the result's figures with their units and the published reference, as the
  window, the report and the trend show them;
* :func:`store_in_library` keeps a result in the library index of the folder holding its session
  (result name ``clinical_test:<test>``, :meth:`mimucap.io.library.Library.store_result`);
* :func:`earlier_results` and :func:`subject_trend`: a subject's results of one test across visits,
  oldest first, for the report's "earlier visits" and the library's trend chart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mimucap.io.library import INDEX_NAME, Library, LibraryError
from mimucap.session.clinical_tests import RESULT_KEYS, TEST_NAMES, ClinicalTestResult

#: Result key → (name people read, unit, decimals).
QUANTITIES: dict[str, tuple[str, str, int]] = {
    "total_s": ("Total time", "s", 1),
    "sit_to_stand_s": ("Sit-to-stand", "s", 1),
    "walk_out_s": ("Walk out", "s", 1),
    "turn_s": ("Turn", "s", 1),
    "walk_back_s": ("Walk back", "s", 1),
    "turn_to_sit_s": ("Turn-to-sit", "s", 1),
    "speed_m_s": ("Gait speed", "m/s", 2),
    "cadence_steps_min": ("Cadence", "steps/min", 0),
    "distance_m": ("Distance walked", "m", 0),
    "stands": ("Full stands", "", 0),
    "cycle_s": ("Mean sit-stand-sit cycle", "s", 2),
}
#: The result of each test that its trend and reference follow.
MAIN_RESULT = {"tug": "total_s", "10mwt": "speed_m_s", "2mwt": "distance_m", "6mwt": "distance_m",
               "chair-stand": "stands"}
#: Library result name prefix.
RESULT_PREFIX = "clinical_test:"
#: Reference value names as people read them.
_REFERENCE_WORDS = {"mean": "mean", "ci95_low": "95 % CI from", "ci95_high": "to", "p25": "25th percentile",
                    "p75": "75th percentile", "predicted": "predicted", "lower_limit": "lower limit of normal"}


def format_quantity(key: str, value: float | None) -> str:
    """``value`` of result ``key`` with its unit ("12.3 s"; "–" when not measured; never "-0")."""
    if value is None or not math.isfinite(float(value)):
        return "–"
    _name, unit, decimals = QUANTITIES[key]
    text = f"{float(value) + 0.0:.{decimals}f}"
    if text.lstrip("-").strip("0.") == "":
        text = text.lstrip("-")
    return f"{text} {unit}".strip()


def reference_text(key: str, reference: dict[str, Any] | None) -> str:
    """The reference of result ``key`` in words ("" when the reference is of another result)."""
    if reference is None or reference.get("key") != key:
        return ""
    parts = []
    for name, words in _REFERENCE_WORDS.items():
        if name in reference:
            parts.append(f"{words} {format_quantity(key, reference[name])}")
    return f"{', '.join(parts)} ({reference.get('group', '')})"


def result_rows(result: ClinicalTestResult) -> list[tuple[str, str, str]]:
    """(name, value with unit, reference) for every figure of ``result``, the main one first."""
    keys = RESULT_KEYS[result.test]
    rows = [(QUANTITIES[key][0], format_quantity(key, result.values.get(key)), reference_text(key, result.reference))
            for key in keys]
    details = result.details
    if result.test == "tug":
        for name, key in (("Trunk peak turning rate, turn", "turn_peak_trunk_rate_dps"),
                          ("Trunk peak turning rate, turn-to-sit", "turn_to_sit_peak_trunk_rate_dps")):
            value = details.get(key)
            if value is not None and math.isfinite(float(value)):
                rows.append((name, f"{float(value):.0f} °/s", ""))
    elif result.test in ("2mwt", "6mwt"):
        for minute, speed in enumerate(details.get("minute_speeds_m_s") or [], start=1):
            rows.append((f"Speed, minute {minute}", format_quantity("speed_m_s", speed), ""))
        change = details.get("last_vs_first_minute_percent")
        if change is not None and math.isfinite(float(change)):
            rows.append(("Last minute against the first", f"{float(change):+.0f} %", ""))
    return rows


# -- across visits ----------------------------------------------------------------------------------
def find_library(session_path: str | Path) -> Library | None:
    """The library whose folder holds ``session_path`` (its index in that folder or above), or None."""
    for folder in Path(session_path).resolve().parents:
        if (folder / INDEX_NAME).is_file():
            try:
                return Library(folder)
            except LibraryError:
                return None
    return None


def store_in_library(session_path: str | Path, result: ClinicalTestResult, library_root: str | Path | None = None) -> str:
    """Keep ``result`` in the library of its session (``library_root``, else the library found
    above the session; scanned first, so a new recording is in the index); a sentence saying
    where, or why not ("" when the session is in no library)."""
    try:
        library = Library(library_root) if library_root is not None else find_library(session_path)
        if library is None:
            return ""
        library.scan()
        library.store_result(session_path, RESULT_PREFIX + result.test, result.to_dict())
    except (LibraryError, KeyError, ValueError, OSError) as error:
        return f"Not kept in the library: {error}."
    return f"Kept in the library ({library.root}) for the trend of this subject's visits."


@dataclass(frozen=True)
class Visit:
    """One earlier or later run of a test: ``recorded_utc`` (ISO 8601), ``session`` (path in the
    library), ``values`` (the result's keys), ``result`` (live or reprocessed)."""

    recorded_utc: str
    session: str
    values: dict[str, float | None]
    result: str


def subject_trend(library: Library, subject_id: str, test: str) -> list[Visit]:
    """The subject's stored results of ``test`` across the library's sessions, oldest first."""
    if test not in TEST_NAMES:
        raise ValueError(f"unknown clinical test {test!r}")
    visits = []
    for entry in library.sessions(subject_id):
        stored = library.result(entry.path, RESULT_PREFIX + test)
        if stored is None:
            continue
        values = {key: stored.get(key) for key in RESULT_KEYS[test]}
        visits.append(Visit(entry.recorded_utc, entry.path, values, str(stored.get("result", ""))))
    return sorted(visits, key=lambda v: (v.recorded_utc, v.session))


def earlier_results(session_path: str | Path, test: str, library_root: str | Path | None = None) -> list[Visit]:
    """The subject's results of ``test`` recorded before the session ``session_path`` (itself
    excluded), from its library (``library_root``, else the one found above the session);
    empty when it is in none."""
    try:
        library = Library(library_root) if library_root is not None else find_library(session_path)
        if library is None:
            return []
        relative = library.relative(session_path)
    except (LibraryError, ValueError):
        return []
    entry = next((e for e in library.sessions() if e.path == relative), None)
    if entry is None:
        return []
    return [v for v in subject_trend(library, entry.subject_id, test)
            if v.session != relative and v.recorded_utc <= entry.recorded_utc]
