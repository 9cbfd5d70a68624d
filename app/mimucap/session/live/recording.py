"""The live session's recording part: what is being recorded where, the markers, and the stop
that leaves a session file to write (no Qt).

:class:`LiveRecording` runs one :class:`~mimucap.session.live.recorder.Recorder` at a time (the
crash-safe journal beside the session file): every block the session takes in while recording,
the simulator's truth beside them when the source has one (evaluation only), and the markers.
What a recording stores besides the samples (calibrations, filter states, subject...) is
gathered by the live session when it starts one.

Events (``events``, :class:`~mimucap.session.events.EmitterGroup`):

* ``recording(info_or_None)``: recording started (:class:`RecordingInfo`) or stopped;
* ``progress(RecordingInfo)``: while recording, at the status rate (elapsed s, bytes, markers);
* ``marker(t_s, label, recorded)``: a marker the user placed, at session time ``t_s``
  (``recorded``: it is in the recording, as markers are while recording);
* ``failed(text)``: the recording could not be written (a full disk...): why; once per
  recording, which the caller should then end.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mimucap.core.sensor_samples import SensorSamples
from mimucap.core.simulate.truth import SuitTruth
from mimucap.session.events import EmitterGroup
from mimucap.session.live.recorder import Recorder, RecordingResult


@dataclass(frozen=True)
class RecordingInfo:
    """What is being recorded where: ``path``, ``elapsed_s`` (s), ``size_bytes`` (journal so far),
    ``markers`` placed, ``samples`` per sensor."""

    path: Path
    elapsed_s: float
    size_bytes: int
    markers: int
    samples: dict[str, int] = field(default_factory=dict)


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


class LiveRecording:
    """The recording of a live session whose host clock is ``clock`` (monotonic, s)."""

    def __init__(self, clock: Callable[[], float]) -> None:
        self._clock = clock
        self.events = EmitterGroup("recording", "progress", "marker", "failed")
        self._recorder: Recorder | None = None
        self._markers = 0
        self._failure_told = False
        self._journaled_truth: SuitTruth | None = None   # the simulator truth block last journaled
        #: session time (s) at which the current recording started (``None``: not recording)
        self.started_s: float | None = None

    @property
    def active(self) -> bool:
        """Whether a recording runs."""
        return self._recorder is not None

    @property
    def failure(self) -> str | None:
        """Why the current recording could not be written (``None``: it is being written)."""
        return None if self._recorder is None else self._recorder.failure

    def start(self, path: str | Path, metadata: Mapping[str, Any], start_host_s: float, started_s: float) -> None:
        """Record everything from host time ``start_host_s`` (session time ``started_s``) into
        session file ``path`` (journal beside it), with ``metadata``."""
        if self._recorder is not None:
            raise ValueError(f"already recording to {self._recorder.out_path}")
        recorder = Recorder(path, dict(metadata))
        recorder.start(start_host_s)
        self._recorder = recorder
        self._failure_told = False
        self._markers = 0
        self._journaled_truth = None
        self.started_s = started_s
        self.events.recording.emit(self.info())

    def take(self, blocks: list[SensorSamples]) -> None:
        """Journal ``blocks`` (nothing arrived: keep the journal's flush clock going); a write
        failure is told once (``failed``)."""
        recorder = self._recorder
        if recorder is None:
            return
        if blocks:
            recorder.add_blocks(blocks)
        else:
            recorder.tick()
        if recorder.failure and not self._failure_told:
            self._failure_told = True
            self.events.failed.emit(recorder.failure)

    def take_truth(self, truth: SuitTruth, host_t_s: np.ndarray, note: str) -> None:
        """Journal the simulator's newest truth block (evaluation only) at host times
        ``host_t_s``, once, while recording (the block current when the recording started too);
        ``note`` says where the truth came from."""
        if self._recorder is None or truth is self._journaled_truth:
            return
        self._recorder.add_truth(host_t_s, truth.q_world_from_segment, truth.joint_angles_deg,
                                 truth.root_position_m, note)
        self._journaled_truth = truth

    def add_marker(self, label: str, host_s: float, t_s: float) -> None:
        """Place marker ``label`` at host time ``host_s`` (session time ``t_s``): in the recording
        while recording (``OSError`` when it cannot be written), told by ``marker`` either way."""
        recorder = self._recorder
        if recorder is not None:
            if not recorder.add_marker(label, host_s):
                raise OSError(recorder.failure or f"could not write the marker to {recorder.out_path}")
            self._markers += 1
        self.events.marker.emit(t_s, label, recorder is not None)

    def info(self) -> RecordingInfo | None:
        """What is being recorded where, or ``None`` when not recording."""
        recorder = self._recorder
        if recorder is None:
            return None
        try:
            size = recorder.journal_path.stat().st_size
        except OSError:
            size = 0
        return RecordingInfo(path=recorder.out_path, elapsed_s=self._clock() - recorder.start_host_s,
                             size_bytes=size, markers=self._markers, samples=dict(recorder.samples))

    def publish_progress(self) -> None:
        """Emit ``progress`` while recording (the status rate calls it)."""
        info = self.info()
        if info is not None:
            self.events.progress.emit(info)

    def end(self, status: Mapping[str, Any], devices: Any) -> RecordingToSave:
        """Stop now (fast: the journal gets its last records, ``status`` and ``devices``, and is
        closed); the returned :class:`RecordingToSave` writes the session file when asked."""
        if self._recorder is None:
            raise ValueError("not recording")
        recorder, self._recorder = self._recorder, None
        self.started_s = None
        recorder.close(status, devices=devices)
        self.events.recording.emit(None)
        return RecordingToSave(recorder=recorder)
