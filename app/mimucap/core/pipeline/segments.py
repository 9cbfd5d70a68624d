"""Step 4 of the processing path: segments from sensors, the body-calibration step (no I/O, no Qt).

Body calibration (Podoprosvetov, Aliseychik, Orlov, Rebrik, "Calibration algorithm for MIMU
sensors group"): ``q_world_from_segment = q_world_from_sensor ⊗ q_sensor_from_segment``; without
one, each assigned sensor's axes stand for its segment's. Segments without a sensor follow their
parents; a root without one faces north (:func:`segments_from_sensors`).

:class:`SegmentStage` is this step for all sensors at once, in the live form (one instant) and
the batch form (every instant of a recording) alike: it takes every sensor at the same instants
(:class:`~mimucap.core.pipeline.instants.SensorsAtInstants`: orientations, the filters' flags,
their heading uncertainty, magnetometer-free orientations) and gives every segment's
orientation. A :class:`JointCoupling` given to the stage acts on those sensors before the body
calibration is applied: the place where segments joined by a joint share constraints (a
hinge-like knee keeps its axis, so two segments' relative heading holds while their
magnetometers are rejected: Laidig, Lehmann, Bégin, Seel, "Exploiting kinematic constraints to
compensate magnetometer disturbances when calculating joint angles of approximate hinge
joints"), and where a change of field alike for every sensor can be told from a local one.
Without one the sensors' orientations are used as the chains gave them.

Quaternions ``[w, x, y, z]``, world ENU.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

import numpy as np

from mimucap.core import bodycal, skeleton
from mimucap.core.pipeline.instants import SensorsAtInstants


def one_sensor_per_segment(sensor_segments: Mapping[str, str | None]) -> dict[str, str]:
    """``sensor_segments`` (sensor id → segment) with each segment carried by one sensor, the
    first in the mapping's order (a recording made when two sensors could share a segment, e.g.
    the simulated suit's second pelvis unit, keeps its first); unassigned sensors are left out."""
    kept: dict[str, str] = {}
    for sensor, segment in sensor_segments.items():
        if segment is not None and segment not in kept.values():
            kept[sensor] = segment
    return kept


def assignment_of(body_calibration: bodycal.BodyCalibration | None,
                  sensor_segments: Mapping[str, str]) -> dict[str, str]:
    """Sensor id → segment as the pose uses it: the body calibration's when there is one, else
    ``sensor_segments`` with one sensor per segment (:func:`one_sensor_per_segment`)."""
    if body_calibration is not None:
        return {sensor: segment for segment, sensor in body_calibration.sensors.items()}
    return one_sensor_per_segment(sensor_segments)


def segments_from_sensors(model: skeleton.SkeletonModel, q_world_from_sensor: Mapping[str, np.ndarray],
                          body_calibration: bodycal.BodyCalibration | None,
                          sensor_segments: Mapping[str, str]) -> dict[str, np.ndarray] | None:
    """Every segment's ``q_world_from_segment`` (..., 4) from its sensors' orientations at the
    same instants (step 4). Rows where a sensor has no orientation (NaN) leave its segment to
    follow its parent (a root without one faces north); ``None`` when no assigned sensor has
    any orientation."""
    if body_calibration is not None:
        found = bodycal.segment_orientations(body_calibration, q_world_from_sensor, require_all=False, allow_nan=True)
    else:
        found = {segment: np.asarray(q_world_from_sensor[sensor], dtype=np.float64)
                 for sensor, segment in one_sensor_per_segment(sensor_segments).items()
                 if sensor in q_world_from_sensor and segment in model.segment_names}
    if not found:
        return None
    north = np.broadcast_to(skeleton.q_world_from_body_facing(0.0), next(iter(found.values())).shape).copy()
    result: dict[str, np.ndarray] = {}
    for segment in model.segments:
        fallback = north if segment.parent is None else result[segment.parent]
        own = found.get(segment.name)
        if own is None:
            result[segment.name] = fallback
            continue
        missing = ~np.isfinite(own).all(axis=-1)
        if np.any(missing):
            own = own.copy()
            own[missing] = fallback[missing]
        result[segment.name] = own
    return result


class JointCoupling(Protocol):
    """A correction of the sensors' orientations at the same instants from what the joints
    between their segments constrain (see the module docstring).

    :meth:`couple` is called with the instants in time order: every instant of a recording at
    once in the batch form, in the live form the instants formed since the last call (every
    instant once, whether a pose is shown there or not); a coupling that learns (a heading
    offset between two segments, the common field) keeps that between calls. It
    returns the instants with corrected ``q_world_from_sensor`` (and may leave them as they are),
    and with ``heading_source`` when it chooses where each sensor's heading comes from (the
    reasons for doubt follow that choice: :func:`~mimucap.core.pipeline.joint_angles.joint_reasons`).
    :class:`~mimucap.core.heading_sources.HeadingCoupling` is the application's.
    """

    def couple(self, instants: SensorsAtInstants, stage: "SegmentStage") -> SensorsAtInstants:
        """``instants`` corrected; ``stage`` gives the model, the body calibration and which
        sensor is on which segment."""
        ...


class SegmentStage:
    """Sensors at the same instants → segment orientations (see the module docstring).

    Args:
        model: the skeleton model.
        body_calibration: the body calibration, or None (each sensor's axes stand for its segment's).
        sensor_segments: sensor id → segment, used without a body calibration.
        coupling: the joint coupling to apply first, or None.
    """

    def __init__(self, model: skeleton.SkeletonModel, body_calibration: bodycal.BodyCalibration | None,
                 sensor_segments: Mapping[str, str], coupling: JointCoupling | None = None) -> None:
        self.model = model
        self.body_calibration = body_calibration
        self.sensor_segments = dict(sensor_segments)
        self.coupling = coupling
        #: sensor id → segment, as the pose uses it (:func:`assignment_of`)
        self.segment_of_sensor = assignment_of(body_calibration, self.sensor_segments)

    def segments(self, instants: SensorsAtInstants) -> dict[str, np.ndarray] | None:
        """Segment → ``q_world_from_segment`` (…, 4) at the instants of ``instants``; None when
        no assigned sensor has an orientation."""
        return self.coupled_segments(instants)[1]

    def coupled_segments(self, instants: SensorsAtInstants
                         ) -> tuple[SensorsAtInstants, dict[str, np.ndarray] | None]:
        """:meth:`segments` with the instants the coupling made of ``instants`` (as given
        without one)."""
        if self.coupling is not None:
            instants = self.coupling.couple(instants, self)
        return instants, self.uncoupled_segments(instants)

    def uncoupled_segments(self, instants: SensorsAtInstants) -> dict[str, np.ndarray] | None:
        """:meth:`segments` of instants the coupling has already made (or without one)."""
        return segments_from_sensors(self.model, instants.q_world_from_sensor, self.body_calibration,
                                     self.sensor_segments)
