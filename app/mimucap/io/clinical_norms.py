"""Published reference values of the clinical tests: the shipped file
``resources/norms/clinical-tests.json`` (format ``mimucap-clinical-norms 1``), and the
reference that applies to one subject.

Each test (``tug``, ``10mwt``, ``2mwt``, ``6mwt``, ``chair-stand``) has its ``source`` (the
publication), the result ``key`` it refers to, what its numbers are (``statistic``) and either
``rows`` (each for an age range ``age_min``..``age_max`` in whole years and, where the source
splits them, a ``sex``; with ``mean`` and optionally ``ci95_low``/``ci95_high``, or the
percentiles ``p25``/``p75``) or ``equations`` per sex (a prediction linear in ``height_cm``,
``age_years`` and ``weight_kg`` plus ``constant``, with the lower limit of normal
``lower_limit_below_m`` below it, valid for ``age_min``..``age_max``). ``not_entered`` says which
of the source's values were left out because they could not be checked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from mimucap.io.json_document import read_json_document

FORMAT = "mimucap-clinical-norms 1"
NORMS_RESOURCE = "norms/clinical-tests.json"


@dataclass(frozen=True)
class Reference:
    """The reference of one result for one subject: ``key`` (the result it applies to),
    ``values`` (e.g. ``mean``, ``ci95_low``, ``p25``, ``predicted``, ``lower_limit``), ``group``
    (whom it describes, e.g. "women 70-79 years"), ``statistic``, ``source``."""

    key: str
    values: dict[str, float]
    group: str
    statistic: str
    source: str

    def to_dict(self) -> dict[str, Any]:
        return {"key": self.key, **self.values, "group": self.group, "statistic": self.statistic,
                "source": self.source}


def read_norms(path: str | Path | None = None) -> dict[str, Any]:
    """The norms document (default: the shipped file); ``ValueError`` naming the file when it
    is not one."""
    if path is None:
        from mimucap.resources import resource_path

        path = resource_path(NORMS_RESOURCE)
    document = read_json_document(path, "clinical norms table")
    if not isinstance(document, dict) or document.get("format") != FORMAT or not isinstance(document.get("tests"), dict):
        raise ValueError(f"{path}: not a clinical norms file (format '{FORMAT}' with 'tests')")
    for test, table in document["tests"].items():
        if not table.get("source") or not table.get("key"):
            raise ValueError(f"{path}: the norms of {test} lack their source or key")
    return document


def reference_for(norms: dict[str, Any], test: str, subject: dict[str, Any]) -> tuple[Reference | None, str]:
    """The reference of ``test`` for ``subject`` (a session's subject record: ``age_years``,
    ``sex``, ``height_m``, ``weight_kg``), and a sentence saying why there is none."""
    table = norms["tests"].get(test)
    if table is None:
        return None, f"no published reference for {test} is shipped"
    age = subject.get("age_years")
    sex = str(subject.get("sex") or "")
    if "equations" in table:
        return _from_equations(table, sex, age, subject.get("height_m"), subject.get("weight_kg"))
    rows = table.get("rows", [])
    by_sex = any("sex" in row for row in rows)
    if by_sex and not sex:
        return None, "the subject's sex is not in the session's subject record (the reference depends on it)"
    if age is None and any(row["age_max"] - row["age_min"] < 60 for row in rows):
        return None, "the subject's age is not in the session's subject record (the reference depends on it)"
    for row in rows:
        if by_sex and row.get("sex") != sex:
            continue
        if age is not None and not row["age_min"] <= math.floor(float(age)) <= row["age_max"]:
            continue
        values = {k: float(v) for k, v in row.items() if k not in ("sex", "age_min", "age_max")}
        group = f"{_people(row.get('sex', ''))} {row['age_min']}-{row['age_max']} years"
        return Reference(table["key"], values, group, table["statistic"], table["source"]), ""
    ages = sorted({(row["age_min"], row["age_max"]) for row in rows})
    return None, (f"the source gives no reference for age {age:g}" if age is not None else "no reference applies") + \
        f" (it covers {ages[0][0]}-{ages[-1][1]} years)"


def _from_equations(table: dict[str, Any], sex: str, age, height_m, weight_kg) -> tuple[Reference | None, str]:
    missing = [name for name, value in (("sex", sex or None), ("age", age), ("height", height_m), ("weight", weight_kg))
               if value is None]
    if missing:
        return None, f"the subject's {', '.join(missing)} not in the session's subject record (the prediction needs them)"
    if not table["age_min"] <= float(age) <= table["age_max"]:
        return None, f"the reference equations hold for {table['age_min']}-{table['age_max']} years, not {float(age):g}"
    equation = table["equations"][sex]
    predicted = (equation["constant"] + equation["height_cm"] * 100.0 * float(height_m)
                 + equation["age_years"] * float(age) + equation["weight_kg"] * float(weight_kg))
    values = {"predicted": predicted, "lower_limit": predicted - equation["lower_limit_below_m"]}
    group = f"{_people(sex)} {float(age):g} years, {100.0 * float(height_m):.0f} cm, {float(weight_kg):g} kg"
    return Reference(table["key"], values, group, table["statistic"], table["source"]), ""


def _people(sex: str) -> str:
    return {"female": "women", "male": "men"}.get(sex, "adults")
