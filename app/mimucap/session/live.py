"""The live session the main window shows: sensor blocks in, skeleton, plots and files out (no Qt).

:class:`LiveSession` is driven by the GUI's timers, in one thread: :meth:`LiveSession.step`
takes whatever the feed (:mod:`mimucap.session.feeds`) delivered since the last call and
runs it through the pipeline:

1. magnetometer calibration of each sensor that has one (``mag_cal = A⁻¹ (mag_raw − b)``, µT);
2. orientation ``q_world_from_sensor`` (world ENU, scalar first): the device's own when it
   sends one, otherwise an online :class:`~mimucap.core.fusion.OrientationEKF` per sensor;
3. segment orientations ``q_world_from_segment``: through the applied body calibration
   (:func:`mimucap.core.bodycal.segment_orientations`); until one is applied, the simulated
   suit shows the simulator's truth (:attr:`LiveSession.pose_source` says
   ``"simulator truth"``) and other sources show each assigned sensor's axes as its
   segment's (``"sensor axes (no body calibration)"``);
4. joint angles (deg, :func:`mimucap.core.skeleton.joint_angles_deg_stacked`) of every pose,
   computed in one batch when the plots ask (:meth:`LiveSession.joint_series`);
5. the recorder (:class:`~mimucap.session.recording.Recorder`) when recording.

Times: ``t_s`` is seconds on the host monotonic clock since the live session started.

API for calibration wizards (``MagnetometerWizard(parent, live_session)``,
``BodyCalibrationWizard(parent, live_session)``):

* ``live_session.simulator``: the :class:`~mimucap.core.simulate.SuitSimulator` when the source
  is the simulated suit in process (``None`` otherwise); ``simulator.set_activity("tpose",
  arms="both")`` makes the subject do what the wizard asks.
* ``live_session.events.blocks.connect(callback)``: ``callback(blocks)`` gets every list of
  :class:`~mimucap.acquisition.samples.SampleBlock` (raw, before calibration) as it arrives;
  disconnect with ``live_session.events.blocks.disconnect(callback)`` when the wizard closes.
* ``live_session.sensor_ids``, ``live_session.sensor_segments`` (sensor id → segment),
  ``live_session.latest_orientations()`` (sensor id → ``q_world_from_sensor`` (4,)),
  ``live_session.series(sensor_id, window_s)`` (recent raw ``t_s``, ``acc``, ``gyr``, ``mag_uT``).
* ``live_session.apply_mag_calibration(cal)`` (a :class:`~mimucap.core.magcal.MagCalibration`;
  the sensor's fusion restarts with calibrated samples), ``live_session.mag_calibrations``.
* ``live_session.apply_body_calibration(cal)`` (a :class:`~mimucap.core.bodycal.BodyCalibration`:
  the figure then follows the sensors through it, world mode is normalised to its N-pose) and
  ``live_session.clear_body_calibration()``.
* ``live_session.events.calibration`` is emitted after either is applied.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from mimucap.acquisition.samples import SampleBlock, concatenate_blocks
from mimucap.acquisition.source_spec import SimulatedSpec, parse_source_spec
from mimucap.core import bodycal, rotation, skeleton
from mimucap.core.fusion import FLAG_NAMES, OrientationEKF, update_together
from mimucap.core.magcal import MagCalibration
from mimucap.core.simulate import SimulationConfig, SuitTruth
from mimucap.session.events import EmitterGroup
from mimucap.session.feeds import SimulatorFeed, SupervisorFeed
from mimucap.session.figure import FigureBuilder, FigureGeometry, heading_rad
from mimucap.session.recording import Recorder, RecordingResult
from mimucap.session.ring_buffer import RingBuffer
from mimucap.session.sources import SourceOptions

#: A sensor whose last sample arrived longer ago than this (s) is flagged stale.
STALE_AFTER_S = 1.0
#: Longest scrolling window the live plots can show (s).
MAX_WINDOW_S = 30.0
#: Samples per second the ring buffers are sized for (larger rates keep a shorter history).
BUFFER_RATE_HZ = 200.0
#: Joint-angle history rate bound: one pose per pipeline step (the GUI pumps at 100 Hz).
ANGLE_BUFFER_RATE_HZ = 120.0

POSE_BODY_CALIBRATION = "body calibration"
POSE_SIMULATOR_TRUTH = "simulator truth"
#: Where a recording's ground truth came from (stored with it).
TRUTH_NOTE = "simulated suit shown live in mimucap gui"
POSE_SENSOR_AXES = "sensor axes (no body calibration)"
POSE_NONE = "no data"
POSE_UNASSIGNED = "no sensor assigned (Session → Assign Sensors)"

#: Fusion flags the sensor panel shows: flag name (:data:`FLAG_NAMES`) → label.
FLAG_LABELS = {"rest": "rest", "mag_rejected": "mag disturbed", "acc_rejected": "acc disturbed",
               "uninitialised": "starting"}


@dataclass(frozen=True)
class SensorRow:
    """One line of the sensor panel.

    ``rate_hz`` samples/s over the last 2 s; ``drops`` sequence gaps; ``latency_ms`` p95 from
    the sample's host time to its arrival in this process; ``battery_pct`` (NaN if unknown);
    ``mag_cal`` ``"calibrated"``, ``"on-board"`` (device fuses itself) or ``"not calibrated"``;
    ``mag_cal_age_s`` since the calibration was made (NaN if none); ``flags`` fusion flags
    now (``"rest"``, ``"mag disturbed"``, ...); ``stale`` no sample for :data:`STALE_AFTER_S`;
    ``state`` the tint name of its segment (``ok``, ``mag_uncalibrated``, ``stale``);
    ``rejections`` packets of this sensor the source refused, by reason
    (:class:`~mimucap.acquisition.rejections.Rejection` value → count, since the source started).
    """

    sensor_id: str
    segment: str | None
    rate_hz: float
    drops: int
    latency_ms: float
    battery_pct: float
    mag_cal: str
    mag_cal_age_s: float
    flags: tuple[str, ...]
    stale: bool
    state: str
    rejections: Mapping[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class RecordingInfo:
    """What is being recorded where: ``path``, ``elapsed_s`` (s), ``size_bytes`` (journal so far),
    ``markers`` placed, ``samples`` per sensor."""

    path: Path
    elapsed_s: float
    size_bytes: int
    markers: int
    samples: dict[str, int] = field(default_factory=dict)


class _SensorState:
    """Per-sensor live state: recent raw samples for the plots, fusion, latest orientation."""

    def __init__(self, sensor_id: str, capacity: int) -> None:
        self.sensor_id = sensor_id
        #: rows acc (m/s²), gyr (rad/s), mag (µT, calibrated when applied); NaN when absent
        self.raw = RingBuffer(capacity, (3, 3))
        self.ekf: OrientationEKF | None = None
        self.q_world_from_sensor: np.ndarray | None = None
        self.onboard = False
        self.flags = 0
        self.battery_pct = float("nan")


class LiveSession:
    """The live pipeline of one source (see the module doc).

    Args:
        feed: a :class:`SimulatorFeed` or :class:`SupervisorFeed` (not started yet).
        label: how the status bar names the source.
        model_name: skeleton model (``"ten_segment"`` or ``"fifteen_segment"``).
        height_m: the subject's height (m).
        clock: monotonic clock (s), the same the feed uses.

    Events (``self.events``): ``blocks(list[SampleBlock])`` raw data as it arrives;
    ``frame(frame_id)`` a new pose; ``calibration()`` a calibration was applied;
    ``recording(info_or_None)`` recording started/stopped; ``marker(t_s, label, recorded)``
    a marker the user placed (session time; ``recorded``: the marker is in the recording, as
    markers are while recording; the simulated subject's activity changes are not markers).
    """

    def __init__(self, feed, label: str = "", model_name: str = "ten_segment", height_m: float = 1.75,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.feed = feed
        self.label = label or getattr(feed, "name", "source")
        self.model = skeleton.load_model(model_name)
        self.height_m = float(height_m)
        self.builder = FigureBuilder(self.model, self.height_m)
        self.events = EmitterGroup("blocks", "frame", "calibration", "recording", "marker")
        self._clock = clock
        self.t0_host_s: float | None = None
        self.display_mode = "world"
        #: sensor id → the segment it is worn on, as the source knows it (the simulated suit's truth)
        self._worn_on: dict[str, str] = dict(feed.sensor_segments())
        self.sensor_segments: dict[str, str] = dict(self._worn_on)
        self.mag_calibrations: dict[str, MagCalibration] = {}
        self.body_calibration: bodycal.BodyCalibration | None = None
        self._capacity = int(MAX_WINDOW_S * BUFFER_RATE_HZ)
        self._sensors: dict[str, _SensorState] = {}
        self._joint_columns = self._group_columns()
        #: joint → its row in :func:`skeleton.joint_angles_deg_stacked` output (model joint order)
        self._joint_row = {joint: self.model.joint_names.index(joint) for joint in self._joint_columns}
        self._segment_parents = [(s.name, s.parent) for s in self.model.segments]
        self._angles = {j: RingBuffer(int(MAX_WINDOW_S * ANGLE_BUFFER_RATE_HZ), (3,)) for j in self._joint_columns}
        self._angle_t = RingBuffer(int(MAX_WINDOW_S * ANGLE_BUFFER_RATE_HZ))
        #: poses since the last joint-angle update: (t_s, (S, 4) orientations in model order)
        self._pending_angles: list[tuple[float, np.ndarray]] = []
        self._q_world_from_segment: dict[str, np.ndarray] | None = None
        self._q_stacked: np.ndarray | None = None   # the same (S, 4), segments in model order
        self._root_m: np.ndarray | None = None
        self._pose_source = POSE_NONE
        self._t_s = float("nan")
        self._frame_id = 0
        self._geometry: tuple[object, FigureGeometry] | None = None
        self._recorder: Recorder | None = None
        self._journaled_truth: SuitTruth | None = None   # the simulator truth block last recorded
        self._recording_markers = 0
        self.last_recording: RecordingResult | None = None
        self.samples_received = 0
        self.last_arrival_s = float("nan")   #: host time the newest block arrived (latency bench)
        self.started = False

    def _group_columns(self) -> dict[str, tuple[str, str, str]]:
        columns = skeleton.joint_angle_columns(self.model)
        grouped: dict[str, list[str]] = {}
        for joint in self.model.joint_names:
            grouped[joint] = [c for c in columns if c.startswith(joint + "_")][:3]
        return {j: tuple(c) for j, c in grouped.items() if len(c) == 3}

    # -- source ----------------------------------------------------------------------------
    @property
    def simulator(self):
        """The in-process :class:`~mimucap.core.simulate.SuitSimulator`, or ``None``."""
        return getattr(self.feed, "simulator", None)

    @property
    def sensor_ids(self) -> tuple[str, ...]:
        ids = list(self.feed.sensor_ids)
        ids += [s for s in self._sensors if s not in ids]
        return tuple(ids)

    def start(self) -> None:
        """Start the feed; ``t_s = 0`` is now."""
        self.t0_host_s = self._clock()
        self.feed.start()
        self.started = True

    def stop(self) -> RecordingResult | None:
        """Stop recording (the file is written) and the feed."""
        result = self.stop_recording() if self.recording else None
        if self.started:
            self.feed.stop()
            self.started = False
        return result

    # -- state -------------------------------------------------------------------------------
    @property
    def source_problem(self) -> str:
        """Why the source may be sending nothing, as its reader reported it (e.g. a serial
        device that cannot be opened); "" when nothing is known to be wrong."""
        return self.feed.problem()

    @property
    def pose_source(self) -> str:
        """What drives the figure (see the module doc)."""
        return self._pose_source

    @property
    def time_s(self) -> float:
        """Session time (s) of the newest pose (NaN before the first)."""
        return self._t_s

    @property
    def cursor_s(self) -> float:
        """The time the plots are aligned to (s): the newest pose (what the 3D view shows),
        live; while no pose is made (no sensor assigned yet), the newest sample's time, so the
        plots still scroll with the raw data. NaN before any data."""
        if self._pose_source in (POSE_NONE, POSE_UNASSIGNED):
            return self._newest_time()
        return self._t_s

    @property
    def q_world_from_segment(self) -> dict[str, np.ndarray] | None:
        """Newest segment orientations, segment → ``(4,)`` (world ENU, scalar first)."""
        return self._q_world_from_segment

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(self._joint_columns)

    def joint_columns(self, joint: str) -> tuple[str, str, str]:
        """The three angle column names of ``joint`` (meaning and ``_deg`` unit in the name)."""
        return self._joint_columns[joint]

    def latest_orientations(self) -> dict[str, np.ndarray]:
        """Sensor id → newest ``q_world_from_sensor`` (4,) (sensors with an estimate only)."""
        return {sid: s.q_world_from_sensor for sid, s in self._sensors.items() if s.q_world_from_sensor is not None}

    def set_display_mode(self, mode: str) -> None:
        """``"world"`` or ``"body"`` (see :mod:`mimucap.session.figure`)."""
        self.builder.display_alpha(mode, rotation.identity(), 0.0)  # validates
        self.display_mode = mode
        self._geometry = None

    def set_height(self, height_m: float) -> None:
        """The subject's height (m): rescales the figure."""
        builder = FigureBuilder(self.model, float(height_m))  # validates
        self.height_m = float(height_m)
        self.builder = builder
        self._geometry = None

    def assign_sensor(self, sensor_id: str, segment: str | None) -> None:
        """Wear ``sensor_id`` on ``segment`` (``None`` unassigns); a segment holds one sensor."""
        if segment is not None and segment not in self.model.segment_names:
            raise ValueError(f"sensor {sensor_id}: unknown segment {segment!r}; use one of {', '.join(self.model.segment_names)}")
        for other, seg in list(self.sensor_segments.items()):
            if seg == segment and other != sensor_id:
                del self.sensor_segments[other]
        if segment is None:
            self.sensor_segments.pop(sensor_id, None)
        else:
            self.sensor_segments[sensor_id] = segment

    # -- calibrations ------------------------------------------------------------------------
    def apply_mag_calibration(self, calibration: MagCalibration) -> None:
        """Use ``calibration`` for its sensor from now on (its fusion restarts)."""
        self.mag_calibrations[calibration.sensor_id] = calibration
        state = self._sensors.get(calibration.sensor_id)
        if state is not None:
            state.ekf = None
        self.events.calibration.emit()

    def apply_body_calibration(self, calibration: bodycal.BodyCalibration) -> None:
        """Drive the figure through ``calibration`` (sensor → segment rotations) from now on."""
        unknown = [s for s in calibration.segments if s not in self.model.segment_names]
        if unknown:
            raise ValueError(f"the body calibration has segments the {self.model.name} model lacks: {', '.join(unknown)}")
        self.body_calibration = calibration
        for segment, sensor in calibration.sensors.items():
            self.assign_sensor(sensor, segment)
        self._geometry = None
        self.events.calibration.emit()

    def clear_body_calibration(self) -> None:
        self.body_calibration = None
        self._geometry = None
        self.events.calibration.emit()

    # -- driving -----------------------------------------------------------------------------
    def step(self) -> int:
        """Run everything that arrived since the last call through the pipeline; returns the
        number of samples taken in."""
        if not self.started:
            return 0
        blocks = self.feed.poll()
        if self._recorder is not None:
            self._recorder.add_blocks(blocks) if blocks else self._recorder.tick()
        if not blocks:
            return 0
        self.last_arrival_s = max(float(b.receive_time_s[-1]) for b in blocks if len(b))
        self.events.blocks.emit(blocks)
        count = 0
        to_fuse: list[_FusionInput] = []
        for block in _merged_per_sensor(blocks):
            count += self._take_block(block, to_fuse)
        _fuse(to_fuse)
        self.samples_received += count
        self._update_pose()
        return count

    def _take_block(self, block: SampleBlock, to_fuse: list[_FusionInput]) -> int:
        """Buffer ``block`` for the plots; queue its samples for the sensor's filter on
        ``to_fuse`` (fused by :func:`_fuse` once the whole poll is in). Returns its length."""
        n = len(block)
        if n == 0:
            return 0
        state = self._sensors.get(block.sensor_id)
        if state is None:
            state = self._sensors[block.sensor_id] = _SensorState(block.sensor_id, self._capacity)
        t = block.host_time_s - self.t0_host_s
        mag = block.mag_uT
        calibration = self.mag_calibrations.get(block.sensor_id)
        if mag is not None and calibration is not None:
            mag = calibration.apply(mag, block.sensor_id)
        raw = np.full((n, 3, 3), np.nan)
        for row, values in enumerate((block.acc, block.gyr, mag)):
            if values is not None:
                raw[:, row] = values
        state.raw.append(t, raw)
        if block.battery_pct is not None:
            state.battery_pct = float(block.battery_pct[-1])
        if block.q_world_from_sensor is not None:
            state.onboard = True
            state.q_world_from_sensor = np.asarray(block.q_world_from_sensor[-1], dtype=float)
        elif block.gyr is not None:
            if state.ekf is None:
                state.ekf = OrientationEKF(use_mag=mag is not None)
            to_fuse.append(_FusionInput(state, t, block.gyr, block.acc, mag))
        return n

    def _update_pose(self) -> None:
        truth = getattr(self.feed, "last_truth", None)
        q_segments: dict[str, np.ndarray] | None = None
        root = None
        t_pose = float("nan")
        if self.body_calibration is not None:
            found = bodycal.segment_orientations(self.body_calibration, self.latest_orientations(), require_all=False)
            if self.model.root in found:
                q_segments = self._filled(found)
                t_pose = self._newest_time()
                self._pose_source = POSE_BODY_CALIBRATION
        elif truth is not None:
            q_segments = self._truth_through_assignment(truth)
            root = truth.root_position_m[-1] * (self.height_m / self.feed.config.height_m)
            if self._recorder is not None and truth is not self._journaled_truth:
                self._journal_truth(truth)
            t_pose = self.feed.host_time_of(float(truth.t_s[-1])) - self.t0_host_s
            self._pose_source = POSE_SIMULATOR_TRUTH
        else:
            latest = self.latest_orientations()
            q_segments = self._figure_from({seg: latest[sid] for sid, seg in self.sensor_segments.items()
                                            if sid in latest})
            if q_segments is not None:
                t_pose = self._newest_time()
                self._pose_source = POSE_SENSOR_AXES
        if not q_segments:
            self._pose_source = POSE_UNASSIGNED if self._sensors else POSE_NONE
            return
        missing = [name for name in self.model.segment_names if name not in q_segments]
        if missing:
            raise ValueError(f"the {self.pose_source} pose lacks segments of the {self.model.name} model: "
                             f"{', '.join(missing)}; choose the model the source was made for")
        q_stacked = np.array([q_segments[name] for name in self.model.segment_names], dtype=float)
        self._q_world_from_segment = q_segments
        self._q_stacked = q_stacked
        self._root_m = root
        self._t_s = t_pose
        self._frame_id += 1
        self._geometry = None
        self._pending_angles.append((t_pose, q_stacked))
        if len(self._pending_angles) > self._angle_t.capacity:
            del self._pending_angles[: len(self._pending_angles) - self._angle_t.capacity]
        self.events.frame.emit(self._frame_id)

    def _flush_angles(self) -> None:
        """Joint angles of the poses since the last call, computed in one vectorised batch
        (the plots ask at 30 Hz; poses arrive at up to 100 Hz)."""
        if not self._pending_angles:
            return
        pending, self._pending_angles = self._pending_angles, []
        t = np.array([p[0] for p in pending])
        q = np.array([p[1] for p in pending]).transpose(1, 0, 2)  # (S, P, 4), segments in model order
        angles = skeleton.joint_angles_deg_stacked(self.model, q)  # (J, P, 3) in column order
        self._angle_t.append(t, t)
        for joint, row in self._joint_row.items():
            self._angles[joint].append(t, angles[row])

    def _journal_truth(self, truth: SuitTruth) -> None:
        """Hand a new block of the simulator's truth to the recorder, on host time."""
        self._journaled_truth = truth
        self._recorder.add_truth(self.feed.host_time_of(truth.t_s), truth.q_world_from_segment, truth.joint_angles_deg,
                                 truth.root_position_m, TRUTH_NOTE)

    def _truth_through_assignment(self, truth: SuitTruth) -> dict[str, np.ndarray] | None:
        """The simulated subject's pose as the sensor assignment shows it: each assigned
        segment turns as the segment its sensor is really worn on (so a sensor assigned to the
        wrong segment shows as it would on real hardware), the others follow their parents
        (:func:`bodycal.fill_missing_segments`; an unassigned pelvis faces north). ``None`` when
        no sensor is assigned."""
        newest = {name: q[-1] for name, q in truth.q_world_from_segment.items()}
        return self._figure_from({segment: newest[self._worn_on[sid]] for sid, segment in self.sensor_segments.items()
                                  if self._worn_on.get(sid) in newest})

    def _figure_from(self, found: Mapping[str, np.ndarray]) -> dict[str, np.ndarray] | None:
        """Every segment's orientation from those of the segments that have one (``found``,
        segment → ``q_world_from_segment``): the others follow their parents, an absent root
        faces north. ``None`` when ``found`` is empty."""
        if not found:
            return None
        found = dict(found)
        if self.model.root not in found:
            found[self.model.root] = skeleton.q_world_from_body_facing(0.0)
        return self._filled(found)

    def _filled(self, found: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        return bodycal.fill_missing_segments(found, self._segment_parents)

    def _newest_time(self) -> float:
        times = [s.raw.latest_t() for s in self._sensors.values() if len(s.raw)]
        return max(times) if times else float("nan")

    def frame(self) -> tuple[object, FigureGeometry] | None:
        """``(frame_id, geometry)`` of the newest pose, or None before the first one.

        ``frame_id`` changes with every new pose and with the display mode.
        """
        if self._q_world_from_segment is None:
            return None
        frame_id = (self._frame_id, self.display_mode)
        if self._geometry is None or self._geometry[0] != frame_id:
            q = self._q_stacked
            heading_ref = None
            if self.body_calibration is not None:
                heading_ref = bodycal_heading(self.body_calibration)
            proximal, distal = skeleton.forward_kinematics_stacked(self.model, q, self.height_m, self._root_m)
            geometry = self.builder.build_arrays(proximal, distal, q, mode=self.display_mode,
                                                 heading_ref_rad=heading_ref)
            self._geometry = (frame_id, geometry)
        return self._geometry

    # -- views for the panel and the plots -----------------------------------------------------
    def segment_states(self) -> dict[str, str]:
        """Segment → tint state of its sensor (``ok``, ``mag_uncalibrated``, ``stale``)."""
        return {row.segment: row.state for row in self.sensor_rows() if row.segment is not None}

    def sensor_rows(self) -> list[SensorRow]:
        """One :class:`SensorRow` per known sensor, in the source's order."""
        now = self._clock()
        stats = self.feed.stats()
        rows = []
        for sid in self.sensor_ids:
            st = stats.get(sid)
            state = self._sensors.get(sid)
            last_seen = float("nan") if st is None else st.last_seen_s
            stale = not (now - last_seen <= STALE_AFTER_S)
            calibration = self.mag_calibrations.get(sid)
            onboard = state is not None and state.onboard
            truth_shown = self._pose_source == POSE_SIMULATOR_TRUTH
            if calibration is not None:
                mag_cal, age = "calibrated", _age_s(calibration.created_utc)
            elif onboard:
                mag_cal, age = "on-board", float("nan")
            else:
                mag_cal, age = "not calibrated", float("nan")
            flags = ()
            if state is not None and state.ekf is not None:
                flags = tuple(label for key, label in FLAG_LABELS.items() if state.flags & FLAG_NAMES[key])
            if stale:
                tint = "stale"
            elif mag_cal == "not calibrated" and not truth_shown:
                tint = "mag_uncalibrated"
            else:
                tint = "ok"
            rows.append(SensorRow(
                sensor_id=sid, segment=self.sensor_segments.get(sid),
                rate_hz=float("nan") if st is None else st.rate_hz, drops=0 if st is None else st.drops,
                latency_ms=float("nan") if st is None else 1000.0 * st.latency_p95_s,
                battery_pct=float("nan") if state is None else state.battery_pct,
                mag_cal=mag_cal, mag_cal_age_s=age, flags=flags, stale=stale, state=tint,
                rejections={} if st is None else dict(st.rejections)))
        return rows

    def series(self, sensor_id: str, window_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Last ``window_s`` seconds of one sensor: ``t_s`` (N,), ``acc`` (N,3) m/s², ``gyr``
        (N,3) rad/s, ``mag_uT`` (N,3) (calibrated when a calibration is applied)."""
        state = self._sensors.get(sensor_id)
        if state is None or not len(state.raw):
            empty = np.zeros((0, 3))
            return np.zeros(0), empty, empty, empty
        t, raw = state.raw.since(state.raw.latest_t() - window_s)
        return t, raw[:, 0], raw[:, 1], raw[:, 2]

    def joint_series(self, joint: str, window_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Last ``window_s`` seconds of ``joint``'s angles: ``t_s`` (N,), ``angles_deg`` (N,3)
        in the order of :meth:`joint_columns`."""
        self._flush_angles()
        buffer = self._angles[joint]
        if not len(buffer):
            return np.zeros(0), np.zeros((0, 3))
        return buffer.since(buffer.latest()[0] - window_s)

    # -- recording ---------------------------------------------------------------------------
    @property
    def recording(self) -> bool:
        return self._recorder is not None

    @property
    def recording_started_s(self) -> float | None:
        """Session time (s) at which the current recording started, ``None`` when not
        recording: an instant's time in the recording (what review and export show) is its
        session time minus this."""
        if self._recorder is None:
            return None
        return self._recorder.start_host_s - self.t0_host_s

    def start_recording(self, path: str | Path, subject: Mapping[str, Any] | None = None) -> None:
        """Record everything from now on into session file ``path`` (journal beside it)."""
        if self._recorder is not None:
            raise ValueError(f"already recording to {self._recorder.out_path}")
        if not self.started:
            raise ValueError("start the source before recording")
        metadata = {
            "source": self.label, "sensor_segments": dict(self.sensor_segments),
            "skeleton_model": self.model.name, "height_m": self.height_m,
            "subject": dict(subject or {}), "created_by": "mimucap gui",
        }
        if self.body_calibration is not None:
            metadata["body_calibration"] = self.body_calibration.to_dict()
        if self.mag_calibrations:
            metadata["mag_calibrated_sensors"] = sorted(self.mag_calibrations)
        recorder = Recorder(path, metadata)
        recorder.start(self._clock())
        self._recorder = recorder
        self._journaled_truth = None
        self._recording_markers = 0
        self.events.recording.emit(self.recording_info())

    def add_marker(self, label: str) -> float:
        """Mark now with ``label`` (in the recording when recording); returns its ``t_s``."""
        now = self._clock()
        label = str(label).strip() or "marker"
        if self._recorder is not None:
            if not self._recorder.add_marker(label, now):
                raise OSError(self._recorder.failure or f"could not write the marker to {self._recorder.out_path}")
            self._recording_markers += 1
        t_s = now - (self.t0_host_s or now)
        self.events.marker.emit(t_s, label, self._recorder is not None)
        return t_s

    def recording_info(self) -> RecordingInfo | None:
        recorder = self._recorder
        if recorder is None:
            return None
        try:
            size = recorder.journal_path.stat().st_size
        except OSError:
            size = 0
        return RecordingInfo(path=recorder.out_path, elapsed_s=self._clock() - recorder.start_host_s,
                             size_bytes=size, markers=self._recording_markers, samples=dict(recorder.samples))

    @property
    def recording_failure(self) -> str | None:
        return None if self._recorder is None else self._recorder.failure

    def end_recording(self) -> RecordingToSave:
        """Stop recording now (fast: the journal gets its last records and is closed); the
        returned :class:`RecordingToSave` writes the session file when asked (in any thread:
        a long recording takes seconds to convert). Until then the journal holds everything."""
        if self._recorder is None:
            raise ValueError("not recording")
        recorder, self._recorder = self._recorder, None
        status = {sid: {"received": s.received, "drops": s.drops, "rate_hz": s.rate_hz}
                  for sid, s in self.feed.stats().items()}
        recorder.close(status)
        pending = RecordingToSave(recorder=recorder)
        self.events.recording.emit(None)
        return pending

    def stop_recording(self) -> RecordingResult:
        """Stop and write the session file now; returns what was written."""
        result = self.end_recording().save()
        self.last_recording = result
        return result


@dataclass
class _FusionInput:
    """One block of one sensor for its filter: times ``t`` (N,) s, ``gyr`` (N, 3) rad/s,
    ``acc`` (N, 3) m/s² and ``mag`` (N, 3) µT (calibrated) or ``None``."""

    state: _SensorState
    t: np.ndarray
    gyr: np.ndarray
    acc: np.ndarray | None
    mag: np.ndarray | None


def _fuse(inputs: list[_FusionInput]) -> None:
    """Run each input through its sensor's filter and keep the newest orientation and flags.

    Sensors whose blocks have the same length and channels and whose filters the same
    settings go through the filter in one call (:func:`update_together`): on a poll of a
    17-sensor suit that is one call instead of 17. A sensor with more than one block in the
    poll has its blocks fused one after the other."""
    blocks_of = Counter(id(item.state) for item in inputs)
    groups: dict[object, list[_FusionInput]] = {}
    for item in inputs:
        shares = blocks_of[id(item.state)] == 1  # a filter appears once in a call
        key = (len(item.t), item.acc is None, item.mag is None, item.state.ekf.grouping_key) if shares else id(item)
        groups.setdefault(key, []).append(item)
    for group in groups.values():
        stacked = lambda name: None if getattr(group[0], name) is None else np.stack(  # noqa: E731
            [getattr(item, name) for item in group])
        result = update_together([item.state.ekf for item in group], stacked("t"), stacked("gyr"),
                                 stacked("acc"), stacked("mag"))
        newest_q = result.q_world_from_sensor[:, -1]
        finite = np.isfinite(newest_q).all(axis=1).tolist()
        for item, q, flags, ok in zip(group, newest_q, result.flags[:, -1].tolist(), finite):
            if ok:
                item.state.q_world_from_sensor = q
            item.state.flags = int(flags)


def _merged_per_sensor(blocks: list[SampleBlock]) -> list[SampleBlock]:
    """The blocks of one poll with each sensor's consecutive blocks (same channels) joined:
    wireless nodes arrive a sample or two at a time, and the filter, buffers and statistics
    cost the same per call whatever the block's length."""
    groups: dict[tuple, list[SampleBlock]] = {}
    for block in blocks:
        if len(block):
            groups.setdefault((block.sensor_id, block.channels()), []).append(block)
    return [concatenate_blocks(parts) for parts in groups.values()]


@dataclass
class RecordingToSave:
    """A stopped recording whose session file is still to be written.

    :meth:`save` reads only the closed recorder's journal (samples, markers and, when the
    simulated suit was shown, its truth), so it may run off the GUI thread.
    """

    recorder: Recorder

    @property
    def session_path(self) -> Path:
        return self.recorder.out_path

    def save(self) -> RecordingResult:
        """Write the session file and remove the journal."""
        return self.recorder.write_session()


def bodycal_heading(calibration: bodycal.BodyCalibration) -> float:
    """Heading (rad, CCW from north) the subject faced in the calibration's N-pose."""
    return heading_rad(np.asarray(calibration.q_world_from_body, dtype=float))


def _age_s(created_utc: str) -> float:
    try:
        created = datetime.fromisoformat(created_utc.replace("Z", "+00:00"))
    except (ValueError, AttributeError):
        return float("nan")
    if created.tzinfo is None:
        created = created.replace(tzinfo=timezone.utc)
    return (datetime.now(timezone.utc) - created).total_seconds()


def open_live_session(spec: str = "simulated", clock: Callable[[], float] = time.monotonic,
                      time_scale: float = 1.0, in_process_simulator: bool = True,
                      n_sensors: int | None = None, rate_hz: float = 100.0,
                      model_name: str | None = None) -> LiveSession:
    """A live session (not started) for source ``spec``.

    ``simulated[:SCENARIO]`` runs the simulated suit (``n_sensors`` at ``rate_hz``) in process
    (wizards can direct it) unless ``in_process_simulator`` is False; everything else
    (``udp:``, ``serial:``, ``replay:``) runs in acquisition workers.

    ``model_name`` (``"ten_segment"`` or ``"fifteen_segment"``, default ten) is the skeleton
    the sensors drive. The simulated suit wears 10 sensors on the ten-segment model and 17 on
    the fifteen-segment one unless ``n_sensors`` says otherwise (more than 10 sensors imply
    the fifteen-segment model).
    """
    if model_name is not None and model_name not in skeleton.MODEL_NAMES:
        raise ValueError(f"unknown skeleton model {model_name!r}; use one of {', '.join(skeleton.MODEL_NAMES)}")
    parsed = parse_source_spec(spec)
    if isinstance(parsed, SimulatedSpec) and in_process_simulator:
        if n_sensors is None:
            n_sensors = 17 if model_name == "fifteen_segment" else 10
        config = SimulationConfig(scenario=parsed.scenario, n_sensors=n_sensors, rate_hz=rate_hz)
        feed = SimulatorFeed(config, clock=clock, time_scale=time_scale)
        return LiveSession(feed, f"simulated:{parsed.scenario}", model_name=config.model_name,
                           height_m=config.height_m, clock=clock)
    options = SourceOptions() if n_sensors is None else SourceOptions(sensor_count=n_sensors)
    feed = SupervisorFeed(spec, options)
    return LiveSession(feed, spec, model_name=model_name or "ten_segment", clock=clock)
