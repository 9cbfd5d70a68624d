"""The activity timeline of the simulated subject: activities strung together and blended.

A :class:`Schedule` places activities one after another and blends each new one in over its
``blend_in_s`` (the longer of it and the previous activity's ``blend_out_s``; minimum-jerk
weights), so poses, velocities and accelerations stay continuous. Frames and units as in
:mod:`mimucap.core.simulate.body_pose`.
"""

from __future__ import annotations

import bisect
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from mimucap.core.simulate.activities import Activity, HoldSensors
from mimucap.core.simulate.body_pose import BaseState, BodyPose, align_keys, blend, empty_pose_like
from mimucap.core.simulate.minimum_jerk import minimum_jerk


@dataclass
class _Entry:
    start_s: float
    activity: Activity
    state: BaseState
    label: str
    marker: str
    blend_s: float
    #: Whether this entry's poses may include a hand-held bundle (it or a predecessor holds one).
    carries_bundle: bool


class Schedule:
    """Activities on a timeline, extended lazily from an iterator; poses at any times.

    ``pose(t)`` is a pure function of ``t`` for the entries already placed: evaluating the same
    time twice gives identical results, whatever else was evaluated in between.
    """

    def __init__(self, activities: Iterator[Activity], start_s: float = 0.0, state: BaseState = BaseState()) -> None:
        self._entries: list[_Entry] = []
        self._starts: list[float] = []
        self._source: Iterator[Activity] | None = iter(activities)
        self._pending_start = start_s
        self._pending_state = state
        self._append_next()

    @property
    def entries(self) -> list[tuple[float, str]]:
        """(start time, label) of every activity placed so far."""
        return [(e.start_s, e.label) for e in self._entries]

    @property
    def markers(self) -> list[tuple[float, str]]:
        """(start time, marker label) of every activity placed so far."""
        return [(e.start_s, e.marker) for e in self._entries]

    def _append_next(self) -> bool:
        if self._source is None:
            return False
        try:
            activity = next(self._source)
        except StopIteration:
            self._source = None
            return False
        self._add(self._pending_start, activity)
        return True

    def _add(self, start_s: float, activity: Activity) -> None:
        blend_s = activity.blend_in_s
        if self._entries:
            pose = self._pose_of_entry(len(self._entries) - 1, np.array([start_s]))
            state = BaseState(float(pose.heading_rad[0]), (float(pose.root_xy_m[0, 0]), float(pose.root_xy_m[0, 1])))
            blend_s = max(blend_s, self._entries[-1].activity.blend_out_s)
        else:
            state = self._pending_state
        carries = isinstance(activity, HoldSensors) or bool(self._entries and self._entries[-1].carries_bundle)
        self._entries.append(_Entry(start_s, activity, state, activity.describe(), activity.marker_label(),
                                    blend_s, carries))
        self._starts.append(start_s)
        if activity.duration_s is not None:
            self._pending_start = start_s + activity.duration_s

    def extend_to(self, t_s: float) -> None:
        """Place scripted activities until the timeline covers ``t_s``."""
        while self._source is not None and self._entries[-1].activity.duration_s is not None \
                and self._pending_start <= t_s:
            if not self._append_next():
                break

    def switch(self, t_s: float, activities: Iterator[Activity]) -> None:
        """From ``t_s`` on, follow ``activities`` instead (blended in; later scripted entries dropped)."""
        keep = bisect.bisect_right(self._starts, t_s)
        if keep == 0:
            raise ValueError("cannot switch activity before the schedule starts")
        del self._entries[keep:]
        del self._starts[keep:]
        self._source = iter(activities)
        self._pending_start = t_s
        self._append_next()

    def forget_before(self, t_s: float) -> None:
        """Drop activities no longer needed for times at or after ``t_s`` (bounded memory when
        streaming for hours); later poses are unchanged.

        Entry ``j`` consults entry ``j-1`` only for times in ``[start_j, start_j + blend_j)``
        (including the warped times of a bundle being put down, which are ≥ ``start_j``), so
        walking back from the entry running at ``t_s`` finds the oldest entry still needed.
        """
        if not self._entries:
            return
        keep = max(bisect.bisect_right(self._starts, t_s) - 1, 0)
        lowest = t_s
        while keep > 0 and lowest < self._entries[keep].start_s + self._entries[keep].blend_s:
            lowest = min(lowest, self._entries[keep].start_s)
            keep -= 1
        if keep:
            del self._entries[:keep]
            del self._starts[:keep]

    def _pose_of_entry(self, index: int, t: np.ndarray) -> BodyPose:
        entry = self._entries[index]
        tau = t - entry.start_s
        pose = entry.activity.pose(tau, entry.state)
        if index == 0:
            return pose
        weight = minimum_jerk(tau / entry.blend_s)
        partial = weight < 1.0
        if not np.any(partial):
            return pose
        if self._entries[index - 1].carries_bundle:
            # A bundle being put down (or handed to the next activity) slows to a stop during
            # the blend: its previous motion is followed on the warped clock start + B·(x − x²/2),
            # x = tau / B, which starts at full speed and ends at rest.
            x = np.clip(tau[partial] / entry.blend_s, 0.0, 1.0)
            warped = entry.start_s + entry.blend_s * (x - 0.5 * x * x)
            k = x.shape[0]
            both = self._pose_of_entry(index - 1, np.concatenate((t[partial], warped)))
            previous, slowed = both.take(np.arange(k)), both.take(np.arange(k, 2 * k))
            previous.bundle_q, previous.bundle_p_m = slowed.bundle_q, slowed.bundle_p_m
            previous.bundle_weight, previous.axis_turned = slowed.bundle_weight, np.full(k, -1, dtype=np.int64)
        else:
            previous = self._pose_of_entry(index - 1, t[partial])
        blended = blend(previous, pose.take(partial), weight[partial])
        if np.all(partial):
            return blended
        # Make both sides carry the same joints and held sensors before writing back.
        full = blend(pose, pose, np.zeros(t.shape[0]))
        align_keys(full, blended)
        full.put(partial, blended)
        return full

    def pose(self, t_s: np.ndarray) -> BodyPose:
        """The subject at times ``t_s`` (m,) (any order, at or after the schedule start)."""
        t = np.asarray(t_s, dtype=np.float64)
        self.extend_to(float(t.max()))
        index = np.searchsorted(np.asarray(self._starts), t, side="right") - 1
        if np.any(index < 0):
            index = np.maximum(index, 0)
        pieces = [(i, index == i) for i in np.unique(index)]
        if len(pieces) == 1:
            return self._pose_of_entry(int(pieces[0][0]), t)
        poses = [(mask, self._pose_of_entry(int(i), t[mask])) for i, mask in pieces]
        result = empty_pose_like([pose for _, pose in poses], t.shape[0])
        for mask, pose in poses:
            align_keys(result, pose)
            result.put(mask, pose)
        return result

    def entry_start(self, t_s: np.ndarray) -> np.ndarray:
        """Start time (s) of the activity running at each of ``t_s`` (m,)."""
        starts = np.asarray(self._starts)
        index = np.maximum(np.searchsorted(starts, np.asarray(t_s, dtype=np.float64), side="right") - 1, 0)
        return starts[index]

    def label_at(self, t_s: float) -> str:
        """Label of the activity running at ``t_s``."""
        self.extend_to(t_s)
        index = max(bisect.bisect_right(self._starts, t_s) - 1, 0)
        return self._entries[index].label
