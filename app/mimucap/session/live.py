"""The live session the main window shows: sensor blocks in, skeleton, plots and files out (no Qt).

:class:`LiveSession` is driven by one clock, in one thread (the GUI's pump, a test's loop):
:meth:`LiveSession.step` takes whatever the source (a feed of :mod:`mimucap.session.feeds`) delivered since the last
call and runs it through the one processing path of :mod:`mimucap.core.pipeline`
(:class:`~mimucap.core.pipeline.live.LivePipeline`): magnetometer calibration, orientation filter
(``q_world_from_sensor``, world ENU, scalar first; the device's own when it fuses on board),
poses at one instant through the body calibration (until one is applied, each assigned
sensor's axes stand for its segment, for every source alike), joint angles (deg) computed in
one batch when the plots ask (:meth:`LiveSession.joint_series`), and the recorder
(:class:`~mimucap.session.recording.Recorder`) when recording. A recording stores what is
needed to compute the same numbers again (:mod:`mimucap.session.processing`).

The session is a composition of parts with small interfaces: the *source* (``feed``: ``poll``,
``stats``, ``follow(instruction)``), the *pipeline* (``pipeline``,
:class:`~mimucap.core.pipeline.live.LivePipeline`), the *pose* (``pose``,
:class:`~mimucap.session.live_pose.LivePose`: the newest pose, where the figure stands, its
picture and the joint-angle history), the *recorder* (:class:`~mimucap.session.recording.Recorder`,
while recording) and the *status* (``status``,
:class:`~mimucap.session.live_status.StatusPublisher`: what the panels show, at a steady rate).
It tells what changed through its events (:class:`LiveSession`, napari style): widgets
subscribe to them and never ask the session on a timer of their own. Magnetometer calibrations are
data that persist, kept per device: each sensor the source brings gets the calibration stored for
the device the source says it is (and no other: another suit numbered alike takes none, and the
sensor says why), and a calibration made in the wizard is saved there for that device. Each
calibration's standing (:func:`~mimucap.core.magcal.standing.calibration_standing`: verdict,
device, the local field of the last seconds, age) is in the sensor rows, the checklist and what
a recording stores (``magnetometer_readiness``). The simulated suit's ground truth
is kept beside the data for evaluation only (:meth:`LiveSession.truth_pose`, the recording's
truth); it never drives the figure.

Times: ``t_s`` is seconds on the host monotonic clock since the live session started.

API for calibration wizards (``MagnetometerWizard(parent, live_session)``,
``BodyCalibrationWizard(parent, live_session)``):

* ``live_session.instruct(instruction)`` (:mod:`mimucap.session.instructions`): what the subject
  is asked to do; the source is told too (the simulated subject does it);
* ``live_session.events.processed.connect(callback)``: ``callback(items)`` gets every list of
  :class:`ProcessedBlock` (raw samples and the pipeline's orientations) as it arrives;
* ``live_session.sensor_ids``, ``live_session.sensor_segments`` (sensor id → segment),
  ``live_session.latest_orientations()`` (sensor id → ``q_world_from_sensor`` (4,)),
  ``live_session.series(sensor_id, window_s)`` (recent ``t_s``, ``acc``, ``gyr``, ``mag_uT``);
* ``live_session.apply_mag_calibration(cal)``, ``live_session.mag_calibrations``,
  ``live_session.onboard_sensors()`` (sensors that fuse on board: nothing to calibrate);
* ``live_session.apply_body_calibration(cal)`` and ``live_session.clear_body_calibration()``;
* ``live_session.events.calibration`` is emitted after either changes.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from mimucap.acquisition.source_spec import SimulatedSpec, format_source_spec, parse_source_spec
from mimucap.core import bodycal, skeleton
from mimucap.core.clinical_names import segment_name
from mimucap.core.fusion import FLAG_NAMES
from mimucap.core.device_identity import SensorDevice, describe_device, devices_to_json
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.magcal.standing import LocalField, Standing, age_s_at, local_field
from mimucap.core.sensor_samples import SensorSamples, join_per_sensor
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.truth import SuitTruth
from mimucap.io.calibration_store import CalibrationFileError, CalibrationStore
from mimucap.io.pairing_store import PairingStore
from mimucap.session.evaluation import angle_errors
from mimucap.session.events import EmitterGroup
from mimucap.session.feeds import SimulatorFeed, SupervisorFeed
from mimucap.session.figure import FigureBuilder, FigureGeometry, bodycal_heading, emit_pose_figures
from mimucap.session.instructions import Instruction
from mimucap.session.live_pose import LivePose, joint_column_groups
from mimucap.session.live_status import StatusPublisher
from mimucap.session.lsl_clock import recording_lsl_clock
from mimucap.session.processing import check_body_calibration_fits, recording_record
from mimucap.session.recording_checklist import magnetometer_readiness, sensor_standing
from mimucap.session.recording import Recorder, RecordingResult
from mimucap.session.ring_buffer import RingBuffer
from mimucap.session.sources import SourceOptions
from mimucap.core.pipeline import doubt_reasons
from mimucap.core.pipeline.chain import SensorOrientations
from mimucap.core.pipeline.live import LivePipeline
from mimucap.core.pipeline.recording import POSE_BODY_CALIBRATION, POSE_SENSOR_AXES
from mimucap.core.pipeline.segments import one_sensor_per_segment
from mimucap.core.pipeline.settings import RESULT_LIVE, PipelineSettings
from mimucap.core.heading_sources import heading_coupling

#: A sensor whose last sample arrived longer ago than this (s) is flagged stale.
STALE_AFTER_S = 1.0
#: Longest scrolling window the live plots can show (s).
MAX_WINDOW_S = 30.0
#: Samples per second the ring buffers are sized for (larger rates keep a shorter history).
BUFFER_RATE_HZ = 200.0
#: Joint-angle history rate bound: one pose per pipeline step (the GUI pumps at 62.5 Hz; other
#: drivers, e.g. a test's stepped clock, may step faster).
ANGLE_BUFFER_RATE_HZ = 120.0

#: Where a recording's ground truth came from (stored with it, for evaluation).
TRUTH_NOTE = "simulated suit shown live in mimucap gui"
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
    ``mag_cal_age_s`` since the calibration was made (NaN if none); ``mag_cal_verdict`` its
    verdict (``good``, ``warn``; "" without one); ``mag_field_warning`` says when the local field
    (magnitude, dip) no longer matches the calibration's (""); ``mag_standing`` the
    calibration's standing (:func:`~mimucap.core.magcal.standing.calibration_standing`: verdict,
    device, local field, age; ``None`` without a calibration); ``mag_cal_note`` why a
    calibration stored under its id is not used (another device's, a damaged file:
    ``mag_cal_unreadable``; "");
    ``device`` what the source says of its device (:class:`~mimucap.core.device_identity.SensorDevice`);
    ``local_field`` the field it measures now, corrected by its calibration (``None`` without a
    calibration or enough samples); ``has_magnetometer`` whether it sends a magnetic field;
    ``flags`` fusion flags
    now (``"rest"``, ``"mag disturbed"``, ...); ``stale`` no sample for :data:`STALE_AFTER_S`;
    ``state`` the tint name of its segment (``ok``, ``mag_uncalibrated``, ``stale``);
    ``signal_dbm`` the strength of its radio link where the source reports one (SlimeVR), NaN
    otherwise; ``rejections`` packets of this sensor the source refused, by reason
    (:class:`~mimucap.acquisition.rejections.Rejection` value → count, since the source started);
    ``doubt`` why its newest orientation may be wrong, in words ("" when it is trustworthy;
    :mod:`mimucap.core.pipeline.doubt_reasons`).
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
    mag_cal_verdict: str = ""
    mag_field_warning: str = ""
    signal_dbm: float = float("nan")
    rejections: Mapping[str, int] = field(default_factory=dict)
    mag_standing: Standing | None = None
    mag_cal_note: str = ""
    mag_cal_unreadable: bool = False
    device: SensorDevice | None = None
    local_field: LocalField | None = None
    has_magnetometer: bool = False
    doubt: str = ""


def doubt_warning(rows) -> str:
    """What the status bar says while sensors' orientations are doubtful: why, and the sensors
    (segment and id) for each reason ("" when every orientation is trustworthy)."""
    sensors_of: dict[str, list[str]] = {}
    for row in rows:
        if row.doubt and not row.stale:
            where = f"{segment_name(row.segment)} ({row.sensor_id})" if row.segment else row.sensor_id
            sensors_of.setdefault(row.doubt, []).append(where)
    parts = [f"{why}: {', '.join(sensors)}" for why, sensors in sensors_of.items()]
    return ("Orientation doubtful — " + "; ".join(parts)) if parts else ""


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
    """Per-sensor live state: recent samples for the plots and the battery charge."""

    def __init__(self, sensor_id: str, capacity: int) -> None:
        self.sensor_id = sensor_id
        #: rows acc (m/s²), gyr (rad/s), mag (µT, calibrated when applied); NaN when absent
        self.raw = RingBuffer(capacity, (3, 3))
        self.has_mag = False
        self.battery_pct = float("nan")


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


class LiveSession:
    """The live pipeline of one source (see the module doc).

    Args:
        feed: the source, a :class:`~mimucap.session.feeds.LiveSource` (:class:`SimulatorFeed`
            or :class:`SupervisorFeed`, not started yet).
        label: how the status bar names the source.
        model_name: skeleton model (``"ten_segment"`` or ``"fifteen_segment"``).
        height_m: the subject's height (m).
        clock: monotonic clock (s), the same the feed uses.
        calibration_store: where magnetometer calibrations are kept (loaded for every sensor
            the source brings, saved when the wizard makes one); ``None`` keeps them in memory.
        settings: the processing path's settings (stored with every recording).
        status_clock: the clock (s) the status is published on: the wall's, since people read
            it, even when the data runs on a faster simulated ``clock`` (a test's).

    Events (``self.events``, :class:`~mimucap.session.events.EmitterGroup`), emitted in the
    thread that calls :meth:`step` (rates for the GUI's pump at 62.5 Hz); times ``t_s`` are
    session seconds:

    * data, from every :meth:`step` that took samples in:

      - ``blocks(list[SensorSamples])``: the raw blocks as they arrived;
      - ``processed(list[ProcessedBlock])``: the same data with the pipeline's orientations;
      - ``data(cursor_s)``: new samples (and angles) for the plots, up to :attr:`cursor_s`;
      - ``truth_frame(frame_id, geometry_or_None)``: with each new pose while someone listens,
        the simulator's true pose (:meth:`truth_frame`; evaluation only), just before ``frame``;
      - ``frame(frame_id, geometry)``: a new pose, as :meth:`frame` gives it (at most one a
        step, the step's last event, so that a view can draw all the step changed in one
        picture at once; again, with a new ``frame_id``, after the display mode or the height
        changed); its :class:`~mimucap.session.figure.FigureGeometry` is built only while
        someone listens;
      - ``sensors(sensor_ids)``: the tuple of known sensors grew (a worker source's sensors
        appear with their first samples);

    * state changes, when they happen:

      - ``pose_source(text)``: what drives the figure (:attr:`pose_source`) changed;
      - ``assignment(sensor_segments)``: a sensor was worn on another segment (a copy of
        :attr:`sensor_segments`);
      - ``calibration()``: a magnetometer or body calibration was applied or cleared;
      - ``recording(info_or_None)``: recording started (:class:`RecordingInfo`) or stopped;
      - ``recording_failed(text)``: the recording could not be written (a full disk...): why;
        once per recording, which the caller should then end (:meth:`end_recording`);
      - ``marker(t_s, label, recorded)``: a marker the user placed (``recorded``: it is in the
        recording, as markers are while recording; the simulated subject's activity changes are
        not markers);
      - ``truth_available(bool)``: the source's truth became known (:attr:`has_truth`);

    * the status, at :data:`~mimucap.session.live_status.STATUS_RATE_HZ` (4 Hz on
      ``status_clock``) and at once after a change it shows (:meth:`publish_status` publishes it
      now):

      - ``status(list[SensorRow])``: the sensor table (rates and drops over the last 2 s);
      - ``checklist(list[CheckItem])``: the checklist before recording (not while recording);
      - ``recording_progress(RecordingInfo)``: while recording (elapsed s, bytes, markers);
      - ``source_problem(text)``: why the source may send nothing ("" : nothing known), when it
        changed;
      - ``refused(reasons, senders)``: packets refused from no known sensor (reason → count,
        sender → count), when they changed;
      - ``unpaired(list[UnpairedSensor])``: the sensors a network source refuses because their
        device is not paired (:mod:`mimucap.acquisition.pairing`), when they changed (a device
        became known, another was heard);
      - ``truth_errors(column → RMS deg)``: the running flexion error against the simulator's
        truth over 5 s (sources with truth, while someone listens).
    """

    def __init__(self, feed, label: str = "", model_name: str = "ten_segment", height_m: float = 1.75,
                 clock: Callable[[], float] = time.monotonic, calibration_store: CalibrationStore | None = None,
                 settings: PipelineSettings = PipelineSettings(),
                 status_clock: Callable[[], float] = time.monotonic) -> None:
        self.feed = feed
        self.label = label or getattr(feed, "name", "source")
        self.model = skeleton.load_model(model_name)
        #: the pose part: the newest pose, its figure, the joint-angle history
        self.pose = LivePose(self.model, height_m, MAX_WINDOW_S, ANGLE_BUFFER_RATE_HZ)
        self.events = EmitterGroup("blocks", "processed", "data", "frame", "truth_frame", "sensors",
                                   "pose_source", "assignment", "calibration", "recording", "marker",
                                   "recording_failed", "truth_available", "status", "checklist", "recording_progress",
                                   "source_problem", "refused", "unpaired", "truth_errors")
        self.pipeline = LivePipeline(self.model, settings, heading_coupling(settings, RESULT_LIVE))
        self.calibration_store = calibration_store
        #: the paired suit the network sources let in (:func:`open_live_session` sets it; the
        #: source must be opened again for a device paired meanwhile to be let in)
        self.pairing_store: PairingStore | None = None
        #: sensor → why a magnetometer calibration stored under its id is not used (a damaged
        #: file, another device's calibration)
        self.calibration_problems: dict[str, str] = {}
        #: sensor → what the source says of its device (updated from the feed every step)
        self.devices: dict[str, SensorDevice] = dict(feed.devices())
        #: sensors whose calibration in use was loaded from the store (a change of device drops it)
        self._stored_calibrations: set[str] = set()
        #: sensors of :attr:`calibration_problems` whose stored file could not be read
        self._unreadable: set[str] = set()
        self._clock = clock
        self.t0_host_s: float | None = None
        #: sensor id → segment, as the source names it (a replayed recording's placement, the
        #: simulated suit's labels); the user's assignment changes it
        self.sensor_segments: dict[str, str] = one_sensor_per_segment(feed.sensor_segments())
        self.body_calibration: bodycal.BodyCalibration | None = None
        self._capacity = int(MAX_WINDOW_S * BUFFER_RATE_HZ)
        self._sensors: dict[str, _SensorState] = {}
        self._joint_columns = joint_column_groups(self.model)
        self._pose_source = POSE_NONE
        self._recorder: Recorder | None = None
        self._journaled_truth: SuitTruth | None = None   # the simulator truth block last recorded
        #: newest pose of the simulator's truth (segment → (4,)), for evaluation only
        self._truth_pose: dict[str, np.ndarray] | None = None
        self._truth_geometry: tuple[object, FigureGeometry] | None = None
        #: the simulator's true joint angles (deg) of the last seconds, for the accuracy check
        self._truth_angles = {j: RingBuffer(int(MAX_WINDOW_S * BUFFER_RATE_HZ), (3,)) for j in self._joint_columns}
        self._recording_markers = 0
        self._failure_told = False
        self.last_recording: RecordingResult | None = None
        self.samples_received = 0
        self.last_arrival_s = float("nan")   #: host time the newest block arrived (latency bench)
        self.started = False
        self._known_ids: tuple[str, ...] = ()
        self._load_stored_calibrations(self.feed.sensor_ids)
        #: the status part: publishes what the panels show (see :mod:`mimucap.session.live_status`)
        self.status = StatusPublisher(self, self.events, status_clock)

    # -- source ----------------------------------------------------------------------------
    @property
    def simulator(self):
        """The in-process :class:`~mimucap.core.simulate.suit.SuitSimulator`, or ``None`` (for the
        evaluation of its truth; the pipeline and the procedures never ask for it)."""
        return getattr(self.feed, "simulator", None)

    def instruct(self, instruction: Instruction) -> None:
        """Tell the source what a procedure asks of the subject (the person reads it on the
        screen; the simulated subject does it)."""
        self.feed.follow(instruction)

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
        return self.pose.time_s

    @property
    def cursor_s(self) -> float:
        """The time the plots are aligned to (s): the newest pose (what the 3D view shows),
        live; while no pose is made (no sensor assigned yet), the newest sample's time, so the
        plots still scroll with the raw data. NaN before any data."""
        if self._pose_source in (POSE_NONE, POSE_UNASSIGNED):
            return self._newest_time()
        return self.pose.time_s

    @property
    def q_world_from_segment(self) -> dict[str, np.ndarray] | None:
        """Newest segment orientations, segment → ``(4,)`` (world ENU, scalar first)."""
        return self.pose.q_world_from_segment

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.pose.joint_names

    def joint_columns(self, joint: str) -> tuple[str, str, str]:
        """The three angle column names of ``joint`` (meaning and ``_deg`` unit in the name)."""
        return self.pose.joint_columns(joint)

    @property
    def height_m(self) -> float:
        """The subject's height (m)."""
        return self.pose.height_m

    @property
    def builder(self) -> FigureBuilder:
        """What makes the figure of a pose (the model at the subject's height)."""
        return self.pose.builder

    @property
    def display_mode(self) -> str:
        return self.pose.display_mode

    def latest_orientations(self) -> dict[str, np.ndarray]:
        """Sensor id → newest ``q_world_from_sensor`` (4,) (sensors with an estimate only)."""
        return self.pipeline.latest_orientations()

    def onboard_sensors(self) -> tuple[str, ...]:
        """Sensors that send their own orientation (fused on board: no magnetometer to calibrate)."""
        return tuple(sid for sid, chain in self.pipeline.chains.items() if chain.onboard)

    def orientation_only_sensors(self) -> tuple[str, ...]:
        """Sensors that send their own orientation and no magnetometer readings (on-board
        fusion that calibrates itself, e.g. SlimeVR trackers): nothing to calibrate here."""
        onboard = set(self.onboard_sensors())
        return tuple(sid for sid, s in self._sensors.items() if sid in onboard and not s.has_mag)

    def set_display_mode(self, mode: str) -> None:
        """``"world"`` or ``"body"`` (see :mod:`mimucap.session.figure`)."""
        self.pose.set_display_mode(mode)
        self._emit_frame()

    def set_height(self, height_m: float) -> None:
        """The subject's height (m): rescales the figure."""
        self.pose.set_height(height_m)
        self._emit_frame()

    def assign_sensor(self, sensor_id: str, segment: str | None) -> None:
        """Wear ``sensor_id`` on ``segment`` (``None`` unassigns); a segment holds one sensor."""
        if segment is not None and segment not in self.model.segment_names:
            raise ValueError(f"sensor {sensor_id}: unknown segment {segment!r}; use one of {', '.join(self.model.segment_names)}")
        for other, seg in list(self.sensor_segments.items()):
            if seg == segment and other != sensor_id:
                del self.sensor_segments[other]
        before = dict(self.sensor_segments)
        if segment is None:
            self.sensor_segments.pop(sensor_id, None)
        else:
            self.sensor_segments[sensor_id] = segment
        if self.sensor_segments != before:
            self.status.mark_due()
            self.events.assignment.emit(dict(self.sensor_segments))

    # -- calibrations ------------------------------------------------------------------------
    @property
    def mag_calibrations(self) -> dict[str, MagCalibration]:
        """Sensor id → the magnetometer calibration in use."""
        return self.pipeline.mag_calibrations

    def device_of(self, sensor_id: str) -> SensorDevice:
        """What the source says of ``sensor_id``'s device (nothing yet: ``SensorDevice()``)."""
        return self.devices.get(sensor_id, SensorDevice())

    def _load_stored_calibrations(self, sensor_ids) -> None:
        """Apply the stored magnetometer calibration of each sensor in ``sensor_ids`` that is
        not calibrated yet, its device's (:meth:`~mimucap.io.calibration_store.CalibrationStore.lookup`);
        a sensor whose source has not said which device it is waits for it. Why one stored under
        its id is not used (another device's, a damaged file) is kept in :attr:`calibration_problems`."""
        if self.calibration_store is None:
            return
        for sensor_id in sensor_ids:
            device = self.device_of(sensor_id)
            if sensor_id in self.mag_calibrations or sensor_id in self.calibration_problems or not device.settled:
                continue
            try:
                found = self.calibration_store.lookup(sensor_id, device)
            except (CalibrationFileError, OSError, ValueError) as error:
                self.calibration_problems[sensor_id] = str(error)
                self._unreadable.add(sensor_id)
                continue
            if found.calibration is not None:
                self.pipeline.set_mag_calibration(found.calibration)
                self._stored_calibrations.add(sensor_id)
            elif found.note:
                self.calibration_problems[sensor_id] = found.note

    def _follow_devices(self) -> None:
        """Take what the source now says of its sensors' devices: a sensor whose device became
        known gets its device's stored calibration; one whose device changed (another node
        answering to the same id) loses a calibration made on another device."""
        devices = self.feed.devices()
        if devices == self.devices:
            return
        changed = [sid for sid in set(devices) | set(self.devices) if devices.get(sid) != self.devices.get(sid)]
        self.devices = dict(devices)
        for sensor_id in changed:
            calibration = self.mag_calibrations.get(sensor_id)
            now = self.device_of(sensor_id).device_id
            made_on = None if calibration is None else calibration.device_id
            if calibration is not None and (sensor_id in self._stored_calibrations
                                            or (made_on is not None and now is not None and made_on != now)):
                self.pipeline.clear_mag_calibration(sensor_id)
                self._stored_calibrations.discard(sensor_id)
            self.calibration_problems.pop(sensor_id, None)
            self._unreadable.discard(sensor_id)
        self._load_stored_calibrations(changed)
        self.status.mark_due()
        self.events.calibration.emit()

    def _refuse_while_recording(self, what: str) -> None:
        if self._recorder is not None:
            raise ValueError(f"stop recording before {what}: a recording is computed with the calibrations "
                             "it started with")

    def apply_mag_calibration(self, calibration: MagCalibration, save: bool = True) -> None:
        """Use ``calibration`` for its sensor from now on (its filter learns the heading anew,
        :meth:`mimucap.core.pipeline.chain.SensorChain.set_mag_calibration`) and keep it in the
        calibration store (``save``) for the next start."""
        self._refuse_while_recording("changing a magnetometer calibration")
        device = self.device_of(calibration.sensor_id).device_id
        if calibration.device_id is None and device is not None:
            calibration = replace(calibration, device_id=device)   # made here, on this device
        elif calibration.device_id is not None and device is not None and calibration.device_id != device:
            raise ValueError(f"sensor {calibration.sensor_id}: this magnetometer calibration was made on "
                             f"{describe_device(calibration.device_id)}, and the sensor is "
                             f"{describe_device(device)}: calibrate it here")
        self.pipeline.set_mag_calibration(calibration)
        self._stored_calibrations.discard(calibration.sensor_id)
        self.calibration_problems.pop(calibration.sensor_id, None)
        self._unreadable.discard(calibration.sensor_id)
        if save and self.calibration_store is not None:
            self.calibration_store.save(calibration)
        self.status.mark_due()
        self.events.calibration.emit()

    def apply_body_calibration(self, calibration: bodycal.BodyCalibration) -> None:
        """Drive the figure through ``calibration`` (sensor → segment rotations) from now on."""
        self._refuse_while_recording("applying a body calibration")
        check_body_calibration_fits(calibration, self.model)
        self.body_calibration = calibration
        for segment, sensor in calibration.sensors.items():
            self.assign_sensor(sensor, segment)
        self._body_calibration_changed()

    def clear_body_calibration(self) -> None:
        self._refuse_while_recording("clearing the body calibration")
        self.body_calibration = None
        self._body_calibration_changed()

    def _body_calibration_changed(self) -> None:
        """The figure is driven anew: the poses made and where the figure stands are forgotten."""
        self.pipeline.forget_poses()
        self.pose.reset()
        self.status.mark_due()
        self.events.calibration.emit()

    # -- driving -----------------------------------------------------------------------------
    def step(self) -> int:
        """Run everything that arrived since the last call through the pipeline; returns the
        number of samples taken in."""
        if not self.started:
            return 0
        blocks = self.feed.poll()
        merged = join_per_sensor(blocks)  # once: the recorder and the pipeline take the same records
        if self._recorder is not None:
            if blocks:
                self._recorder.add_blocks(merged)
            else:
                self._recorder.tick()
            if self._recorder.failure and not self._failure_told:
                self._failure_told = True
                self.events.recording_failed.emit(self._recorder.failure)
        self._note_truth()
        self._follow_devices()
        if not blocks:
            self.status.tick()
            return 0
        self.last_arrival_s = max(float(b.receive_time_s[-1]) for b in blocks if len(b))
        self.events.blocks.emit(blocks)
        new_sensors = [b.sensor_id for b in merged if b.sensor_id not in self._sensors]
        if new_sensors:
            self._load_stored_calibrations(new_sensors)
            self.status.mark_due()
        times = [block.t_s - self.t0_host_s for block in merged]
        outputs = self.pipeline.feed([b.with_times(t) for b, t in zip(merged, times)])
        by_sensor = {out.sensor_id: out for out in outputs}
        processed = []
        count = 0
        for block, t in zip(merged, times):
            orientation = by_sensor.get(block.sensor_id)
            count += self._buffer(block, t, None if orientation is None else orientation.mag_uT)
            processed.append(ProcessedBlock(block.sensor_id, t, block, orientation))
        self.events.processed.emit(processed)
        self.samples_received += count
        known = self.sensor_ids
        if known != self._known_ids:
            self._known_ids = known
            self.events.sensors.emit(known)
        posed = self._update_pose()
        self.events.data.emit(self.cursor_s)
        self.status.tick()
        if posed:  # last: a view may draw everything this step changed in one picture at once
            self._emit_frame()
        return count

    def publish_status(self) -> None:
        """Emit the status events now, each of them (``status``, ``checklist`` or
        ``recording_progress``, ``source_problem``, ``refused``, ``truth_errors``) and
        ``pose_source``: for widgets that have just subscribed; :meth:`step` publishes the
        status at its own rate."""
        self.status.forget()
        self.events.pose_source.emit(self._pose_source)
        self.status.publish()

    def _buffer(self, block: SensorSamples, t: np.ndarray, mag_calibrated: np.ndarray | None) -> int:
        """Keep ``block`` for the plots (the calibrated field when there is one)."""
        n = len(block)
        state = self._sensors.get(block.sensor_id)
        if state is None:
            state = self._sensors[block.sensor_id] = _SensorState(block.sensor_id, self._capacity)
        mag = mag_calibrated if mag_calibrated is not None else block.mag_uT
        raw = np.full((n, 3, 3), np.nan)
        for row, values in enumerate((block.acc, block.gyr, mag)):
            if values is not None:
                raw[:, row] = values
        state.raw.append(t, raw)
        state.has_mag = state.has_mag or mag is not None
        if block.battery_pct is not None:
            state.battery_pct = float(block.battery_pct[-1])
        return n

    def _update_pose(self) -> bool:
        """Take the pipeline's newest pose; returns whether there is a new one."""
        pose = self.pipeline.pose(self.body_calibration, self.sensor_segments)
        if pose is None:
            if self.pose.q_world_from_segment is None or not self._assigned_sensors_seen():
                self._set_pose_source(POSE_UNASSIGNED if self._sensors else POSE_NONE)
            return False
        t_pose, q_segments = pose
        self._set_pose_source(POSE_BODY_CALIBRATION if self.body_calibration is not None else POSE_SENSOR_AXES)
        try:
            self.pose.take(t_pose, q_segments)
        except ValueError as error:
            raise ValueError(f"{self.pose_source}: {error}") from None
        return True

    def _set_pose_source(self, source: str) -> None:
        if source != self._pose_source:
            self._pose_source = source
            self.events.pose_source.emit(source)

    def _emit_frame(self) -> None:
        """Emit ``truth_frame`` and then ``frame`` with the newest pose's figure, built only when
        someone listens (a new ``frame_id`` for a new pose, display mode or height)."""
        if self.pose.q_world_from_segment is None:
            return
        self._truth_geometry = None
        emit_pose_figures(self)

    def _assigned_sensors_seen(self) -> bool:
        segments = (self.body_calibration.sensors.values() if self.body_calibration is not None
                    else self.sensor_segments)
        return any(sid in self._sensors for sid in segments)

    # -- the simulator's truth (evaluation only) -----------------------------------------------
    def _note_truth(self) -> None:
        """Keep the simulator's newest true pose for the on-screen comparison and journal its
        truth while recording; neither ever drives the figure."""
        truth = getattr(self.feed, "last_truth", None)
        if truth is None or truth is self._journaled_truth:
            return
        first = self._truth_pose is None
        self._truth_pose = {name: q[-1] for name, q in truth.q_world_from_segment.items()}
        if first:
            self.events.truth_available.emit(True)
        t = self.feed.host_time_of(truth.t_s) - self.t0_host_s
        for joint, columns in self._joint_columns.items():
            if all(c in truth.joint_angles_deg for c in columns):
                self._truth_angles[joint].append(t, np.stack([truth.joint_angles_deg[c] for c in columns], axis=-1))
        if self._recorder is not None:
            self._journal_truth(truth)
        self._journaled_truth = truth

    def truth_pose(self) -> dict[str, np.ndarray] | None:
        """The simulated subject's true segment orientations now (segment → (4,)), or ``None``
        for a source without truth. For evaluation: shown beside the estimate, never as it."""
        return self._truth_pose

    @property
    def has_truth(self) -> bool:
        """Whether the source knows the true pose (the simulated suit)."""
        return self._truth_pose is not None

    def truth_joint_series(self, joint: str, window_s: float) -> tuple[np.ndarray, np.ndarray]:
        """The simulator's true angles of ``joint`` over the last ``window_s`` seconds (as
        :meth:`joint_series`; empty for a source without truth). For evaluation only."""
        buffer = self._truth_angles[joint]
        if not len(buffer):
            return np.zeros(0), np.zeros((0, 3))
        return buffer.since(buffer.latest()[0] - window_s)

    def truth_errors(self, window_s: float = 5.0, columns=None) -> dict[str, float]:
        """RMS error (deg) of each joint-angle column (or only of ``columns``) against the
        simulator's truth over the last ``window_s`` seconds (empty for a source without truth):
        the on-screen accuracy check."""
        errors: dict[str, float] = {}
        if not self.has_truth:
            return errors
        wanted = None if columns is None else set(columns)
        for joint, joint_columns in self._joint_columns.items():
            if wanted is not None and wanted.isdisjoint(joint_columns):
                continue
            t, estimate = self.joint_series(joint, window_s)
            t_true, true = self.truth_joint_series(joint, window_s + 1.0)
            if not len(t) or len(t_true) < 2:
                continue
            found = angle_errors(t, dict(zip(joint_columns, estimate.T)), t_true, dict(zip(joint_columns, true.T)))
            errors.update({column: error.rms_deg for column, error in found.items()})
        return errors

    def _journal_truth(self, truth: SuitTruth) -> None:
        """Hand a new block of the simulator's truth to the recorder, on host time."""
        self._recorder.add_truth(self.feed.host_time_of(truth.t_s), truth.q_world_from_segment, truth.joint_angles_deg,
                                 truth.root_position_m, TRUTH_NOTE)

    def _newest_time(self) -> float:
        times = [s.raw.latest_t() for s in self._sensors.values() if len(s.raw)]
        return max(times) if times else float("nan")

    def frame(self) -> tuple[object, FigureGeometry] | None:
        """``(frame_id, geometry)`` of the newest pose, or None before the first one.

        ``frame_id`` changes with every new pose, display mode and height.
        """
        return self.pose.frame(self._heading_ref())

    def truth_frame(self) -> tuple[object, FigureGeometry] | None:
        """``(frame_id, geometry)`` of the simulator's true pose, standing where the estimate
        stands (the ghost figure of the on-screen accuracy check); ``None`` for a source without
        truth or before the first estimated pose. Evaluation only: never the figure itself."""
        truth = self._truth_pose
        if truth is None:
            return None
        frame_id = ("truth", self.pose.frame_id, self.pose.display_mode)
        if self._truth_geometry is None or self._truth_geometry[0] != frame_id:
            geometry = self.pose.figure_of(truth, self._heading_ref())
            if geometry is None:
                return None
            self._truth_geometry = (frame_id, geometry)
        return self._truth_geometry

    def _heading_ref(self) -> float | None:
        """The heading the body display mode turns to face the camera: the N-pose's."""
        return None if self.body_calibration is None else bodycal_heading(self.body_calibration)

    # -- views for the panel and the plots -----------------------------------------------------
    def segment_states(self) -> dict[str, str]:
        """Segment → tint state of its sensor (``ok``, ``mag_uncalibrated``, ``stale``)."""
        return {row.segment: row.state for row in self.sensor_rows() if row.segment is not None}

    def sensor_rows(self) -> list[SensorRow]:
        """One :class:`SensorRow` per known sensor, in the source's order."""
        now = self._clock()
        stats = self.feed.stats()
        signal = self.feed.signal_dbm()
        rows = []
        for sid in self.sensor_ids:
            st = stats.get(sid)
            state = self._sensors.get(sid)
            last_seen = float("nan") if st is None else st.last_seen_s
            stale = not (now - last_seen <= STALE_AFTER_S)
            calibration = self.mag_calibrations.get(sid)
            chain = self.pipeline.chains.get(sid)
            onboard = chain is not None and chain.onboard
            if calibration is not None:
                mag_cal, age = "calibrated", _age_s(calibration.created_utc)
            elif onboard:
                mag_cal, age = "on-board", float("nan")
            else:
                mag_cal, age = "not calibrated", float("nan")
            flags = ()
            if chain is not None and chain.ekf is not None:
                value = self.pipeline.flags.get(sid, 0)
                flags = tuple(label for key, label in FLAG_LABELS.items() if value & FLAG_NAMES[key])
            why = doubt_reasons.describe(self.pipeline.doubt_of(sid)) if chain is not None else ""
            if stale:
                tint = "stale"
            elif mag_cal == "not calibrated":
                tint = "mag_uncalibrated"
            else:
                tint = "ok"
            verdict = "" if calibration is None else str(calibration.quality.get("verdict", ""))
            device = self.device_of(sid)
            here = None if calibration is None or state is None else self._local_field(state)
            row = SensorRow(
                mag_cal_verdict=verdict, device=device, local_field=here,
                mag_cal_note="" if calibration is not None else self.calibration_problems.get(sid, ""),
                mag_cal_unreadable=calibration is None and sid in self._unreadable,
                has_magnetometer=state is not None and state.has_mag,
                sensor_id=sid, segment=self.sensor_segments.get(sid),
                rate_hz=float("nan") if st is None else st.rate_hz, drops=0 if st is None else st.drops,
                latency_ms=float("nan") if st is None else 1000.0 * st.latency_p95_s,
                battery_pct=float("nan") if state is None else state.battery_pct,
                mag_cal=mag_cal, mag_cal_age_s=age, flags=flags, stale=stale, state=tint,
                signal_dbm=signal.get(sid, float("nan")),
                rejections={} if st is None else dict(st.rejections), doubt=why)
            if calibration is not None:
                standing = sensor_standing(calibration, row)
                fits = [p.text for p in standing.problems if p.kind == "field"]
                row = replace(row, mag_standing=standing,
                              mag_field_warning="; ".join(fits) + ": calibrate again here" if fits else "")
            rows.append(row)
        return rows

    @staticmethod
    def _local_field(state: _SensorState) -> LocalField | None:
        """The field the sensor measured over the last :data:`FIELD_CHECK_WINDOW_S`, corrected
        by its calibration (the plots' buffer holds the corrected field)."""
        if not len(state.raw):
            return None
        _t, rows = state.raw.since(state.raw.latest_t() - FIELD_CHECK_WINDOW_S)
        return local_field(rows[:, 0], rows[:, 1], rows[:, 2])

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
        return self.pose.joint_series(joint, window_s)

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

    def start_recording(self, path: str | Path, subject: Mapping[str, Any] | None = None,
                        extra_metadata: Mapping[str, Any] | None = None) -> None:
        """Record everything from now on into session file ``path`` (journal beside it);
        ``extra_metadata``: further top-level metadata keys (e.g. the library's ``"library"``)."""
        if self._recorder is not None:
            raise ValueError(f"already recording to {self._recorder.out_path}")
        if not self.started:
            raise ValueError("start the source before recording")
        start_host_s = self._clock()
        metadata = {
            "source": self.label, "sensor_segments": dict(self.sensor_segments),
            "skeleton_model": self.model.name, "height_m": self.height_m,
            "subject": dict(subject or {}), "created_by": "mimucap gui",
            "devices": devices_to_json(self.devices),
            "magnetometer_readiness": magnetometer_readiness(self),
            **recording_record(mag_calibrations=self.mag_calibrations, body_calibration=self.body_calibration,
                               settings=self.pipeline.settings, filter_states=self.pipeline.filter_states(),
                               time_offset_s=start_host_s - self.t0_host_s),
        }
        lsl_clock = recording_lsl_clock(start_host_s, self._clock)
        if lsl_clock is not None:  # lines the recording up with a LabRecorder XDF of the same minutes
            metadata["lsl_clock"] = lsl_clock
        metadata.update(extra_metadata or {})
        recorder = Recorder(path, metadata)
        recorder.start(start_host_s)
        self._recorder = recorder
        self._failure_told = False
        self._journaled_truth = None
        self._recording_markers = 0
        self.status.mark_due()
        self.events.recording.emit(self.recording_info())

    def add_marker(self, label: str, host_s: float | None = None) -> float:
        """Mark now, or the instant ``host_s`` (s on the session's clock: a marker that came with
        its own time, e.g. from a Lab Streaming Layer stream), with ``label`` (in the recording
        when recording); returns its ``t_s``."""
        now = self._clock() if host_s is None else float(host_s)
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
        recorder.close(status, devices=devices_to_json(self.feed.devices()))
        pending = RecordingToSave(recorder=recorder)
        self.status.mark_due()
        self.events.recording.emit(None)
        return pending

    def stop_recording(self) -> RecordingResult:
        """Stop and write the session file now; returns what was written."""
        result = self.end_recording().save()
        self.last_recording = result
        return result


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

    def save(self, progress: Callable[[float], None] | None = None) -> RecordingResult:
        """Write the session file and remove the journal (``progress``: called with the
        fraction done, 0..1, in the thread that saves)."""
        return self.recorder.write_session(progress)


#: Seconds of recent samples the local field is measured over (the sensor panel, the checklist).
FIELD_CHECK_WINDOW_S = 2.0


def _age_s(created_utc: str) -> float:
    age = age_s_at(created_utc, datetime.now(timezone.utc))
    return float("nan") if age is None else age


def open_live_session(spec: str = "simulated", clock: Callable[[], float] = time.monotonic,
                      in_process_simulator: bool = True,
                      n_sensors: int | None = None, rate_hz: float = 100.0,
                      model_name: str | None = None,
                      calibration_store: CalibrationStore | None = None,
                      pairing_store: PairingStore | None = None) -> LiveSession:
    """A live session (not started) for source ``spec``.

    ``simulated[:SCENARIO][@ROOM]`` runs the simulated suit (``n_sensors`` at ``rate_hz``) in process
    (wizards can direct it) unless ``in_process_simulator`` is False; everything else
    (``udp:``, ``serial:``, ``replay:``) runs in acquisition workers.

    ``calibration_store`` keeps the magnetometer calibrations (default: the user's store,
    :class:`~mimucap.io.calibration_store.CalibrationStore`). ``pairing_store`` holds the paired
    suit (default: the user's, :class:`~mimucap.io.pairing_store.PairingStore`): the network
    sources (``udp:``, ``slimevr:``) let in only its devices; the simulated suit, a replay and a
    serial line need no pairing.

    ``model_name`` (``"ten_segment"`` or ``"fifteen_segment"``, default ten) is the skeleton
    the sensors drive. The simulated suit wears 10 sensors on the ten-segment model and 17 on
    the fifteen-segment one unless ``n_sensors`` says otherwise (more than 10 sensors imply
    the fifteen-segment model).
    """
    if model_name is not None and model_name not in skeleton.MODEL_NAMES:
        raise ValueError(f"unknown skeleton model {model_name!r}; use one of {', '.join(skeleton.MODEL_NAMES)}")
    parsed = parse_source_spec(spec)
    store = calibration_store if calibration_store is not None else CalibrationStore()
    if isinstance(parsed, SimulatedSpec) and in_process_simulator:
        if n_sensors is None:
            n_sensors = 17 if model_name == "fifteen_segment" else 10
        config = SimulationConfig(scenario=parsed.scenario, n_sensors=n_sensors, rate_hz=rate_hz, room=parsed.room)
        feed = SimulatorFeed(config, clock=clock)
        return LiveSession(feed, format_source_spec(parsed), model_name=config.model_name,
                           height_m=config.height_m, clock=clock, calibration_store=store)
    pairings = pairing_store if pairing_store is not None else PairingStore()
    options = SourceOptions(sensor_count=n_sensors, paired_devices=pairings.device_ids())
    feed = SupervisorFeed(spec, options)
    session = LiveSession(feed, spec, model_name=model_name or "ten_segment", clock=clock, calibration_store=store)
    session.pairing_store = pairings
    return session
