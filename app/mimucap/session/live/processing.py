"""The live session's processing part: each sensor's new samples through the one processing path,
and the pose they make (no Qt).

:class:`LiveProcessing` holds the :class:`~mimucap.core.pipeline.live.LivePipeline` of the live view:
magnetometer calibration, orientation filter (``q_world_from_sensor``, world ENU, scalar first;
the device's own when it fuses on board) and the pose of the assigned segments at one instant,
through the body calibration when one is applied (until then each assigned sensor's axes stand
for its segment). It never reads the simulator's truth.

Events (``events``, :class:`~mimucap.session.events.EmitterGroup`), in the thread that calls
:meth:`LiveProcessing.process`:

* ``processed(list[ProcessedBlock])``: every step that brought samples, the raw blocks with the
  orientations the pipeline gave them (what the calibration procedures read);
* ``pose_source(text)``: what drives the figure (:attr:`LiveProcessing.pose_source`) changed.

Times ``t_s`` are session seconds (the host monotonic clock minus the session's start).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from mimucap.core import bodycal, skeleton
from mimucap.core.bodycal import static_alignment
from mimucap.core.heading_sources import heading_coupling
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.pipeline.chain import SensorOrientations
from mimucap.core.pipeline.live import LivePipeline
from mimucap.core.pipeline.recording import POSE_BODY_CALIBRATION, POSE_SENSOR_AXES
from mimucap.core.pipeline.settings import RESULT_LIVE, PipelineSettings
from mimucap.core.sensor_samples import SensorSamples
from mimucap.session.events import EmitterGroup

#: What drives the figure before any sample arrived, and while no assigned sensor sends.
POSE_NONE = "no data"
POSE_UNASSIGNED = "no sensor assigned (Session → Assign Sensors)"


@dataclass(frozen=True)
class ProcessedBlock:
    """One sensor's new samples as the pipeline took them: ``t_s`` (N,) session seconds,
    ``block`` the raw :class:`~mimucap.core.sensor_samples.SensorSamples` (host times, uncalibrated
    magnetometer), ``orientation`` the pipeline's output (``None`` for a sensor without an
    orientation: no gyroscope and no on-board fusion)."""

    sensor_id: str
    t_s: np.ndarray
    block: SensorSamples
    orientation: SensorOrientations | None

    @property
    def mag_uT(self) -> np.ndarray | None:
        """The magnetic field (N, 3) µT as the filter took it: calibrated when a calibration is
        applied, else raw (``None`` without a magnetometer)."""
        if self.orientation is not None and self.orientation.mag_uT is not None:
            return self.orientation.mag_uT
        return self.block.mag_uT


class LiveProcessing:
    """The processing path of the live view for skeleton ``model`` with ``settings`` (see the
    module doc)."""

    def __init__(self, model: skeleton.SkeletonModel, settings: PipelineSettings = PipelineSettings()) -> None:
        self.pipeline = LivePipeline(model, settings, heading_coupling(settings, RESULT_LIVE))
        self.events = EmitterGroup("processed", "pose_source")
        self._pose_source = POSE_NONE
        #: sensors that have sent a magnetic field
        self._with_mag: set[str] = set()

    @property
    def settings(self) -> PipelineSettings:
        return self.pipeline.settings

    # -- samples in ------------------------------------------------------------------------
    def process(self, blocks: Sequence[SensorSamples], t0_host_s: float) -> list[ProcessedBlock]:
        """Run ``blocks`` (one per sensor, host times) through the pipeline on session time
        (host time − ``t0_host_s``) and emit ``processed``; returns what it emitted."""
        times = [block.t_s - t0_host_s for block in blocks]
        outputs = self.pipeline.feed([block.with_times(t) for block, t in zip(blocks, times)])
        by_sensor = {out.sensor_id: out for out in outputs}
        processed = [ProcessedBlock(block.sensor_id, t, block, by_sensor.get(block.sensor_id))
                     for block, t in zip(blocks, times)]
        self._with_mag.update(block.sensor_id for block in blocks if block.mag_uT is not None)
        self.events.processed.emit(processed)
        return processed

    # -- the pose --------------------------------------------------------------------------
    @property
    def pose_source(self) -> str:
        """What drives the figure: :data:`~mimucap.core.pipeline.recording.POSE_BODY_CALIBRATION`,
        :data:`~mimucap.core.pipeline.recording.POSE_SENSOR_AXES`, :data:`POSE_UNASSIGNED` or :data:`POSE_NONE`."""
        return self._pose_source

    def pose(self, body_calibration: bodycal.BodyCalibration | None, sensor_segments: Mapping[str, str],
             seen_sensors: Iterable[str], had_pose: bool) -> tuple[float, dict[str, np.ndarray]] | None:
        """The newest pose ready (``(t_s, segment → q_world_from_segment (4,))``) or ``None``;
        says what drives the figure. ``seen_sensors``: the sensors that have sent samples;
        ``had_pose``: whether the figure shows a pose already (it is kept while its sensors send)."""
        pose = self.pipeline.pose(body_calibration, sensor_segments)
        if pose is None:
            assigned = body_calibration.sensors.values() if body_calibration is not None else sensor_segments
            seen = set(seen_sensors)
            if not had_pose or not any(sid in seen for sid in assigned):
                self._set_pose_source(POSE_UNASSIGNED if seen else POSE_NONE)
            return None
        self._set_pose_source(POSE_BODY_CALIBRATION if body_calibration is not None else POSE_SENSOR_AXES)
        return pose

    def forget_poses(self) -> None:
        """The figure is driven anew (a body calibration applied or cleared): the next pose is
        the newest one, whatever was made before."""
        self.pipeline.forget_poses()

    def publish_pose_source(self) -> None:
        """Emit ``pose_source`` now (for widgets that have just subscribed)."""
        self.events.pose_source.emit(self._pose_source)

    def _set_pose_source(self, source: str) -> None:
        if source != self._pose_source:
            self._pose_source = source
            self.events.pose_source.emit(source)

    # -- the sensors' filters ----------------------------------------------------------------
    @property
    def mag_calibrations(self) -> dict[str, MagCalibration]:
        """Sensor id → the magnetometer calibration the filters apply."""
        return self.pipeline.mag_calibrations

    def set_mag_calibration(self, calibration: MagCalibration) -> None:
        """Apply ``calibration`` to its sensor from now on (its filter learns the heading anew)."""
        self.pipeline.set_mag_calibration(calibration)

    def clear_mag_calibration(self, sensor_id: str) -> None:
        """Use ``sensor_id``'s raw magnetometer from now on."""
        self.pipeline.clear_mag_calibration(sensor_id)

    def filter_states(self) -> dict[str, dict[str, list]]:
        """Sensor → its filter state now (JSON-ready), what a recording starts from."""
        return self.pipeline.filter_states()

    def coupling_state(self, time_offset_s: float) -> dict[str, Any] | None:
        """Where the heading coupling's averages stand now, on the clock of a recording that
        starts ``time_offset_s`` (s) into the session (JSON-ready; None without a coupling),
        what the recording's *as seen live* result continues from."""
        return self.pipeline.coupling_state(time_offset_s)

    def latest_orientations(self) -> dict[str, np.ndarray]:
        """Sensor id → newest ``q_world_from_sensor`` (4,) (sensors with an estimate only)."""
        return self.pipeline.latest_orientations()

    def knows(self, sensor_id: str) -> bool:
        """Whether ``sensor_id``'s samples have been through the pipeline."""
        return sensor_id in self.pipeline.chains

    def onboard(self, sensor_id: str) -> bool:
        """Whether ``sensor_id`` sends its own orientation (fused on board)."""
        chain = self.pipeline.chains.get(sensor_id)
        return chain is not None and chain.onboard

    def onboard_sensors(self) -> tuple[str, ...]:
        """Sensors that send their own orientation (fused on board: no magnetometer to calibrate)."""
        return tuple(sid for sid, chain in self.pipeline.chains.items() if chain.onboard)

    def orientation_only_sensors(self) -> tuple[str, ...]:
        """Sensors that send their own orientation and no magnetometer readings (on-board fusion
        that calibrates itself, e.g. SlimeVR trackers): nothing to calibrate here."""
        return tuple(sid for sid in self.onboard_sensors() if sid not in self._with_mag)

    def has_magnetometer(self, sensor_id: str) -> bool:
        """Whether ``sensor_id`` has sent a magnetic field."""
        return sensor_id in self._with_mag

    def fusion_flags(self, sensor_id: str) -> int | None:
        """The newest flags of ``sensor_id``'s filter (:data:`~mimucap.core.fusion.FLAG_NAMES`
        bits), ``None`` for a sensor without a filter of its own."""
        chain = self.pipeline.chains.get(sensor_id)
        if chain is None or chain.ekf is None:
            return None
        return self.pipeline.flags.get(sensor_id, 0)

    def doubt_bits(self, sensor_id: str) -> int:
        """Why ``sensor_id``'s newest orientation may be wrong (:mod:`mimucap.core.pipeline.sensor_doubt` bits; 0: trustworthy)."""
        return self.pipeline.doubt_of(sensor_id)

    def static_orientation(self, sensor_id: str, acc: np.ndarray, mag_raw_uT: np.ndarray) -> np.ndarray | None:
        """``q_world_from_sensor`` (4,) of ``sensor_id`` held still over the samples ``acc`` (K, 3)
        m/s² and ``mag_raw_uT`` (K, 3) raw µT, with the magnetometer calibration and declination
        the filter uses (:func:`mimucap.core.bodycal.static_alignment`); None when the sensor has
        no magnetometer calibration (its raw field is not what the filter will settle on) or
        sends its own orientation. ``ValueError`` when the field is vertical or disturbed (its
        magnitude off the calibration's by more than the filter's tolerance)."""
        chain = self.pipeline.chains.get(sensor_id)
        if chain is None or chain.onboard or chain.mag_calibration is None:
            return None
        fusion = chain.settings.fusion
        return static_alignment(acc, chain.calibrated_mag(np.asarray(mag_raw_uT, dtype=np.float64)),
                                fusion.declination_rad, chain.mag_calibration.field_uT, fusion.mag_norm_tol)
