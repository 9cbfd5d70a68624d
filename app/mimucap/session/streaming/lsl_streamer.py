"""A live session's Lab Streaming Layer streams: outlets of what the pipeline computes, and
markers both ways (no Qt).

:class:`LslStreamer` subscribes to a :class:`~mimucap.session.live.live_session.LiveSession`'s events and
publishes, through liblsl (``pylsl``, an optional extra: ``pip install 'mimucap[lsl]'``):

* **segment orientations** (:func:`segment_layout`): stream type ``MoCap``, following the XDF
  meta-data conventions for motion capture: per segment four channels of type
  ``OrientationA``..``OrientationD``, the Hamilton quaternion ``q_world_from_segment``
  ``[w, x, y, z]`` (world ENU: x east, y north, z up; unit ``normalized``), each channel naming
  its ``<object>`` (the segment), one ``<object>`` per segment under ``<setup><objects>``;
* **joint angles** (:func:`joint_layout`): the machine column names (``knee_r_flexion_deg``) as
  labels, the clinical name ("Right knee flexion"), the sign ("+ flexion / − extension"), the
  angle sequence and the unit ``deg`` in each channel's meta-data (BIDS-Motion type ``JNTANG``);
  a joint whose two segments do not both carry a sensor, and every joint before a body
  calibration, reads NaN;
* **each sensor's raw samples** (:func:`raw_layout`): accelerometer (``ACCEL``, ``m/s^2``),
  gyroscope (``GYRO``, ``rad/s``), magnetometer as it left the sensor, before its calibration
  (``MAGN``, ``µT``), the BIDS-Motion channel types, components ``x``/``y``/``z`` in the
  sensor's frame, and the sample's sequence number (``MISC``: a gap is a dropped sample);
  a channel the sensor does not send reads NaN;
* the session's **markers** (:func:`marker_layout`, type ``Markers``, one string channel).

Every sample carries the time it was *sampled* (the sensor's synchronised sample time, session
seconds, the same instants the window shows), mapped onto the LSL clock
(:func:`~mimucap.session.streaming.lsl_clock.lsl_offset_s`), never the time it was sent. The poses are those
of the one processing path (:meth:`~mimucap.core.pipeline.live.LivePipeline.poses_after`: every instant
of the reference sensor, where the window shows the newest one per frame) and the joint angles
the same function of them the plots use. A stream's nominal rate is measured from its first
:data:`RATE_SAMPLES` sample times (the outlet opens then, with them); its ``source_id`` is made
of the session's source and the stream's kind, so it is the same after a restart and
LabRecorder reconnects.

A marker stream of another program (a stimulus program, a force-plate trigger) becomes session
markers at its samples' LSL times (:meth:`LslStreamer.take_markers`, then
:meth:`LslStreamer.poll`: in the recording while recording); those are not sent out again.
The live session must run on the host's monotonic clock (its default).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from mimucap import __version__
from mimucap.core import skeleton
from mimucap.core.clinical_names import angle_label, angle_sign_text, segment_name
from mimucap.session.views.live_pose import joint_column_groups
from mimucap.session.streaming.lsl_clock import load_pylsl, lsl_offset_s

#: Every MimuCap stream's name starts so (LabRecorder lists them by name).
NAME_PREFIX = "MimuCap"
SEGMENTS_TYPE = "MoCap"
JOINTS_TYPE = "JointAngles"
RAW_TYPE = "IMU"
MARKERS_TYPE = "Markers"
#: Sample times a stream's nominal rate is measured from before its outlet opens.
RATE_SAMPLES = 20
#: Quaternion channel types of the XDF motion-capture meta-data, in MimuCap's order [w, x, y, z].
ORIENTATION_TYPES = ("OrientationA", "OrientationB", "OrientationC", "OrientationD")
#: Raw channels: (label suffix, BIDS-Motion type, component, unit).
RAW_CHANNELS = tuple((f"{kind}_{axis}", bids, axis, unit)
                     for kind, bids, unit in (("acc", "ACCEL", "m/s^2"), ("gyr", "GYRO", "rad/s"),
                                              ("mag", "MAGN", "µT"))
                     for axis in "xyz")
#: The angle sequence of every joint the live view and the stream use (docs/conventions.md).
JOINT_SEQUENCE = "intrinsic Z-X'-Y'' (ISB): flexion, adduction, rotation"
#: How long :meth:`LslStreamer.take_markers` looks for the stream by default (s).
RESOLVE_TIMEOUT_S = 3.0


@dataclass(frozen=True)
class Channel:
    """One channel's meta-data: ``label``, ``type``, ``unit`` and further ``fields`` (tag → text)."""

    label: str
    type: str
    unit: str
    fields: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class StreamLayout:
    """What one outlet carries: its ``name``, ``type``, ``source_id``, ``channels``, the LSL
    ``channel_format`` and the ``objects`` (label, readable name) of a motion-capture stream,
    plus ``reference`` fields (tag → text) that say where its data comes from."""

    name: str
    type: str
    source_id: str
    channels: tuple[Channel, ...]
    channel_format: str = "double64"
    objects: tuple[tuple[str, str], ...] = ()
    reference: tuple[tuple[str, str], ...] = ()


def source_id(source: str, kind: str) -> str:
    """The stable ``source_id`` of a stream of ``kind`` from the session's ``source``."""
    return f"{NAME_PREFIX}:{source}:{kind}"


def segment_layout(model: skeleton.SkeletonModel, source: str) -> StreamLayout:
    """The segment-orientation stream of ``model`` (see the module doc)."""
    channels = tuple(Channel(f"{segment}_q{part}", kind, "normalized",
                             (("object", segment), ("component", f"quat_{part}")))
                     for segment in model.segment_names for part, kind in zip("wxyz", ORIENTATION_TYPES))
    return StreamLayout(f"{NAME_PREFIX} segments", SEGMENTS_TYPE, source_id(source, "segments"), channels,
                        objects=tuple((segment, segment_name(segment)) for segment in model.segment_names),
                        reference=(("frame", "q_world_from_segment, Hamilton [w, x, y, z] "
                                    "(OrientationA = w); world ENU: x east, y north (magnetic), z up"),
                                   ("model", model.name)))


def joint_layout(model: skeleton.SkeletonModel, source: str) -> StreamLayout:
    """The joint-angle stream of ``model`` (the joints with three angles, in model order)."""
    channels = []
    for joint, columns in joint_column_groups(model).items():
        for column in columns:
            fields = (("name", angle_label(column).replace(" (°)", "")), ("sign", angle_sign_text(column)),
                      ("joint", joint), ("sequence", JOINT_SEQUENCE))
            channels.append(Channel(column, "JNTANG", "deg", fields))
    return StreamLayout(f"{NAME_PREFIX} joint angles", JOINTS_TYPE, source_id(source, "joint angles"),
                        tuple(channels), reference=(("model", model.name),
                                                    ("zero", "the calibrated N-pose")))


def raw_layout(sensor_id: str, segment: str | None, source: str, device_id: str | None = None) -> StreamLayout:
    """The raw-sample stream of sensor ``sensor_id`` (worn on ``segment``, if known; its
    device's hardware id ``device_id``, if known: an import finds its magnetometer
    calibration by it)."""
    tracked = segment or sensor_id
    channels = tuple(Channel(label, kind, unit, (("component", axis), ("tracked_point", tracked)))
                     for label, kind, axis, unit in RAW_CHANNELS)
    channels += (Channel("seq", "MISC", "n/a", (("description", "sequence number; a gap is a dropped sample"),)),)
    reference = (("sensor_id", sensor_id), ("segment", segment or ""), ("device_id", device_id or ""),
                 ("frame", "sensor axes; magnetometer before its calibration"))
    return StreamLayout(f"{NAME_PREFIX} raw {sensor_id}", RAW_TYPE, source_id(source, f"raw {sensor_id}"),
                        channels, reference=reference)


def marker_layout(source: str) -> StreamLayout:
    """The session's marker stream."""
    return StreamLayout(f"{NAME_PREFIX} markers", MARKERS_TYPE, source_id(source, "markers"),
                        (Channel("marker", "Marker", "n/a"),), channel_format="string")


def stream_info(pylsl, layout: StreamLayout, rate_hz: float, source: str):
    """A ``pylsl.StreamInfo`` of ``layout`` at nominal ``rate_hz`` (0: irregular), its meta-data
    written into ``desc``."""
    info = pylsl.StreamInfo(layout.name, layout.type, len(layout.channels), rate_hz, layout.channel_format,
                            layout.source_id)
    desc = info.desc()
    channels = desc.append_child("channels")
    for channel in layout.channels:
        node = channels.append_child("channel")
        node.append_child_value("label", channel.label)
        node.append_child_value("type", channel.type)
        node.append_child_value("unit", channel.unit)
        for tag, text in channel.fields:
            node.append_child_value(tag, text)
    if layout.objects:
        objects = desc.append_child("setup").append_child("objects")
        for label, name in layout.objects:
            node = objects.append_child("object")
            node.append_child_value("label", label)
            node.append_child_value("class", "Segment")
            node.append_child_value("name", name)
    acquisition = desc.append_child("acquisition")
    acquisition.append_child_value("manufacturer", NAME_PREFIX)
    acquisition.append_child_value("model", "magnetic-inertial measurement units")
    acquisition.append_child_value("software_version", __version__)
    acquisition.append_child_value("source", source)
    for tag, text in layout.reference:
        acquisition.append_child_value(tag, text)
    return info


def nominal_rate_hz(t_s: np.ndarray) -> float:
    """A stream's nominal rate (Hz) from its first sample times ``t_s`` (N,) s: one over their
    median interval, to 0.1 Hz."""
    steps = np.diff(np.asarray(t_s, dtype=np.float64))
    steps = steps[steps > 0]
    if not len(steps):
        raise ValueError("no increasing sample times to measure a rate from")
    return round(1.0 / float(np.median(steps)), 1)


class _Outlet:
    """An outlet that opens once :data:`RATE_SAMPLES` sample times give its nominal rate; the
    samples before are sent then, with their own times."""

    def __init__(self, pylsl, layout: StreamLayout, source: str) -> None:
        self.pylsl = pylsl
        self.layout = layout
        self.source = source
        self.outlet = None
        self.rate_hz = float("nan")
        self._waiting: list[tuple[np.ndarray, np.ndarray]] = []
        self.pushed = 0

    def push(self, lsl_s: np.ndarray, rows: np.ndarray) -> None:
        """Samples ``rows`` (N, channels) sampled at LSL times ``lsl_s`` (N,)."""
        if not len(lsl_s):
            return
        if self.outlet is None:
            self._waiting.append((lsl_s, rows))
            times = np.concatenate([t for t, _ in self._waiting])
            if len(times) < RATE_SAMPLES:
                return
            self.rate_hz = nominal_rate_hz(times)
            self.outlet = self.pylsl.StreamOutlet(stream_info(self.pylsl, self.layout, self.rate_hz, self.source))
            lsl_s, rows = times, np.concatenate([r for _, r in self._waiting])
            self._waiting = []
        self.outlet.push_chunk(np.ascontiguousarray(rows, dtype=np.float64), [float(t) for t in lsl_s])
        self.pushed += len(lsl_s)


class LslStreamer:
    """The LSL outlets (and a marker inlet) of a running live ``session`` (see the module doc).

    Args:
        session: the :class:`~mimucap.session.live.live_session.LiveSession` (started or not; on the host's
            monotonic clock).
        pylsl: the pylsl module (default: imported; :class:`~mimucap.session.streaming.lsl_clock.LslMissing`
            says how to install it).
        clock: the session's clock (s), to measure the LSL clock's offset from.
    """

    def __init__(self, session, pylsl=None, clock: Callable[[], float] = time.monotonic) -> None:
        self.pylsl = pylsl or load_pylsl()
        self.session = session
        self.source = session.label
        #: LSL clock − session clock (s)
        self.offset_s = lsl_offset_s(self.pylsl, clock)
        model = session.model
        self._columns = joint_column_groups(model)
        self.segments = _Outlet(self.pylsl, segment_layout(model, self.source), self.source)
        self.joints = _Outlet(self.pylsl, joint_layout(model, self.source), self.source)
        self.raw: dict[str, _Outlet] = {}
        self.markers = self.pylsl.StreamOutlet(stream_info(self.pylsl, marker_layout(self.source), 0.0, self.source))
        self._last_pose_t = -math.inf
        self._inlet = None
        #: the name of the marker stream taken in ("" : none)
        self.marker_stream = ""
        #: markers taken in from :attr:`marker_stream` so far
        self.markers_taken = 0
        self._taking = False
        self._callbacks = ((session.events.processed, self._on_processed), (session.events.data, self._on_data),
                           (session.events.marker, self._on_marker))
        for emitter, callback in self._callbacks:
            emitter.connect(callback)

    # -- clock -----------------------------------------------------------------------------------
    def lsl_time(self, t_s):
        """The LSL time (s) of session time ``t_s`` (s; scalar or array)."""
        return t_s + self.session.t0_host_s + self.offset_s

    def host_time(self, lsl_s: float) -> float:
        """The session clock's time (s) of LSL time ``lsl_s``."""
        return float(lsl_s) - self.offset_s

    # -- outlets ---------------------------------------------------------------------------------
    def _on_processed(self, items) -> None:
        for item in items:
            outlet = self.raw.get(item.sensor_id)
            if outlet is None:
                layout = raw_layout(item.sensor_id, self.session.sensor_segments.get(item.sensor_id), self.source,
                                    self.session.device_of(item.sensor_id).device_id)
                outlet = self.raw[item.sensor_id] = _Outlet(self.pylsl, layout, self.source)
            block = item.block
            rows = np.full((len(block), len(RAW_CHANNELS) + 1), np.nan)
            for column, values in enumerate((block.acc, block.gyr, block.mag_uT)):
                if values is not None:
                    rows[:, 3 * column:3 * column + 3] = values
            rows[:, -1] = block.seq
            outlet.push(self.lsl_time(np.asarray(item.t_s, dtype=np.float64)), rows)

    def _on_data(self, _cursor_s: float) -> None:
        session = self.session
        found = session.poses_after(self._last_pose_t)
        if found is not None:
            t_pose, q_segments = found
            self._last_pose_t = float(t_pose[-1])
            model = session.model
            q = np.stack([q_segments[name] for name in model.segment_names])        # (S, P, 4)
            lsl_s = self.lsl_time(t_pose)
            self.segments.push(lsl_s, q.transpose(1, 0, 2).reshape(len(t_pose), -1))
            angles = skeleton.joint_angles_deg_stacked(model, q)                    # (J, P, 3)
            measured = self._measured_joints()
            columns = []
            for joint in self._columns:
                values = angles[model.joint_names.index(joint)]
                columns.append(values if joint in measured else np.full_like(values, np.nan))
            self.joints.push(lsl_s, np.concatenate(columns, axis=1))
        self.poll()

    def _measured_joints(self) -> set[str]:
        """Joints whose two segments each carry a sensor of the body calibration now; none before
        one (the sensors' own axes stand for the segments then: their angles are no joint angles,
        and the window plots none)."""
        session = self.session
        if session.body_calibration is None:
            return set()
        carried = set(session.body_calibration.sensors)
        return {j.name for j in session.model.joints if j.proximal in carried and j.distal in carried}

    def _on_marker(self, t_s: float, label: str, _recorded: bool) -> None:
        if not self._taking:
            self.markers.push_sample([str(label)], float(self.lsl_time(t_s)))

    # -- markers in ------------------------------------------------------------------------------
    def marker_streams(self, timeout_s: float = 1.0) -> list[str]:
        """Names of the marker streams (one channel, irregular rate) on the network, ours left
        out, found within ``timeout_s``."""
        names = []
        for info in self.pylsl.resolve_streams(timeout_s):
            if info.channel_count() == 1 and info.nominal_srate() == 0 and not info.source_id().startswith(NAME_PREFIX):
                if info.name() not in names:
                    names.append(info.name())
        return names

    def take_markers(self, name: str, timeout_s: float = RESOLVE_TIMEOUT_S) -> None:
        """Take every sample of the LSL marker stream called ``name`` from now on as a session
        marker at its time (:meth:`poll`); ``ValueError`` when no such stream answers within
        ``timeout_s``, or when it is not a marker stream (one channel, irregular rate)."""
        found = [info for info in self.pylsl.resolve_byprop("name", name, 1, timeout_s)
                 if not info.source_id().startswith(NAME_PREFIX)]
        if not found:
            raise ValueError(f"no Lab Streaming Layer stream named {name!r} answered within {timeout_s:g} s "
                             "(is the program that sends it running, on this network?)")
        info = found[0]
        if info.channel_count() != 1 or info.nominal_srate() != 0:
            raise ValueError(f"LSL stream {name!r} is not a marker stream: it has {info.channel_count()} channels "
                             f"at {info.nominal_srate():g} Hz (a marker stream has one channel, irregular rate)")
        self.stop_taking_markers()
        inlet = self.pylsl.StreamInlet(info, max_buflen=360, processing_flags=self.pylsl.proc_clocksync)
        inlet.open_stream(timeout_s)
        inlet.time_correction(timeout_s)  # the first estimate, so that the first marker is on our clock
        self._inlet = inlet
        self.marker_stream = name

    def stop_taking_markers(self) -> None:
        if self._inlet is not None:
            self._inlet.close_stream()
        self._inlet = None
        self.marker_stream = ""

    def poll(self) -> int:
        """Take the markers that arrived from :attr:`marker_stream` into the session, each at its
        LSL time; returns how many (the session's ``step`` calls this through its ``data``
        event; call it when the source sends nothing)."""
        if self._inlet is None:
            return 0
        values, stamps = self._inlet.pull_chunk(timeout=0.0)
        self._taking = True
        try:
            for value, stamp in zip(values, stamps):
                self.session.add_marker(_marker_text(value), self.host_time(stamp))
        finally:
            self._taking = False
        self.markers_taken += len(stamps)
        return len(stamps)

    # -- end -------------------------------------------------------------------------------------
    def close(self) -> None:
        """Stop listening to the session and close every stream."""
        for emitter, callback in self._callbacks:
            emitter.disconnect(callback)
        self.stop_taking_markers()
        self.segments = self.joints = self.markers = None
        self.raw = {}

    def streams(self) -> list[tuple[str, int, float]]:
        """``(name, samples pushed, nominal rate Hz)`` of every data outlet so far."""
        outlets = [self.segments, self.joints, *self.raw.values()]
        return [(o.layout.name, o.pushed, o.rate_hz) for o in outlets if o is not None]


def _marker_text(value: Sequence) -> str:
    """A marker sample's label (its one channel, as text)."""
    item = value[0] if len(value) else ""
    return item if isinstance(item, str) else f"{item:g}"
