"""The subject record of a session.

Only what the analysis needs is asked for (no name, no birth date): a pseudonymous id, the
height (m, scales the skeleton), the dominant side, and free notes.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from mimucap.io.session import make_subject

DOMINANCE = ("right", "left", "unknown")
_ID_RE = re.compile(r"^[A-Za-z0-9_.-]{1,40}$")


@dataclass(frozen=True)
class Subject:
    """``subject_id`` letters, digits, ``_.-`` (1–40); ``height_m`` 0.5–2.5 m; ``dominance``
    one of :data:`DOMINANCE`; ``notes`` free text (no personal data, please)."""

    subject_id: str = "S001"
    height_m: float = 1.75
    dominance: str = "right"
    notes: str = ""

    def __post_init__(self) -> None:
        if not _ID_RE.match(self.subject_id or ""):
            raise ValueError(f"subject id {self.subject_id!r}: use 1-40 letters, digits, '_', '.' or '-'")
        if not 0.5 <= float(self.height_m) <= 2.5:
            raise ValueError(f"subject height must be between 0.5 and 2.5 m, got {self.height_m}")
        if self.dominance not in DOMINANCE:
            raise ValueError(f"side dominance must be one of {', '.join(DOMINANCE)}, got {self.dominance!r}")

    def to_dict(self) -> dict:
        """The session file's ``metadata["subject"]`` record (:func:`mimucap.io.session.make_subject`)."""
        return make_subject(self.subject_id, self.height_m, self.dominance, self.notes)
