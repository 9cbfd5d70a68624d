"""The GUI side of the render process: sends scene states, shows the pictures that come back.

:class:`RenderClient` starts :func:`mimucap.gui.scene.render_process.serve` (spawn method),
keeps at most one frame in flight; a frame asked for meanwhile is taken (state and labels) when
that one is back, so a slow frame delays the picture, never the GUI thread, and requests never
pile up. The picture
comes back through a memory-mapped frame file and is handed to a
:class:`~mimucap.gui.vtk_image_widget.VtkImageWidget` (``show_frame``) with the labels
computed for the same state. :meth:`RenderClient.render` with ``wait=True`` blocks until the
picture of the current state is shown (screenshots, tests).

When the process fails (it stops, says :class:`RenderFailed`, or a frame takes longer than
:data:`FRAME_TIMEOUT_S`), :attr:`RenderClient.failed` is emitted once with the reason and
the client stops; its owner then draws in its own process.
"""

from __future__ import annotations

import logging
import mmap
import multiprocessing
import os
import sys
import tempfile
import time
from collections.abc import Callable, Sequence

import numpy as np
from PyQt5 import QtCore, QtGui

from mimucap.gui.scene.render_process import FrameDone, FrameRequest, NoFigure, RenderFailed, frame_pixels, serve
from mimucap.gui.scene.scene_state import FigureLayout, SceneState
from mimucap.gui.vtk_image_widget import OverlayLabel, VtkImageWidget

log = logging.getLogger(__name__)

#: A frame (the first one included: it waits for the process to start) that takes longer
#: than this (s) means the render process is stuck.
FRAME_TIMEOUT_S = 30.0
#: Where the frame file lives: shared memory when the system has it.
FRAME_DIR = "/dev/shm" if os.path.isdir("/dev/shm") else None


class _FrameFile:
    """A temporary file of ``capacity`` bytes, mapped in this process. :meth:`close` removes
    the file; the mapping lasts while a picture shown from it does."""

    def __init__(self, capacity: int) -> None:
        descriptor, self.path = tempfile.mkstemp(prefix="mimucap-frame-", dir=FRAME_DIR)
        try:
            os.ftruncate(descriptor, capacity)
            self.map = mmap.mmap(descriptor, capacity)
        finally:
            os.close(descriptor)
        self.capacity = capacity

    def pixels(self, width: int, height: int) -> np.ndarray:
        return frame_pixels(self.map, width, height)

    def close(self) -> None:
        try:
            os.unlink(self.path)
        except OSError:
            pass
        self.map = None


class RenderClient(QtCore.QObject):
    """The render process of one 3D view.

    Args:
        widget: where the pictures are shown (``show_frame``); its ``label_provider`` is read
            with each state.
        capture: returns the :class:`SceneState` to draw now and a tag for it (e.g. the id
            of the frame it shows), called when the state is sent: a frame asked for while
            another is in flight is taken once that one is back, so it is the newest state and
            always fits the figure last set.

    Signals:
        failed(str): the render process failed (once; the client is closed).
        frame_shown(object): a picture was shown; the tag ``capture`` gave with its state.
    """

    failed = QtCore.pyqtSignal(str)
    frame_shown = QtCore.pyqtSignal(object)

    def __init__(self, widget: VtkImageWidget, capture: Callable[[], tuple[SceneState, object]]) -> None:
        super().__init__(widget)
        self._widget = widget
        self._capture = capture
        context = multiprocessing.get_context("spawn")
        self._connection, child_end = context.Pipe(duplex=True)
        self._stop = context.Event()
        self._process = context.Process(target=serve, args=(child_end, self._stop), name="mimucap-render", daemon=True)
        self._process.start()
        child_end.close()
        self._frame_files: list[_FrameFile] = []  # two, used in turn: one shown, one drawn into
        self._frame_index = 0  # the one the next frame goes to
        self._bgra = sys.byteorder == "little"  # Qt's RGB32 pixels are B, G, R, A bytes there
        self._next_id = 0
        self._in_flight: tuple[int, Sequence[OverlayLabel], object, float] | None = None  # id, labels, tag, sent at
        self._wanted = False  # a frame was asked for and not sent yet
        self._closed = False
        self._notifier = QtCore.QSocketNotifier(self._connection.fileno(), QtCore.QSocketNotifier.Read, self)
        self._notifier.activated.connect(self._read_replies)
        self._watchdog = QtCore.QTimer(self)
        self._watchdog.setInterval(1000)
        self._watchdog.timeout.connect(self._check_in_flight)
        self._watchdog.start()

    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def pid(self) -> int | None:
        """The render process's id."""
        return self._process.pid

    @property
    def frame_paths(self) -> tuple[str, ...]:
        """The frame files in use (removed by :meth:`close`)."""
        return tuple(frame_file.path for frame_file in self._frame_files)

    def set_figure(self, layout: FigureLayout | None) -> None:
        """Show a figure of ``layout`` from the next frame on (``None``: no figure)."""
        self._send(NoFigure() if layout is None else layout)

    def render(self, wait: bool = False) -> None:
        """Draw the scene: now, or as it is when the frame in flight is back. Without ``wait``
        this returns at once (the picture follows); with it, it returns once the picture is
        shown (or the client failed)."""
        if self._closed:
            return
        self._wanted = True
        if self._in_flight is None:
            self._send_wanted()
        if wait:
            deadline = time.monotonic() + FRAME_TIMEOUT_S
            while not self._closed and (self._in_flight is not None or self._wanted):
                if time.monotonic() > deadline:
                    self._fail(f"a frame took over {FRAME_TIMEOUT_S:.0f} s")
                    break
                if self._connection.poll(0.05):
                    self._read_replies()

    def close(self) -> None:
        """Stop the render process and free the frame file (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self._watchdog.stop()
        self._notifier.setEnabled(False)
        self._stop.set()
        try:
            self._connection.send(None)
        except (OSError, ValueError):
            pass
        self._process.join(2.0)
        if self._process.is_alive():
            self._process.terminate()
            self._process.join(2.0)
        self._connection.close()
        for frame_file in self._frame_files:
            frame_file.close()
        self._frame_files = []

    # -- internals -------------------------------------------------------------------------
    def _send(self, message) -> None:
        if self._closed:
            return
        try:
            self._connection.send(message)
        except (OSError, ValueError) as error:
            self._fail(f"the render process cannot be reached ({error})")

    def _send_wanted(self) -> None:
        self._wanted = False
        state, tag = self._capture()
        labels = tuple(self._widget.label_provider()) if self._widget.label_provider is not None else ()
        width, height = state.size_px
        needed = width * height * 4
        if not self._frame_files or self._frame_files[0].capacity < needed:
            for frame_file in self._frame_files:
                frame_file.close()  # mappings stay while in use, here and in the render process
            self._frame_files = [_FrameFile(needed), _FrameFile(needed)]
        self._frame_index = 1 - self._frame_index
        self._next_id += 1
        self._in_flight = (self._next_id, labels, tag, time.monotonic())
        self._send(FrameRequest(self._next_id, self._frame_files[self._frame_index].path, state, bgra=self._bgra))

    def _read_replies(self, *_args) -> None:
        while not self._closed:
            try:
                if not self._connection.poll():
                    return
                message = self._connection.recv()
            except (EOFError, OSError) as error:
                self._fail(f"the render process stopped ({type(error).__name__})")
                return
            if isinstance(message, RenderFailed):
                log.error("render process failed: %s\n%s", message.reason, message.details)
                self._fail(message.reason)
                return
            if isinstance(message, FrameDone):
                self._show(message)

    def _show(self, done: FrameDone) -> None:
        if self._in_flight is None or done.request_id != self._in_flight[0]:
            return
        _, labels, tag, _sent = self._in_flight
        self._in_flight = None
        # Shown in place: the next frame goes to the other file.
        image_format = QtGui.QImage.Format_RGB32 if self._bgra else QtGui.QImage.Format_RGBX8888
        pixels = self._frame_files[self._frame_index].pixels(done.width, done.height)
        self._widget.show_frame(pixels, labels, image_format, copy=False)
        self.frame_shown.emit(tag)
        if self._wanted:
            self._send_wanted()

    def _check_in_flight(self) -> None:
        if self._in_flight is not None and time.monotonic() - self._in_flight[3] > FRAME_TIMEOUT_S:
            self._fail(f"a frame took over {FRAME_TIMEOUT_S:.0f} s")
        elif not self._closed and not self._process.is_alive():
            self._read_replies()  # a last word, if any
            if not self._closed:
                self._fail(f"the render process ended (exit code {self._process.exitcode})")

    def _fail(self, reason: str) -> None:
        if self._closed:
            return
        log.warning("3D view: %s; drawing in the GUI process instead", reason)
        self.close()
        self.failed.emit(reason)
