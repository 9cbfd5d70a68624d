"""What a result holds, said the same way in every output (no Qt).

Every file, report and picture MimuCap writes carries one :class:`Provenance` record, built by
:func:`provenance` alone, so that a reader can tell two numbers apart without asking:

* **result**: *as seen live* (the forward filter) or *reprocessed* (smoothed with past and
  future data), :data:`mimucap.core.pipeline.settings.RESULT_LABELS`;
* **body calibration**: its method, quality, when it was made (local date and time) and where it
  came from (made live, a ``CAL.json`` file, imported), or none, and what that leaves meaningless;
* **magnetometer calibrations**: per sensor its quality and its age at the recording's start
  (ISO dates are compared, so the figure is the same whenever the file is written) and whether
  it corrected the gyroscope's scale (:mod:`mimucap.core.magcal.gyro_scale`), or that the
  raw field was used, or that the device fuses its orientation on board; sensors that read
  alike share a sentence ("S01, S02 magnetometers: good, made 2.0 h before the recording,
  gyroscope scale corrected");
* **skeleton model** ("10-segment skeleton", and the subject's height), **software** version
  (and the one that recorded), **source file**.

Every field is a sentence a clinician reads: qualities in words (:data:`~mimucap.session.views.calibration_age.QUALITY_WORDS`: the
verdicts ``warn`` and ``fail`` read "fair" and "poor"), times in local date and time; the
machine-readable values stay in the files' own fields (the calibrations' JSON, the session's
metadata), never in these lines.

:meth:`Provenance.lines` gives ``Label: text`` lines for text headers (CSV ``#`` lines, ``.mot``
and ``.sto`` header notes, the BVH sidecar, the PDF's first page, the chart's caption);
:meth:`Provenance.parameters` gives ``NAME → [text, ...]`` for C3D's parameter section.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from mimucap import __version__
from mimucap.core.pipeline.settings import RESULT_LABELS
from mimucap.core.skeleton import SkeletonModel
from mimucap.io.library import parse_utc, recorded_utc
from mimucap.session.recorded.calibration_choice import AppliedCalibrations, body_created_utc
from mimucap.session.views.calibration_age import local_time_text, quality_word

#: How each body calibration method is named.
METHOD_NAMES = {"npose_tpose": "N-pose/T-pose", "heading": "heading from a sensor axis",
                "functional": "functional (standing still, then walking)", "xsens-mvn": "Xsens MVN calibration"}
#: What a result without a body calibration cannot give.
WITHOUT_BODY_CALIBRATION = ("none: the segments follow the sensors' own axes, so joint angles, range of motion "
                            "and spatial gait parameters mean nothing")


@dataclass(frozen=True)
class Provenance:
    """What a result holds (module doc); every field a sentence, ``magnetometer`` one per sensor."""

    result: str
    body_calibration: str
    magnetometer: tuple[str, ...]
    skeleton_model: str
    software: str
    source_file: str
    #: where the sensors' headings came from (:func:`heading_lines`); empty for an input whose
    #: orientations were taken as given
    headings: tuple[str, ...] = ()

    #: (field, label, C3D parameter name), in the order every output lists them.
    FIELDS = (("result", "Result", "RESULT"), ("body_calibration", "Body calibration", "BODY_CALIBRATION"),
              ("magnetometer", "Magnetometer calibrations", "MAGNETOMETER"),
              ("headings", "Headings", "HEADINGS"),
              ("skeleton_model", "Skeleton model", "SKELETON_MODEL"), ("software", "Software", "SOFTWARE"),
              ("source_file", "Source file", "SOURCE_FILE"))

    def items(self) -> list[tuple[str, str]]:
        """``(label, text)`` per field; the magnetometer calibrations joined by ``"; "`` (no
        headings line when none is known)."""
        found = []
        for name, label, _parameter in self.FIELDS:
            value = getattr(self, name)
            if name == "headings" and not value:
                continue
            found.append((label, "; ".join(value) if isinstance(value, tuple) else value))
        return found

    def lines(self) -> list[str]:
        """``Label: text`` per field (text headers)."""
        return [f"{label}: {text}" for label, text in self.items()]

    def parameters(self) -> dict[str, list[str]]:
        """C3D parameter name → its strings (one per sensor for the magnetometer calibrations)."""
        found = {}
        for name, _label, parameter in self.FIELDS:
            value = getattr(self, name)
            if name == "headings" and not value:
                continue
            found[parameter] = list(value) if isinstance(value, tuple) else [value]
        return found


def _hours_between(earlier: datetime | None, later: datetime | None) -> float | None:
    if earlier is None or later is None:
        return None
    return (later - earlier).total_seconds() / 3600.0


def describe_offset(hours: float | None, event: str = "the recording") -> str:
    """``"2.5 h before the recording"``, ``"3 days before ..."``, ``"10 min after ..."`` for an
    offset of ``hours`` (positive: before ``event``); ``"date unknown"`` without one."""
    if hours is None:
        return "date unknown"
    side = "before" if hours >= 0 else "after"
    size = abs(hours)
    if size < 1.0 / 60.0:
        return f"within a minute of {event}"
    if size < 1.0:
        amount = f"{size * 60.0:.0f} min"
    elif size < 48.0:
        amount = f"{size:.1f} h"
    else:
        amount = f"{size / 24.0:.0f} days"
    return f"{amount} {side} {event}"


def _magnetometer(calibrations: AppliedCalibrations, recorded: datetime | None) -> tuple[str, ...]:
    """One sentence per group of sensors that read alike (``"S01, S02 magnetometers: good, made
    2.0 h before the recording, gyroscope scale corrected"``), in the sensors' order."""
    said: dict[str, list[str]] = {}
    for sensor_id, calibration in calibrations.magnetometer.items():
        verdict = quality_word((calibration.quality or {}).get("verdict"))
        made = parse_utc(calibration.created_utc)
        gyroscope = "gyroscope scale corrected" if calibration.corrects_gyr else "gyroscope scale not corrected"
        said.setdefault(f"{verdict}, made {describe_offset(_hours_between(made, recorded))}, {gyroscope}",
                        []).append(sensor_id)
    for sensor_id in calibrations.raw_field:
        said.setdefault("not calibrated (the raw field was used)", []).append(sensor_id)
    for sensor_id in calibrations.onboard:
        said.setdefault("none applied (the device fuses its orientation on board)", []).append(sensor_id)
    found = tuple(f"{', '.join(sensors)} magnetometer{'s' if len(sensors) > 1 else ''}: {text}"
                  for text, sensors in said.items())
    return found or ("none (no sensor has a magnetometer)",)


def _body(calibrations: AppliedCalibrations) -> str:
    body = calibrations.body
    if body is None:
        return WITHOUT_BODY_CALIBRATION
    method = METHOD_NAMES.get(body.quality.method, body.quality.method or "method not recorded")
    created = body_created_utc(body)
    when = f"made {local_time_text(created)}" if created else "time not recorded"
    origin = f" ({calibrations.body_origin})" if calibrations.body_origin else ""
    return f"{method}, {quality_word(body.quality.verdict)}, {when}{origin}"


def model_words(model: SkeletonModel) -> str:
    """A skeleton model as people name it: "10-segment skeleton"."""
    return f"{len(model.segment_names)}-segment skeleton"


def heading_lines(mode: str, sources: Mapping[str, Any]) -> tuple[str, ...]:
    """Where the headings came from: the mode in words, then per sensor the share of the pose
    instants of each source (``sources`` sensor → (T,) codes of
    :data:`~mimucap.core.heading_sources.SOURCE_NAMES`), sensors with the same shares together,
    e.g. ``"S09, S10: joint 100 %"``."""
    from mimucap.core.heading_modes import MODE_LABELS
    from mimucap.core.heading_sources import source_summary

    # sensors whose shares read alike are named together, so that a suit's line stays short
    groups: dict[str, list[str]] = {}
    for sensor, shares in source_summary(sources).items():
        groups.setdefault(", ".join(f"{name} {100.0 * share:.0f} %" for name, share in shares.items()), []).append(sensor)
    return (MODE_LABELS.get(mode, mode),) + tuple(f"{', '.join(sensors)}: {text}" for text, sensors in groups.items())


def provenance(*, source_file: str, result: str, calibrations: AppliedCalibrations, model: SkeletonModel,
               height_m: float | None, metadata: Mapping | None = None,
               headings: tuple[str, ...] = ()) -> Provenance:
    """The record of a result (module doc): ``source_file`` the input's name, ``result`` one of
    :data:`~mimucap.core.pipeline.settings.RESULTS` (or a sentence for an input that is no recording),
    the ``calibrations`` applied, the skeleton ``model`` and height (m; None where no figure is
    drawn), the session's ``metadata`` (its recording time and the version that recorded it;
    None for an input that is no MimuCap session)."""
    metadata = metadata or {}
    recorded = parse_utc(recorded_utc(metadata))
    software = f"MimuCap {__version__}"
    recorded_with = metadata.get("mimucap_version")
    if recorded_with and recorded_with != __version__:
        software += f" (recorded with MimuCap {recorded_with})"
    return Provenance(
        result=RESULT_LABELS.get(result, result),
        body_calibration=_body(calibrations),
        magnetometer=_magnetometer(calibrations, recorded),
        skeleton_model=model_words(model)
                       + ("" if height_m is None else f", subject height {height_m:.2f} m"),
        software=software,
        source_file=source_file,
        headings=tuple(headings),
    )
