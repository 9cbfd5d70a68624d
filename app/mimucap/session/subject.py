"""The subject record of a session.

Only what the analysis needs is asked for (no name, no birth date): a pseudonymous id, the
height (m, scales the skeleton), the dominant side, free notes, and optionally the age, sex and
weight that the clinical tests' reference values depend on.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from mimucap.io.session import SEXES, make_subject

DOMINANCE = ("right", "left", "unknown")
_ID_RE = re.compile(r"^[A-Za-z0-9_.-]{1,40}$")


@dataclass(frozen=True)
class Subject:
    """``subject_id`` letters, digits, ``_.-`` (1–40); ``height_m`` 0.5–2.5 m; ``dominance``
    one of :data:`DOMINANCE`; ``notes`` free text (no personal data, please); optional
    ``age_years``, ``sex`` (one of :data:`~mimucap.io.session.SEXES`) and ``weight_kg``."""

    subject_id: str = "S001"
    height_m: float = 1.75
    dominance: str = "right"
    notes: str = ""
    age_years: float | None = None
    sex: str = ""
    weight_kg: float | None = None

    def __post_init__(self) -> None:
        if not _ID_RE.match(self.subject_id or ""):
            raise ValueError(f"subject id {self.subject_id!r}: use 1-40 letters, digits, '_', '.' or '-'")
        if not 0.5 <= float(self.height_m) <= 2.5:
            raise ValueError(f"subject height must be between 0.5 and 2.5 m, got {self.height_m}")
        if self.dominance not in DOMINANCE:
            raise ValueError(f"side dominance must be one of {', '.join(DOMINANCE)}, got {self.dominance!r}")
        self.to_dict()  # the record's own checks: age, sex, weight

    def to_dict(self) -> dict:
        """The session file's ``metadata["subject"]`` record (:func:`mimucap.io.session.make_subject`)."""
        return make_subject(self.subject_id, self.height_m, self.dominance, self.notes, self.age_years, self.sex,
                            self.weight_kg)

    @classmethod
    def from_record(cls, record: dict) -> Subject:
        """The subject of a session file's ``metadata["subject"]`` (missing fields: defaults)."""
        sex = str(record.get("sex") or "")
        return cls(str(record.get("id") or "S001"), float(record.get("height_m") or 1.75),
                   str(record.get("dominance") or "unknown"), str(record.get("notes") or ""),
                   _number(record.get("age_years")), sex if sex in SEXES else "", _number(record.get("weight_kg")))


def _number(value) -> float | None:
    return None if value is None else float(value)
