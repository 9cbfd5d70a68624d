"""Skeleton models by name or from a JSON file of one's own.

A model file is a ``mimucap-skeleton`` document, format version 1 (the built-in models in
:mod:`mimucap.core.skeleton_models` show every field): segments from the root outwards, each
with its parent, joint name, side, and its length, attachment, direction and radius as
fractions of body height in the segment frames described there. :func:`save_model_document`
writes a document, e.g. a built-in model to start from.
"""

from __future__ import annotations

import json
from pathlib import Path

from mimucap.core.skeleton import MODEL_NAMES, SkeletonModel, model_from_dict
from mimucap.core.skeleton import load_model as built_in_model
from mimucap.core.skeleton_models import BUILT_IN_MODELS
from mimucap.io.json_document import read_json_document


def load_model(name_or_path: str | Path = "ten_segment") -> SkeletonModel:
    """The built-in model ``name_or_path`` (one of :data:`MODEL_NAMES`), or the model in the
    JSON file at that path; a bad file raises ``ValueError`` naming it (and the line, for
    invalid JSON)."""
    if str(name_or_path) in MODEL_NAMES:
        return built_in_model(str(name_or_path))
    path = Path(name_or_path)
    if not path.suffix:
        raise ValueError(f"unknown skeleton model {str(name_or_path)!r}; use one of {', '.join(MODEL_NAMES)} "
                         f"or a JSON file")
    data = read_json_document(path, "skeleton model")
    return model_from_dict(data, str(path))


def save_model_document(name: str, path: str | Path) -> Path:
    """Write the built-in model ``name`` as a JSON model file at ``path`` (to edit into one's own)."""
    if name not in BUILT_IN_MODELS:
        raise ValueError(f"unknown skeleton model {name!r}; use one of {', '.join(MODEL_NAMES)}")
    path = Path(path)
    path.write_text(json.dumps(BUILT_IN_MODELS[name], indent=2) + "\n", encoding="utf-8")
    return path
