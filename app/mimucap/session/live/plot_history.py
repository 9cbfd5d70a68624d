"""The live session's plot history: the last seconds of every sensor's samples and of every
joint's angles, as the plots read them (no Qt).

:class:`PlotHistory` keeps, in preallocated ring buffers (:mod:`mimucap.session.live.ring_buffer`),
the last :data:`MAX_WINDOW_S` seconds of each sensor's accelerometer (m/s²), gyroscope (rad/s)
and magnetic field (µT, calibrated when a calibration is applied); the joint angles (deg) are the
pose part's history (:class:`~mimucap.session.views.live_pose.LivePose`, computed in one
vectorised batch when read). Beside them it keeps the simulator's true joint angles when the
source knows them (the dashed curves of the on-screen accuracy check; evaluation only: they are
never the estimate). Times are session seconds.

It is the *plot source* of :mod:`mimucap.gui.live_plots`: ``sensor_ids``, ``sensor_segments``,
``joint_names``, ``joint_columns(joint)``, ``series(sensor_id, window_s)``,
``joint_series(joint, window_s)``, ``truth_joint_series(joint, window_s)`` and ``cursor_s``.

Events (``events``, :class:`~mimucap.session.events.EmitterGroup`):

* ``data(cursor_s)``: new samples (and angles) up to :attr:`PlotHistory.cursor_s`, once per
  step that brought samples (which sensors there are and where they are worn is told by the
  sensors part: ``sensors``, ``assignment``).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mimucap.core.magcal.standing import LocalField, local_field
from mimucap.session.events import EmitterGroup
from mimucap.session.live.processing import POSE_NONE, POSE_UNASSIGNED, LiveProcessing, ProcessedBlock
from mimucap.session.live.ring_buffer import RingBuffer
from mimucap.session.live.sensors import LiveSensors
from mimucap.session.views.live_pose import LivePose

#: Longest scrolling window the live plots can show (s).
MAX_WINDOW_S = 30.0
#: Samples per second the ring buffers are sized for (larger rates keep a shorter history).
BUFFER_RATE_HZ = 200.0
#: Joint-angle history rate bound: one pose per pipeline step (the GUI pumps at 62.5 Hz; other
#: drivers, e.g. a test's stepped clock, may step faster).
ANGLE_BUFFER_RATE_HZ = 120.0


class PlotHistory:
    """The plot history of a live session, with its ``sensors`` (ids and segments),
    ``processing`` (what drives the figure) and ``pose`` (the joint angles) parts (see the module
    doc)."""

    def __init__(self, sensors: LiveSensors, processing: LiveProcessing, pose: LivePose) -> None:
        self._sensors = sensors
        self._processing = processing
        self._pose = pose
        self.events = EmitterGroup("data")
        self._capacity = int(MAX_WINDOW_S * BUFFER_RATE_HZ)
        #: sensor → rows acc (m/s²), gyr (rad/s), mag (µT, calibrated when applied); NaN when absent
        self._raw: dict[str, RingBuffer] = {}
        #: the simulator's true joint angles (deg) of the last seconds (evaluation only)
        self._truth = {joint: RingBuffer(self._capacity, (3,)) for joint in pose.joint_names}

    # -- taking data ---------------------------------------------------------------------------
    def take(self, processed: list[ProcessedBlock]) -> None:
        """Keep each sensor's new samples (the field as the filter took it)."""
        for item in processed:
            n = len(item.t_s)
            buffer = self._raw.get(item.sensor_id)
            if buffer is None:
                buffer = self._raw[item.sensor_id] = RingBuffer(self._capacity, (3, 3))
            raw = np.full((n, 3, 3), np.nan)
            for row, values in enumerate((item.block.acc, item.block.gyr, item.mag_uT)):
                if values is not None:
                    raw[:, row] = values
            buffer.append(item.t_s, raw)

    def take_truth(self, t_s: np.ndarray, joint_angles_deg: Mapping[str, np.ndarray]) -> None:
        """The simulator's true joint angles (column → (N,) deg) at session times ``t_s`` (N,)."""
        for joint, truth in self._truth.items():
            columns = self._pose.joint_columns(joint)
            if all(c in joint_angles_deg for c in columns):
                truth.append(t_s, np.stack([joint_angles_deg[c] for c in columns], axis=-1))

    def publish(self) -> None:
        """Emit ``data`` (new data up to :attr:`cursor_s`)."""
        self.events.data.emit(self.cursor_s)

    # -- what the plots read ----------------------------------------------------------------------
    @property
    def sensor_ids(self) -> tuple[str, ...]:
        return self._sensors.sensor_ids

    @property
    def sensor_segments(self) -> dict[str, str]:
        return self._sensors.sensor_segments

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._pose.joint_names

    def joint_columns(self, joint: str) -> tuple[str, str, str]:
        """The three angle column names of ``joint`` (meaning and ``_deg`` unit in the name)."""
        return self._pose.joint_columns(joint)

    @property
    def cursor_s(self) -> float:
        """The time the plots are aligned to (s): the newest pose (what the 3D view shows); while
        no pose is made (no sensor assigned yet), the newest sample's time, so the plots still
        scroll with the raw data. NaN before any data."""
        if self._processing.pose_source in (POSE_NONE, POSE_UNASSIGNED):
            times = [buffer.latest_t() for buffer in self._raw.values() if len(buffer)]
            return max(times) if times else float("nan")
        return self._pose.time_s

    def series(self, sensor_id: str, window_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Last ``window_s`` seconds of one sensor: ``t_s`` (N,), ``acc`` (N,3) m/s², ``gyr``
        (N,3) rad/s, ``mag_uT`` (N,3) (calibrated when a calibration is applied)."""
        buffer = self._raw.get(sensor_id)
        if buffer is None or not len(buffer):
            empty = np.zeros((0, 3))
            return np.zeros(0), empty, empty, empty
        t, raw = buffer.since(buffer.latest_t() - window_s)
        return t, raw[:, 0], raw[:, 1], raw[:, 2]

    def joint_series(self, joint: str, window_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Last ``window_s`` seconds of ``joint``'s angles: ``t_s`` (N,), ``angles_deg`` (N,3)
        in the order of :meth:`joint_columns`."""
        return self._pose.joint_series(joint, window_s)

    def truth_joint_series(self, joint: str, window_s: float) -> tuple[np.ndarray, np.ndarray]:
        """The simulator's true angles of ``joint`` over the last ``window_s`` seconds (as
        :meth:`joint_series`; empty for a source without truth). For evaluation only."""
        buffer = self._truth[joint]
        if not len(buffer):
            return np.zeros(0), np.zeros((0, 3))
        return buffer.since(buffer.latest()[0] - window_s)

    def local_field(self, sensor_id: str, window_s: float) -> LocalField | None:
        """The field ``sensor_id`` measured over its last ``window_s`` seconds, corrected by its
        calibration (``None`` before any sample; :func:`~mimucap.core.magcal.standing.local_field`)."""
        buffer = self._raw.get(sensor_id)
        if buffer is None or not len(buffer):
            return None
        _t, rows = buffer.since(buffer.latest_t() - window_s)
        return local_field(rows[:, 0], rows[:, 1], rows[:, 2])
