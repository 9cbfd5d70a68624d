"""The processing path fed block by block as samples arrive: the live form (no I/O, no Qt).

:class:`LivePipeline` keeps one chain per sensor (:mod:`.chain`) and each sensor's recent
orientations (:class:`~mimucap.core.pipeline.instants.LiveTrack`); a pose is formed at the
newest instant every assigned sensor has delivered for (:func:`~mimucap.core.pipeline.instants.newest_instant`)
and turned into segment orientations by the same stage as a recording's
(:class:`~mimucap.core.pipeline.segments.SegmentStage`). Fed the same samples from the same
filter states, it gives the numbers of :func:`~mimucap.core.pipeline.recording.process_recording`
with :data:`~mimucap.core.pipeline.settings.RESULT_LIVE`: a recording's *as seen live* result
reproduces the screen.

Times ``t_s`` are float64 seconds on the pipeline's clock (the session's).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from mimucap.core import bodycal, skeleton
from mimucap.core.heading_sources import relieved
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.pipeline.chain import SensorChain, SensorOrientations, update_chains
from mimucap.core.pipeline.doubt_reasons import DOUBT_DTYPE
from mimucap.core.pipeline.instants import (
    CoupledInstants, LiveTrack, instants_after, live_sensors_at, newest_instant, sensors_at_instants,
)
from mimucap.core.pipeline.segments import JointCoupling, SegmentStage
from mimucap.core.pipeline.settings import DEFAULT_PIPELINE_SETTINGS, PipelineSettings
from mimucap.core.sensor_samples import SensorSamples


class LivePipeline:
    """The processing path fed block by block (see the module docstring).

    Args:
        model: the skeleton model the poses are for.
        settings: the filter settings.
        coupling: the joint coupling of the segment stage
            (:class:`~mimucap.core.pipeline.segments.JointCoupling`), or None.
    """

    def __init__(self, model: skeleton.SkeletonModel, settings: PipelineSettings = DEFAULT_PIPELINE_SETTINGS,
                 coupling: JointCoupling | None = None) -> None:
        self.model = model
        self.settings = settings
        self.coupling = coupling
        self.chains: dict[str, SensorChain] = {}
        self.mag_calibrations: dict[str, MagCalibration] = {}
        #: sensor → the filter flags of its newest sample
        self.flags: dict[str, int] = {}
        #: sensor → the reasons its newest orientation may be wrong (:mod:`.doubt_reasons`)
        self.doubts: dict[str, int] = {}
        self._tracks: dict[str, LiveTrack] = {}
        self._last_pose_t = -np.inf
        #: sensor → where the newest pose's heading of that sensor came from, as the coupling
        #: chose it (:data:`~mimucap.core.heading_sources.SOURCE_NAMES`; empty without one)
        self.heading_sources: dict[str, int] = {}
        #: the coupling's output at the last instants it was stepped over (:meth:`_couple_new`)
        self._coupled = CoupledInstants()

    def chain(self, sensor_id: str) -> SensorChain:
        """``sensor_id``'s chain (made at its first samples, with its magnetometer calibration)."""
        chain = self.chains.get(sensor_id)
        if chain is None:
            chain = self.chains[sensor_id] = SensorChain(sensor_id, self.mag_calibrations.get(sensor_id), self.settings)
        return chain

    def set_mag_calibration(self, calibration: MagCalibration) -> None:
        """Use ``calibration`` for its sensor from now on (its filter learns the heading anew:
        :meth:`~mimucap.core.pipeline.chain.SensorChain.set_mag_calibration`)."""
        self.mag_calibrations[calibration.sensor_id] = calibration
        self.chain(calibration.sensor_id).set_mag_calibration(calibration)

    def clear_mag_calibration(self, sensor_id: str) -> None:
        """Use ``sensor_id``'s raw magnetometer from now on (its calibration was for another
        device); its filter learns the heading anew."""
        self.mag_calibrations.pop(sensor_id, None)
        if sensor_id in self.chains:
            self.chains[sensor_id].set_mag_calibration(None)

    def filter_states(self) -> dict[str, dict[str, list]]:
        """Sensor → its filter state now (JSON-ready), for the sensors whose filter runs."""
        return {sid: snap for sid, chain in self.chains.items() if (snap := chain.state_snapshot()) is not None}

    def feed(self, blocks: Sequence[SensorSamples]) -> list[SensorOrientations]:
        """Calibrate and fuse new samples (``t_s`` on the pipeline's clock, raw ``mag_uT``; a
        ``q_world_from_sensor`` is the device's own orientation and is taken as it is): each
        through its sensor's chain (:func:`~mimucap.core.pipeline.chain.update_chains`). Returns
        their orientations in the blocks' order (a block with neither an orientation nor a
        gyroscope gives none)."""
        done = [out for out in update_chains([self.chain(block.sensor_id) for block in blocks], blocks)
                if out is not None]
        for item in done:
            track = self._tracks.get(item.sensor_id)
            if track is None:
                track = self._tracks[item.sensor_id] = LiveTrack()
            calibrated = self.chains[item.sensor_id].mag_calibration is not None
            track.add(item.t_s, item.q_world_from_sensor, item.flags, item.heading_std_rad,
                      item.q_world_from_sensor_no_mag, item.mag_uT if calibrated else None)
            if len(item.flags):
                self.flags[item.sensor_id] = int(item.flags[-1])
                self.doubts[item.sensor_id] = int(item.doubt[-1])
        return done

    def doubt_of(self, sensor_id: str) -> int:
        """The reasons (:mod:`.doubt_reasons`) the sensor's newest orientation may be wrong, less
        its own magnetometer's where the newest pose took its heading from the field the body
        shares or its joint (:func:`~mimucap.core.heading_sources.relieved`)."""
        reasons = self.doubts.get(sensor_id, 0)
        source = self.heading_sources.get(sensor_id)
        if source is None:
            return reasons
        return int(relieved(np.array([reasons], dtype=DOUBT_DTYPE), np.array([source], dtype=np.uint8))[0])

    def latest_orientations(self) -> dict[str, np.ndarray]:
        """Sensor → its newest ``q_world_from_sensor`` (4,) (sensors with one only)."""
        return {sid: track.q[-1] for sid, track in self._tracks.items() if len(track.t)}

    def pose(self, body_calibration: bodycal.BodyCalibration | None,
             sensor_segments: Mapping[str, str]) -> tuple[float, dict[str, np.ndarray]] | None:
        """The newest pose every assigned sensor has delivered for: ``(t_s, segment → (4,))``,
        or ``None`` when no new one is ready. Its instant is a sample time of the reference
        sensor that no assigned, non-silent sensor lags behind
        (:data:`~mimucap.core.pipeline.instants.HOLD_BACK_LIMIT_S`), so that every segment comes
        from samples of the same instant (as
        :func:`~mimucap.core.pipeline.recording.process_recording` forms it)."""
        stage = SegmentStage(self.model, body_calibration, sensor_segments, self.coupling)
        t_pose = newest_instant(self.model, stage.segment_of_sensor, self._tracks, self._last_pose_t)
        if t_pose is None:
            return None
        if self.coupling is None:
            tracks = {sid: self._tracks[sid] for sid in stage.segment_of_sensor
                      if sid in self._tracks and len(self._tracks[sid].t)}
            instants, q_segments = stage.coupled_segments(live_sensors_at(t_pose, tracks))
        else:
            self._couple_new(stage)
            instants = self._coupled.at(np.array([t_pose]))
            if instants is None:
                return None
            q_segments = stage.uncoupled_segments(instants)
            q_segments = None if q_segments is None else {name: q[0] for name, q in q_segments.items()}
        if q_segments is None:
            return None
        self.heading_sources = {sid: int(np.ravel(source)[-1]) for sid, source in instants.heading_source.items()}
        self._last_pose_t = t_pose
        return t_pose, q_segments

    def poses_after(self, t_after_s: float, body_calibration: bodycal.BodyCalibration | None,
                    sensor_segments: Mapping[str, str]) -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
        """Every pose the pipeline can form at an instant later than ``t_after_s`` (s), in one
        batch: ``(t_s (P,), segment → q_world_from_segment (P, 4))``, or ``None`` when there is
        none (:func:`~mimucap.core.pipeline.instants.instants_after`): what :meth:`pose`, which
        keeps only the newest, skips between two calls, with the same orientations. Independent
        of :meth:`pose`'s own progress."""
        stage = SegmentStage(self.model, body_calibration, sensor_segments, self.coupling)
        t_pose = instants_after(self.model, stage.segment_of_sensor, self._tracks, t_after_s)
        if not len(t_pose):
            return None
        if self.coupling is None:
            tracks = {sid: self._tracks[sid].as_sensor_track() for sid in stage.segment_of_sensor
                      if sid in self._tracks and len(self._tracks[sid].t)}
            q_segments = stage.segments(sensors_at_instants(t_pose, tracks))
        else:
            self._couple_new(stage)
            instants = self._coupled.at(t_pose)
            q_segments = None if instants is None else stage.uncoupled_segments(instants)
            t_pose = t_pose if instants is None else np.asarray(instants.t_s)
        return None if q_segments is None else (t_pose, q_segments)

    def _couple_new(self, stage: SegmentStage) -> None:
        """Step the coupling over every instant formed since it was last stepped, whether or not
        a pose is shown there: its averages run over time, and a recording's *as seen live*
        result steps them over every instant (the view refreshes at its own rate)."""
        key = (tuple(sorted(stage.segment_of_sensor.items())), id(stage.body_calibration))
        if key != self._coupled.stage_key:
            self._coupled = CoupledInstants(key)  # another assignment: the coupling starts anew too
        t_new = instants_after(self.model, stage.segment_of_sensor, self._tracks, self._coupled.newest_t)
        if not len(t_new):
            return
        tracks = {sid: self._tracks[sid].as_sensor_track() for sid in stage.segment_of_sensor
                  if sid in self._tracks and len(self._tracks[sid].t)}
        self._coupled.add(self.coupling.couple(sensors_at_instants(t_new, tracks), stage))

    def coupling_state(self, time_offset_s: float = 0.0) -> dict[str, Any] | None:
        """Where the coupling's averages stand now (JSON-ready, on a clock ``time_offset_s``
        behind the pipeline's: a recording's), what a recording's *as seen live* result
        continues from; None without a coupling that keeps one."""
        to_dict = getattr(self.coupling, "state_to_dict", None)
        return None if to_dict is None else to_dict(time_offset_s)

    def forget_poses(self) -> None:
        """Allow the next pose to be any instant again (after a calibration changed)."""
        self._last_pose_t = -np.inf
