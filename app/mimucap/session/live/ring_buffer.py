"""Preallocated ring buffers of time-stamped samples for the live view.

A :class:`RingBuffer` holds the last ``capacity`` samples of one stream: times ``t_s``
(float64 seconds, session clock) and values of a fixed per-sample shape (e.g. ``(3,)`` for
an accelerometer in m/s², ``(4,)`` for a scalar-first quaternion, ``()`` for an angle in
degrees). Memory is allocated once; appending never reallocates. Readers get *copies* in
time order, so a plot can hand them to ``setData`` while the buffer keeps filling.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


class RingBuffer:
    """The last ``capacity`` samples of one stream, oldest first when read.

    Args:
        capacity: number of samples kept (> 0).
        sample_shape: shape of one sample's value, e.g. ``(3,)``.
        dtype: value dtype (float64 by default).
    """

    def __init__(self, capacity: int, sample_shape: tuple[int, ...] = (), dtype=np.float64) -> None:
        if int(capacity) <= 0:
            raise ValueError(f"ring buffer capacity must be positive, got {capacity}")
        self.capacity = int(capacity)
        self.sample_shape = tuple(sample_shape)
        self._t = np.full(self.capacity, np.nan)
        self._v = np.zeros((self.capacity,) + self.sample_shape, dtype=dtype)
        self._head = 0  # index where the next sample goes
        self._count = 0
        self.total_appended = 0

    def __len__(self) -> int:
        return self._count

    def clear(self) -> None:
        """Forget every sample (the memory stays allocated)."""
        self._head = 0
        self._count = 0

    def append(self, t_s: ArrayLike, values: ArrayLike) -> None:
        """Append samples: ``t_s`` shape ``(n,)``, ``values`` shape ``(n,) + sample_shape``."""
        t = np.asarray(t_s, dtype=np.float64)
        if t.ndim == 0:
            t = t.reshape(1)
        n = t.shape[0]
        v = np.asarray(values, dtype=self._v.dtype)
        if v.shape != (n,) + self.sample_shape:
            v = v.reshape((n,) + self.sample_shape)
        if n == 0:
            return
        if n >= self.capacity:
            t, v = t[-self.capacity :], v[-self.capacity :]
            self._t[:] = t
            self._v[:] = v
            self._head = 0
            self._count = self.capacity
            self.total_appended += n
            return
        end = self._head + n
        if end <= self.capacity:
            self._t[self._head : end] = t
            self._v[self._head : end] = v
        else:
            first = self.capacity - self._head
            self._t[self._head :] = t[:first]
            self._v[self._head :] = v[:first]
            self._t[: n - first] = t[first:]
            self._v[: n - first] = v[first:]
        self._head = end % self.capacity
        self._count = min(self.capacity, self._count + n)
        self.total_appended += n

    def _order(self) -> NDArray[np.intp]:
        start = (self._head - self._count) % self.capacity
        return (start + np.arange(self._count)) % self.capacity

    def data(self) -> tuple[NDArray[np.float64], NDArray]:
        """All kept samples, oldest first: ``(t_s (n,), values (n,) + sample_shape)`` (copies)."""
        order = self._order()
        return self._t[order], self._v[order]

    def since(self, t_from_s: float) -> tuple[NDArray[np.float64], NDArray]:
        """Samples with ``t_s >= t_from_s``, oldest first (copies).

        Only the returned samples' values are copied (a live plot asks for a few seconds of
        a buffer that holds thirty).
        """
        start = (self._head - self._count) % self.capacity
        end = start + self._count
        if end <= self.capacity:  # one contiguous run
            t = self._t[start:end]
            first = int(np.searchsorted(t, t_from_s, side="left"))
            return t[first:].copy(), self._v[start + first : end].copy()
        older = self.capacity - start  # samples in the run at the end of the arrays
        t = np.concatenate((self._t[start:], self._t[: end - self.capacity]))
        first = int(np.searchsorted(t, t_from_s, side="left"))
        if first >= older:
            return t[first:], self._v[first - older : end - self.capacity].copy()
        return t[first:], np.concatenate((self._v[start + first :], self._v[: end - self.capacity]))

    def latest(self) -> tuple[float, NDArray] | None:
        """The newest sample ``(t_s, value)`` or ``None`` when empty."""
        if self._count == 0:
            return None
        index = (self._head - 1) % self.capacity
        return float(self._t[index]), self._v[index].copy()

    def latest_t(self) -> float:
        """Time (s) of the newest sample, NaN when empty."""
        if self._count == 0:
            return float("nan")
        return float(self._t[(self._head - 1) % self.capacity])

    def at(self, t_s: float) -> tuple[float, NDArray] | None:
        """The newest sample at or before ``t_s`` (the oldest kept one if all are later)."""
        if self._count == 0:
            return None
        t, v = self.data()
        index = max(int(np.searchsorted(t, t_s, side="right")) - 1, 0)
        return float(t[index]), v[index]
