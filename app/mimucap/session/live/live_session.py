"""The live session the main window shows: sensor blocks in, skeleton, plots and files out (no Qt).

:class:`LiveSession` is driven by one clock, in one thread (the GUI's pump, a test's loop):
:meth:`LiveSession.step` takes whatever the source delivered since the last call and hands it
from part to part. It is a composition; each part is one concept in its own module, owns its
state and tells what changed through its own events (:mod:`mimucap.session.events`):

* ``sensors`` (:class:`~mimucap.session.live.sensors.LiveSensors`): the source, the session
  clock's origin, the sensors known, their devices and batteries, and which segment each is worn on;
* ``processing`` (:class:`~mimucap.session.live.processing.LiveProcessing`): the one processing
  path of :mod:`mimucap.core.pipeline` (magnetometer calibration, orientation filter
  ``q_world_from_sensor``, world ENU, scalar first; the pose of the assigned segments) and what
  drives the figure;
* ``calibrations`` (:class:`~mimucap.session.live.calibrations.LiveCalibrations`): the
  magnetometer calibration of each sensor, kept per device in the calibration store, and the
  body calibration;
* ``pose`` (:class:`~mimucap.session.views.live_pose.LivePose`): the newest pose, where the
  figure stands, its picture and the joint-angle history;
* ``history`` (:class:`~mimucap.session.live.plot_history.PlotHistory`): the last seconds of
  every sensor's samples, what the plots read;
* ``evaluation`` (:class:`~mimucap.session.live.evaluation.LiveEvaluation`): the simulator's
  truth beside the estimate, for evaluation only (it never drives the figure);
* ``recorder`` (:class:`~mimucap.session.live.recording.LiveRecording`): the recording and the markers;
* ``status`` (:class:`~mimucap.session.live.status.StatusPublisher`): what the panels show, at a
  steady rate (the rows are :func:`~mimucap.session.live.sensor_rows.sensor_rows`).

The session's own code is the order of a step and the reactions between parts (a body
calibration forgets the poses made; a recording locks the calibrations; a new device loads its
stored calibration). ``events`` offers every part's events under one name each, the same
emitters the parts own; widgets subscribe to them and never ask the session on a timer of their
own. The methods and properties below the parts are the small vocabulary the panels, the
commands and the tests use; each hands the call to the part that owns it.

Times: ``t_s`` is seconds on the host monotonic clock since the live session started.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from mimucap.acquisition.source_spec import SimulatedSpec, format_source_spec, parse_source_spec
from mimucap.core import bodycal, skeleton
from mimucap.core.device_identity import SensorDevice, devices_to_json
from mimucap.core.magcal.model import MagCalibration
from mimucap.core.pipeline.settings import PipelineSettings
from mimucap.core.pipeline.segments import assignment_of
from mimucap.core.sensor_samples import join_per_sensor
from mimucap.core.simulate.config import SimulationConfig
from mimucap.io.calibration_store import CalibrationStore
from mimucap.io.pairing_store import PairingStore
from mimucap.session.events import EmitterGroup
from mimucap.session.live.calibrations import LiveCalibrations
from mimucap.session.live.checklist import magnetometer_readiness
from mimucap.session.live.evaluation import TRUTH_ERROR_WINDOW_S, TRUTH_NOTE, LiveEvaluation
from mimucap.session.live.plot_history import ANGLE_BUFFER_RATE_HZ, MAX_WINDOW_S, PlotHistory
from mimucap.session.live.processing import LiveProcessing
from mimucap.session.live.recorder import RecordingResult
from mimucap.session.live.recording import LiveRecording, RecordingInfo, RecordingToSave
from mimucap.session.live.sensor_rows import SensorRow, sensor_rows
from mimucap.session.live.sensors import LiveSensors
from mimucap.session.live.status import StatusPublisher
from mimucap.session.streaming.lsl_clock import recording_lsl_clock
from mimucap.session.procedures.instructions import Instruction
from mimucap.session.recorded.stored_processing import recording_record
from mimucap.session.sources.feeds import SimulatorFeed, SupervisorFeed
from mimucap.session.sources.source_configs import SourceOptions
from mimucap.session.views.live_pose import LivePose
from mimucap.session.views.skeleton_figure import FigureBuilder, FigureGeometry, emit_pose_figures


class LiveSession:
    """The live pipeline of one source (see the module doc).

    Args:
        feed: the source, a :class:`~mimucap.session.sources.feeds.LiveSource` (:class:`SimulatorFeed`
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
      - ``processed(list[~mimucap.session.live.processing.ProcessedBlock])``: the same data with the pipeline's orientations;
      - ``data(cursor_s)``: new samples (and angles) for the plots, up to :attr:`cursor_s`;
      - ``truth_frame(frame_id, geometry_or_None)``: with each new pose while someone listens,
        the simulator's true pose (:meth:`truth_frame`; evaluation only), just before ``frame``;
      - ``frame(frame_id, geometry)``: a new pose, as :meth:`frame` gives it (at most one a
        step, the step's last event, so that a view can draw all the step changed in one
        picture at once; again, with a new ``frame_id``, after the display mode or the height
        changed); its :class:`~mimucap.session.views.skeleton_figure.FigureGeometry` is built only while
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

    * the status, at :data:`~mimucap.session.live.status.STATUS_RATE_HZ` (4 Hz on
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
        self.model = skeleton.load_model(model_name)
        self._clock = clock
        self.sensors = LiveSensors(feed, label, self.model, clock)
        self.processing = LiveProcessing(self.model, settings)
        self.calibrations = LiveCalibrations(self.sensors, self.processing, self.model, calibration_store)
        self.pose = LivePose(self.model, height_m, MAX_WINDOW_S, ANGLE_BUFFER_RATE_HZ)
        self.history = PlotHistory(self.sensors, self.processing, self.pose)
        self.evaluation = LiveEvaluation(self.pose, self.history, lambda: self.calibrations.heading_ref_rad)
        self.recorder = LiveRecording(clock)
        sensors, recorder, evaluation = self.sensors.events, self.recorder.events, self.evaluation.events
        self.events = EmitterGroup(
            "frame", "calibration", "status", "checklist",
            blocks=sensors.blocks, sensors=sensors.sensors, assignment=sensors.assignment,
            source_problem=sensors.problem, refused=sensors.refused, unpaired=sensors.unpaired,
            processed=self.processing.events.processed, pose_source=self.processing.events.pose_source,
            data=self.history.events.data,
            truth_frame=evaluation.truth_frame, truth_available=evaluation.available, truth_errors=evaluation.errors,
            recording=recorder.recording, recording_progress=recorder.progress, marker=recorder.marker,
            recording_failed=recorder.failed)
        self.status = StatusPublisher(self, self.events, status_clock)
        #: what the last recording stopped with :meth:`stop_recording` wrote
        self.last_recording: RecordingResult | None = None
        # the reactions between parts (those on events that widgets also follow are called
        # here directly, so that a widget's subscriptions are the only ones on them)
        self.calibrations.events.magnetometer.connect(self._calibration_changed)
        self.calibrations.events.body.connect(self._body_calibration_changed)
        self.calibrations.load_stored(feed.sensor_ids)

    def _recording_changed(self) -> None:
        """A recording is computed with the calibrations it started with: none changes meanwhile."""
        self.calibrations.lock_while_recording(self.recorder.active)
        self.status.mark_due()

    def _assign(self, sensor_id: str, segment: str | None) -> None:
        before = dict(self.sensors.sensor_segments)
        self.sensors.assign(sensor_id, segment)
        if self.sensors.sensor_segments != before:
            self.status.mark_due()

    def _calibration_changed(self, *_sensor_ids) -> None:
        self.status.mark_due()
        self.events.calibration.emit()

    def _body_calibration_changed(self, calibration: bodycal.BodyCalibration | None) -> None:
        """The figure is driven anew (through ``calibration``'s sensors, when one is applied):
        the poses made and where the figure stands are forgotten."""
        if calibration is not None:
            for segment, sensor in calibration.sensors.items():
                self._assign(sensor, segment)
        self.processing.forget_poses()
        self.pose.reset()
        self._calibration_changed()

    # -- driving -----------------------------------------------------------------------------
    def start(self) -> None:
        """Start the source; ``t_s = 0`` is now."""
        self.sensors.start()

    def stop(self) -> RecordingResult | None:
        """Stop recording (the file is written) and the source."""
        result = self.stop_recording() if self.recording else None
        self.sensors.stop()
        return result

    def step(self) -> int:
        """Run everything that arrived since the last call through the parts; returns the number
        of samples taken in."""
        if not self.sensors.started:
            return 0
        blocks = self.sensors.poll()
        merged = join_per_sensor(blocks)  # once: the recorder and the pipeline take the same records
        self.recorder.take(merged)
        self._take_truth()
        changed = self.sensors.follow_devices()
        if changed:
            self.calibrations.follow_devices(changed)
        if not blocks:
            self.status.tick()
            return 0
        new_sensors = self.sensors.new_sensors(merged)
        if new_sensors:
            self.calibrations.load_stored(new_sensors)
            self.status.mark_due()
        processed = self.processing.process(merged, self.sensors.t0_host_s)
        self.history.take(processed)
        count_before = self.sensors.samples_received
        self.sensors.note_samples(merged)
        posed = self._take_pose()
        self.history.publish()
        self.status.tick()
        if posed:  # last: a view may draw everything this step changed in one picture at once
            self._emit_frame()
        return self.sensors.samples_received - count_before

    def _take_pose(self) -> bool:
        """Take the pipeline's newest pose into the pose part; returns whether there is a new one."""
        pose = self.processing.pose(self.calibrations.body, self.sensors.sensor_segments, self.sensors.seen(),
                                    had_pose=self.pose.q_world_from_segment is not None)
        if pose is None:
            return False
        body = self.calibrations.body
        # without a body calibration each sensor's axes stand in for its segment's: the outline
        uncalibrated = None if body is not None else assignment_of(None, self.sensors.sensor_segments)
        try:
            self.pose.take(*pose, segment_of_sensor=uncalibrated)
        except ValueError as error:
            raise ValueError(f"{self.pose_source}: {error}") from None
        return True

    def _take_truth(self) -> None:
        """The simulator's newest truth block to the evaluation and, while recording, to the
        journal; neither ever drives the figure."""
        truth = self.sensors.feed.last_truth
        if truth is None:
            return
        host_t_s = self.sensors.feed.host_time_of(truth.t_s)
        self.evaluation.take(truth, host_t_s - self.sensors.t0_host_s)
        self.recorder.take_truth(truth, host_t_s, TRUTH_NOTE)

    def _emit_frame(self) -> None:
        """Emit ``truth_frame`` and then ``frame`` with the newest pose's figure, built only when
        someone listens (a new ``frame_id`` for a new pose, display mode or height)."""
        if self.pose.q_world_from_segment is None:
            return
        self.evaluation.forget_figure()
        emit_pose_figures(self)

    def publish_status(self) -> None:
        """Emit the status events now, each of them (``status``, ``checklist`` or
        ``recording_progress``, ``source_problem``, ``refused``, ``truth_errors``) and
        ``pose_source``: for widgets that have just subscribed; :meth:`step` publishes the
        status at its own rate."""
        self.status.forget()
        self.processing.publish_pose_source()
        self.status.publish()

    # -- the source and its sensors (:attr:`sensors`) --------------------------------------------
    @property
    def feed(self):
        return self.sensors.feed

    @property
    def label(self) -> str:
        return self.sensors.label

    @property
    def simulator(self):
        """The in-process simulator, or ``None`` (evaluation only)."""
        return self.sensors.simulator

    @property
    def started(self) -> bool:
        return self.sensors.started

    @property
    def t0_host_s(self) -> float | None:
        return self.sensors.t0_host_s

    @property
    def samples_received(self) -> int:
        return self.sensors.samples_received

    @property
    def last_arrival_s(self) -> float:
        return self.sensors.last_arrival_s

    @property
    def source_problem(self) -> str:
        return self.sensors.problem

    @property
    def pairing_store(self) -> PairingStore | None:
        return self.sensors.pairing_store

    @property
    def sensor_ids(self) -> tuple[str, ...]:
        return self.sensors.sensor_ids

    @property
    def sensor_segments(self) -> dict[str, str]:
        return self.sensors.sensor_segments

    @property
    def devices(self) -> dict[str, SensorDevice]:
        return self.sensors.devices

    def device_of(self, sensor_id: str) -> SensorDevice:
        return self.sensors.device_of(sensor_id)

    def instruct(self, instruction: Instruction) -> None:
        self.sensors.instruct(instruction)

    def assign_sensor(self, sensor_id: str, segment: str | None) -> None:
        self._assign(sensor_id, segment)

    # -- processing (:attr:`processing`) ---------------------------------------------------------
    @property
    def pipeline(self):
        return self.processing.pipeline

    @property
    def pose_source(self) -> str:
        return self.processing.pose_source

    def poses_after(self, t_after_s: float) -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
        """Every pose of this session's body calibration and assignment at an instant later than
        ``t_after_s`` (session s): ``(t_s (P,), segment → q_world_from_segment (P, 4))``, or
        None (:meth:`~mimucap.core.pipeline.live.LivePipeline.poses_after`)."""
        return self.pipeline.poses_after(t_after_s, self.body_calibration, self.sensor_segments)

    def latest_orientations(self) -> dict[str, np.ndarray]:
        return self.processing.latest_orientations()

    def onboard_sensors(self) -> tuple[str, ...]:
        return self.processing.onboard_sensors()

    def orientation_only_sensors(self) -> tuple[str, ...]:
        return self.processing.orientation_only_sensors()

    # -- calibrations (:attr:`calibrations`) -----------------------------------------------------
    @property
    def calibration_store(self) -> CalibrationStore | None:
        return self.calibrations.store

    @property
    def mag_calibrations(self) -> dict[str, MagCalibration]:
        return self.calibrations.magnetometer

    @property
    def calibration_problems(self) -> dict[str, str]:
        return self.calibrations.problems

    @property
    def body_calibration(self) -> bodycal.BodyCalibration | None:
        return self.calibrations.body

    def apply_mag_calibration(self, calibration: MagCalibration, save: bool = True) -> None:
        self.calibrations.apply_magnetometer(calibration, save)

    def apply_body_calibration(self, calibration: bodycal.BodyCalibration) -> None:
        self.calibrations.apply_body(calibration)

    def clear_body_calibration(self) -> None:
        self.calibrations.clear_body()

    # -- the pose and the plots (:attr:`pose`, :attr:`history`) ----------------------------------
    @property
    def time_s(self) -> float:
        return self.pose.time_s

    @property
    def cursor_s(self) -> float:
        return self.history.cursor_s

    @property
    def q_world_from_segment(self) -> dict[str, np.ndarray] | None:
        return self.pose.q_world_from_segment

    @property
    def height_m(self) -> float:
        return self.pose.height_m

    @property
    def builder(self) -> FigureBuilder:
        return self.pose.builder

    @property
    def display_mode(self) -> str:
        return self.pose.display_mode

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.pose.joint_names

    def joint_columns(self, joint: str) -> tuple[str, str, str]:
        return self.pose.joint_columns(joint)

    def set_display_mode(self, mode: str) -> None:
        """``"world"`` or ``"body"`` (see :mod:`mimucap.session.views.skeleton_figure`)."""
        self.pose.set_display_mode(mode)
        self._emit_frame()

    def set_height(self, height_m: float) -> None:
        """The subject's height (m): rescales the figure."""
        self.pose.set_height(height_m)
        self._emit_frame()

    def frame(self) -> tuple[object, FigureGeometry] | None:
        """``(frame_id, geometry)`` of the newest pose, or None before the first one
        (``frame_id`` changes with every new pose, display mode and height)."""
        return self.pose.frame(self.calibrations.heading_ref_rad)

    def series(self, sensor_id: str, window_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return self.history.series(sensor_id, window_s)

    def joint_series(self, joint: str, window_s: float) -> tuple[np.ndarray, np.ndarray]:
        return self.history.joint_series(joint, window_s)

    # -- evaluation against the simulator's truth (:attr:`evaluation`) ---------------------------
    @property
    def has_truth(self) -> bool:
        return self.evaluation.has_truth

    def truth_pose(self) -> dict[str, np.ndarray] | None:
        return self.evaluation.truth_pose()

    def truth_frame(self) -> tuple[object, FigureGeometry] | None:
        return self.evaluation.truth_frame()

    def truth_joint_series(self, joint: str, window_s: float) -> tuple[np.ndarray, np.ndarray]:
        return self.history.truth_joint_series(joint, window_s)

    def truth_errors(self, window_s: float = TRUTH_ERROR_WINDOW_S, columns=None) -> dict[str, float]:
        return self.evaluation.truth_errors(window_s, columns)

    # -- status ------------------------------------------------------------------------------
    def sensor_rows(self) -> list[SensorRow]:
        """One :class:`~mimucap.session.live.sensor_rows.SensorRow` per known sensor, in the source's order."""
        return sensor_rows(self.sensors, self.processing, self.calibrations, self.history, self._clock())

    def segment_states(self) -> dict[str, str]:
        """Segment → tint state of its sensor (``ok``, ``mag_uncalibrated``, ``stale``)."""
        return {row.segment: row.state for row in self.sensor_rows() if row.segment is not None}

    # -- recording (:attr:`recorder`) ------------------------------------------------------------
    @property
    def recording(self) -> bool:
        return self.recorder.active

    @property
    def recording_started_s(self) -> float | None:
        """Session time (s) at which the current recording started, ``None`` when not
        recording: an instant's time in the recording (what review and export show) is its
        session time minus this."""
        return self.recorder.started_s

    @property
    def recording_failure(self) -> str | None:
        return self.recorder.failure

    def recording_info(self) -> RecordingInfo | None:
        return self.recorder.info()

    def start_recording(self, path: str | Path, subject: Mapping[str, Any] | None = None,
                        extra_metadata: Mapping[str, Any] | None = None) -> None:
        """Record everything from now on into session file ``path`` (journal beside it), with
        what is needed to compute the same numbers again (the calibrations, the filters' states,
        the settings: :func:`~mimucap.session.recorded.stored_processing.recording_record`);
        ``extra_metadata``: further top-level metadata keys (e.g. the library's ``"library"``)."""
        if self.recorder.active:
            raise ValueError(f"already recording to {self.recorder.info().path}")
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
                               settings=self.processing.settings, filter_states=self.processing.filter_states(),
                               time_offset_s=start_host_s - self.t0_host_s,
                               coupling_state=self.processing.coupling_state(start_host_s - self.t0_host_s)),
        }
        lsl_clock = recording_lsl_clock(start_host_s, self._clock)
        if lsl_clock is not None:  # lines the recording up with a LabRecorder XDF of the same minutes
            metadata["lsl_clock"] = lsl_clock
        metadata.update(extra_metadata or {})
        self.recorder.start(path, metadata, start_host_s, start_host_s - self.t0_host_s)
        self._recording_changed()

    def add_marker(self, label: str, host_s: float | None = None) -> float:
        """Mark now, or the instant ``host_s`` (s on the session's clock: a marker that came with
        its own time, e.g. from a Lab Streaming Layer stream), with ``label`` (in the recording
        when recording); returns its ``t_s``."""
        now = self._clock() if host_s is None else float(host_s)
        t_s = now - (self.t0_host_s or now)
        self.recorder.add_marker(str(label).strip() or "marker", now, t_s)
        return t_s

    def end_recording(self) -> RecordingToSave:
        """Stop recording now (fast: the journal gets its last records and is closed); the
        returned :class:`RecordingToSave` writes the session file when asked (in any thread:
        a long recording takes seconds to convert). Until then the journal holds everything."""
        status = {sid: {"received": s.received, "drops": s.drops, "rate_hz": s.rate_hz}
                  for sid, s in self.sensors.stats().items()}
        pending = self.recorder.end(status, devices_to_json(self.feed.devices()))
        self._recording_changed()
        return pending

    def stop_recording(self) -> RecordingResult:
        """Stop and write the session file now; returns what was written."""
        result = self.end_recording().save()
        self.last_recording = result
        return result


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
    session.sensors.pairing_store = pairings
    return session
