"""What the processing path is run with, and which result it gives (no I/O, no Qt).

A recording stores what the path needs to run again: :class:`PipelineSettings` (the filter's
parameters, where the headings come from) and each sensor's filter state when the recording started (:func:`state_to_dict`,
:func:`state_from_dict`: the JSON form). Two results exist: :data:`RESULT_LIVE`, the forward
filter as the live view ran it (continuing from that state), and :data:`RESULT_REPROCESSED`,
the same filter smoothed over the whole recording with past and future data
(Rauch-Tung-Striebel; what Xsens calls HD reprocessing), from the same prior.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from mimucap.core import heading_modes
from mimucap.core.fusion.params import DEFAULT_FUSION_PARAMS, FusionParams
from mimucap.core.fusion.state import FusionState

RESULT_LIVE = "live"
RESULT_REPROCESSED = "reprocessed"
#: How screens and file headers name each result.
RESULT_LABELS = {RESULT_LIVE: "as seen live (forward filter)",
                 RESULT_REPROCESSED: "reprocessed (filter smoothed with past and future data)"}
RESULTS = (RESULT_LIVE, RESULT_REPROCESSED)
#: The same results in a word or two, for a choice between them (a combo box, a status line).
RESULT_TITLES = {RESULT_REPROCESSED: "Reprocessed", RESULT_LIVE: "As seen live"}


def check_result(result: str) -> str:
    """``result`` when it is one of :data:`RESULTS`, else ``ValueError`` listing them."""
    if result not in RESULTS:
        raise ValueError(f"unknown result {result!r}; use one of {', '.join(RESULTS)}")
    return result


@dataclass(frozen=True)
class PipelineSettings:
    """Settings of the processing path that a recording stores so that it can be recomputed.

    ``fusion``: the orientation filter's parameters (units in their names); ``heading``: where
    the sensors' headings come from (:data:`~mimucap.core.heading_modes.MODES`).
    """

    fusion: FusionParams = DEFAULT_FUSION_PARAMS
    heading: str = heading_modes.MODE_COUPLED

    def __post_init__(self) -> None:
        heading_modes.check_mode(self.heading)

    @property
    def uses_magnetometers(self) -> bool:
        """Whether the filters fuse the magnetometers (all modes but no-magnetometer)."""
        return self.heading != heading_modes.MODE_NO_MAGNETOMETER

    def to_dict(self) -> dict[str, Any]:
        return {"fusion": asdict(self.fusion), "heading": self.heading}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any] | None, origin: str = "pipeline settings") -> "PipelineSettings":
        """Inverse of :meth:`to_dict`; an unknown filter parameter name raises ``ValueError``."""
        if not data:
            return cls()
        try:
            fusion = FusionParams(**dict(data.get("fusion") or {}))
            return cls(fusion=fusion, heading=str(data.get("heading", heading_modes.MODE_COUPLED)))
        except (TypeError, ValueError) as error:
            raise ValueError(f"{origin}: {error}") from None


DEFAULT_PIPELINE_SETTINGS = PipelineSettings()


def state_to_dict(state: FusionState) -> dict[str, list]:
    """A one-sensor :class:`~mimucap.core.fusion.state.FusionState` as JSON-ready lists."""
    return {"q_world_from_sensor": state.q_world_from_sensor[0].tolist(), "bias_rad_s": state.bias_rad_s[0].tolist(),
            "cov": state.cov[0].tolist(), "aux": state.aux[0].tolist()}


def state_from_dict(data: Mapping[str, Any], origin: str) -> FusionState:
    """Inverse of :func:`state_to_dict`; ``ValueError`` naming ``origin`` when malformed.

    The ``aux`` of a recording made before the layout grew is a prefix of today's (new entries
    are appended, :mod:`~mimucap.core.fusion.state`): the entries it lacks start at zero, as in
    a new filter."""
    template = FusionState.new(1)
    try:
        arrays = [np.asarray(data[name], dtype=np.float64)[None]
                  for name in ("q_world_from_sensor", "bias_rad_s", "cov", "aux")]
    except (KeyError, TypeError, ValueError) as error:
        raise ValueError(f"{origin}: malformed filter state ({error!r})") from None
    aux = arrays[3]
    if aux.ndim == 2 and 0 < aux.shape[1] < template.aux.shape[1]:
        arrays[3] = np.concatenate([aux, np.zeros((1, template.aux.shape[1] - aux.shape[1]))], axis=1)
    for array, name, like in zip(arrays, ("q", "bias", "cov", "aux"),
                                 (template.q_world_from_sensor, template.bias_rad_s, template.cov, template.aux)):
        if array.shape != like.shape or not np.all(np.isfinite(array)):
            raise ValueError(f"{origin}: filter state {name} must be finite with shape {like.shape[1:]}")
    return FusionState(*arrays)
