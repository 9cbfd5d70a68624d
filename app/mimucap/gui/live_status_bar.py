"""The main window's status bar while a live session runs: source, pose, accuracy, rates, doubt,
refused packets, the recording indicator, CPU and frame rate.

:class:`LiveStatusBar` is a panel in the sense of the main window: it takes the live session it
shows (:meth:`LiveStatusBar.set_session`) and subscribes to the events it shows, and to nothing
else: ``status`` (the sensor rows, 4 Hz: rates, drops, doubtful orientations; the process's CPU
and the 3D view's frame rate are sampled with it), ``pose_source`` and ``truth_errors`` (what
drives the figure and its running error against the simulator's truth), ``source_problem``,
``refused`` (packets of no known sensor), ``recording`` and ``recording_progress`` (the red
indicator and its clock, the file's name beside it), ``calibration`` (for the hint). What the 3D view says while it has no
figure, or while it shows the outline before a body calibration, follows from the pose source, the source's problem and the calibrations made: it is told
by :attr:`LiveStatusBar.hint_changed`. The accuracy against the truth is shown only with a body
calibration: before it, the sensors' axes stand for the segments and an error of 100° says
nothing but "not calibrated".
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence

from PyQt5 import QtCore, QtWidgets

from mimucap.core.pipeline.recording import POSE_BODY_CALIBRATION, POSE_SENSOR_AXES
from mimucap.gui.elided_label import ElidedLabel
from mimucap.gui.sensor_panel import rejections_tooltip
from mimucap.session.angle_accuracy import accuracy_phrase
from mimucap.session.live.processing import POSE_NONE, POSE_UNASSIGNED
from mimucap.session.live.sensor_rows import doubt_warning
from mimucap.session.views.cpu_meter import CpuMeter

log = logging.getLogger(__name__)

#: The recording indicator: white on red, always in the status bar while recording.
RECORDING_STYLE = "QLabel { background: #d62728; color: white; font-weight: bold; padding: 1px 8px; border-radius: 3px; }"
#: What the 3D view says while it has no figure to show, by pose source.
VIEW_HINTS = {
    POSE_NONE: "Waiting for data from the source…",
    POSE_UNASSIGNED: "No sensor is assigned to a body segment yet.\nSession → Assign Sensors…",
    POSE_SENSOR_AXES: "Not calibrated yet: each sensor is shown where it is worn, turning as it turns.\n"
                      "Next: calibrate the magnetometers (Calibrate → Magnetometers…), then the body.",
}
#: The 3D view's hint once the magnetometers are calibrated: the body is next.
BODY_NEXT_HINT = ("Magnetometers calibrated.\nNext: calibrate the body (Calibrate → Body…): the subject stands "
                  "in the N-pose, then raises both arms sideways.")


def elapsed_text(elapsed_s: float) -> str:
    """``"● REC mm:ss"`` (``h:mm:ss`` from an hour on) for a recording ``elapsed_s`` seconds long."""
    minutes, seconds = divmod(int(elapsed_s), 60)
    hours, minutes = divmod(minutes, 60)
    clock = f"{hours}:{minutes:02d}:{seconds:02d}" if hours else f"{minutes:02d}:{seconds:02d}"
    return f"● REC {clock}"


class LiveStatusBar(QtCore.QObject):
    """The permanent widgets of ``status_bar`` for a live session; ``frame_times()``: the 3D
    view's recent render times (s, monotonic), for its frame rate."""

    #: what the 3D view says while it has no figure ("" : nothing)
    hint_changed = QtCore.pyqtSignal(str)

    def __init__(self, status_bar: QtWidgets.QStatusBar, frame_times: Callable[[], Sequence[float]]) -> None:
        super().__init__(status_bar)
        self._frame_times = frame_times
        self._cpu = CpuMeter()
        self._session = None
        self._source_problem = ""  # the last problem the source reported
        self._pose_source = ""     # what drives the figure
        self._accuracy = ""        # the running error against the simulator's truth, as a phrase
        self._subscriptions = {
            "status": self._status_changed, "pose_source": self._pose_source_changed,
            "source_problem": self._source_problem_changed, "refused": self._refused_changed,
            "truth_errors": self._truth_errors_changed, "recording": self._recording_changed,
            "recording_progress": self._recording_progress,
            "calibration": self._tell_hint}
        self.recording_indicator = QtWidgets.QLabel("", status_bar)
        self.recording_indicator.setObjectName("recordingIndicator")
        self.recording_indicator.setStyleSheet(RECORDING_STYLE)
        self.recording_indicator.setVisible(False)
        status_bar.addPermanentWidget(self.recording_indicator)
        # the file being written, beside the badge and never under it (the whole path on hover;
        # the session panel shows it too)
        self.recording_target = QtWidgets.QLabel("", status_bar)
        self.recording_target.setObjectName("recordingTarget")
        self.recording_target.setVisible(False)
        status_bar.addPermanentWidget(self.recording_target)
        self.source_status = ElidedLabel("", status_bar)
        self.pose_status = ElidedLabel("", status_bar)
        self.refused_status = QtWidgets.QLabel(status_bar)
        self.refused_status.setObjectName("refusedStatus")
        self.refused_status.setStyleSheet("QLabel { color: #c05800; }")
        self.refused_status.setVisible(False)
        status_bar.addPermanentWidget(self.refused_status)
        # while a sensor's orientation is doubtful: which, and why (the whole text as tooltip)
        self.doubt_status = ElidedLabel("", status_bar)
        self.doubt_status.setObjectName("doubtStatus")
        self.doubt_status.setStyleSheet("QLabel { color: #c05800; }")
        self.doubt_status.setVisible(False)
        status_bar.addPermanentWidget(self.doubt_status, 1)
        self.rate_status = QtWidgets.QLabel(status_bar)
        # Wide enough for the usual figures, so that a rate going from 99 to 101 Hz does not
        # need room the status bar has already given away.
        self.rate_status.setMinimumWidth(self.rate_status.fontMetrics().horizontalAdvance("17 sensors, 888 Hz, 888 drops"))
        self.cpu_status = QtWidgets.QLabel(status_bar)
        self.fps_status = QtWidgets.QLabel(status_bar)
        for label in (self.source_status, self.pose_status, self.rate_status, self.cpu_status, self.fps_status):
            status_bar.addPermanentWidget(label)

    def set_session(self, session) -> None:
        """Show ``session`` (a :class:`~mimucap.session.live.live_session.LiveSession`; ``None``:
        none), letting the previous one go."""
        if self._session is not None:
            for name, callback in self._subscriptions.items():
                getattr(self._session.events, name).disconnect(callback)
        self._session = session
        self._accuracy = ""
        if session is None:
            return
        self.source_status.setText(f"Source: {session.label}")
        for name, callback in self._subscriptions.items():
            getattr(session.events, name).connect(callback)

    # -- the session's events ------------------------------------------------------------------
    def _status_changed(self, rows) -> None:
        rates = [r.rate_hz for r in rows if r.rate_hz == r.rate_hz]
        drops = sum(r.drops for r in rows)
        warning = doubt_warning(rows)
        if warning != self.doubt_status.text():
            self.doubt_status.setText(warning)
            self.doubt_status.setVisible(bool(warning))
        self.rate_status.setText(f"{len(rates)} sensors, {sum(rates) / len(rates):.0f} Hz, {drops} drops" if rates else "no data")
        self.cpu_status.setText(f"CPU {self._cpu.sample():.0f} %")
        times = list(self._frame_times())[-61:]
        if len(times) >= 2 and times[-1] > times[0]:
            self.fps_status.setText(f"{(len(times) - 1) / (times[-1] - times[0]):.0f} fps")
        else:
            self.fps_status.setText("– fps")

    def _pose_source_changed(self, pose_source: str) -> None:
        self._pose_source = pose_source
        if pose_source != POSE_BODY_CALIBRATION:
            self._accuracy = ""
        self._show_pose_status()
        self._tell_hint()

    def _truth_errors_changed(self, errors) -> None:
        self._accuracy = accuracy_phrase(errors) if self._pose_source == POSE_BODY_CALIBRATION else ""
        self._show_pose_status()

    def _show_pose_status(self) -> None:
        self.pose_status.setText(f"Pose: {self._pose_source}{self._accuracy}")

    def _source_problem_changed(self, problem: str) -> None:
        self._source_problem = problem
        if problem and self._session is not None:
            log.warning("source %s: %s", self._session.label, problem)
        self._tell_hint()

    def _tell_hint(self, *_why) -> None:
        if self._source_problem and self._pose_source == POSE_NONE:
            self.hint_changed.emit(f"No data from the source.\n{self._source_problem}\n\n"
                                   "Check the device and its connection, or choose another source "
                                   "(File → Choose Source…).")
        elif self._pose_source == POSE_SENSOR_AXES and self._magnetometers_done():
            self.hint_changed.emit(BODY_NEXT_HINT)
        else:
            self.hint_changed.emit(VIEW_HINTS.get(self._pose_source, ""))

    def _magnetometers_done(self) -> bool:
        """Every sensor that needs a magnetometer calibration has one (sensors fusing on board,
        or sending their own orientation, need none)."""
        live = self._session
        if live is None:
            return False
        needing = set(live.sensor_ids) - set(live.onboard_sensors()) - set(live.orientation_only_sensors())
        return bool(needing) and needing <= set(live.mag_calibrations)

    def _refused_changed(self, counts: dict[str, int], senders: dict[str, int]) -> None:
        """Packets refused that belong to no sensor of the table (an unknown sender, a line too
        damaged to name its sensor): counted here, the reasons and senders on hover."""
        total = sum(counts.values())
        self.refused_status.setVisible(total > 0)
        if total:
            self.refused_status.setText(f"{total} packets refused from no known sensor")
            tooltip = rejections_tooltip(counts)
            if senders:
                tooltip += "\nFrom: " + ", ".join(f"{sender} ({count})" for sender, count in senders.items())
            self.refused_status.setToolTip(tooltip)

    def _recording_changed(self, info) -> None:
        self.recording_indicator.setVisible(info is not None)
        self.recording_target.setVisible(info is not None)
        if info is not None:
            self.recording_indicator.setText(elapsed_text(0.0))
            self.recording_target.setText(f"→ {info.path.name}")
            self.recording_target.setToolTip(f"Recording to {info.path}")

    def _recording_progress(self, info) -> None:
        self.recording_indicator.setText(elapsed_text(info.elapsed_s))
