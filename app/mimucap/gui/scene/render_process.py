"""The render process: draws the skeleton scene's pictures for the 3D view of the GUI process.

On a machine without a GPU, Mesa's software rasteriser (llvmpipe) draws in the process that
asks for the picture: for the 3D view at 60 frames per second about a third of a core, taken
from the thread that also runs the plots, the panels and the live pipeline. This process holds
a mirror of the scene (same renderer set-up, :class:`~mimucap.gui.scene.environment.Stage`,
:class:`~mimucap.gui.scene.skeleton_actor.SkeletonActor`), applies each
:class:`~mimucap.gui.scene.scene_state.SceneState` it is sent, renders offscreen and writes
the picture into a memory-mapped frame file (``/dev/shm`` where there is one), so that only a
short reply crosses the pipe. With a GPU the same work is the driver's, a fraction of a
millisecond a frame.

Messages in (over a ``multiprocessing`` connection): a :class:`FigureLayout` (show a figure of
that layout; ``None`` for none: :class:`NoFigure`), a :class:`FrameRequest`, or ``None`` to stop.
Messages out: :class:`FrameDone` or, once, :class:`RenderFailed` (then the process ends). The
process is started with the spawn method from :func:`serve` and also stops when its stop
event is set or the connection closes.
"""

from __future__ import annotations

import mmap
import traceback
from dataclasses import dataclass

import numpy as np

from mimucap.gui.software_gl import prefer_unthreaded_software_gl



@dataclass(frozen=True)
class NoFigure:
    """Show no figure (only the stage)."""


@dataclass(frozen=True)
class FrameRequest:
    """Draw ``state`` and write the picture into the frame file ``frame_path`` (at least
    ``width × height × 4`` bytes), rows from the top, each pixel's bytes in the order B, G, R,
    A when ``bgra`` (what Qt paints fastest on a little-endian machine), otherwise R, G, B, A;
    ``request_id`` comes back in the :class:`FrameDone`."""

    request_id: int
    frame_path: str
    state: object  # a SceneState (typed loosely: this module is imported before VTK)
    bgra: bool = False


@dataclass(frozen=True)
class FrameDone:
    """The picture of request ``request_id`` is in its frame file: ``width × height`` pixels,
    rows from the top."""

    request_id: int
    width: int
    height: int


@dataclass(frozen=True)
class RenderFailed:
    """The render process stopped on an error: ``reason`` (one line) and ``details`` (traceback)."""

    reason: str
    details: str


def frame_pixels(buffer, width: int, height: int) -> np.ndarray:
    """The ``(height, width, 4)`` picture bytes at the start of a frame file's mapped ``buffer``
    (a view, no copy); ``ValueError`` when the file is too small for them."""
    needed = width * height * 4
    if len(buffer) < needed:
        raise ValueError(f"a frame file of {len(buffer)} bytes cannot hold a {width}x{height} picture ({needed} bytes)")
    return np.frombuffer(buffer, dtype=np.uint8, count=needed).reshape(height, width, 4)


class _FrameFiles:
    """The memory-mapped frame files the pictures go to (the GUI alternates between two)."""

    #: files kept mapped; older ones are closed (the GUI replaced them)
    KEPT = 2

    def __init__(self) -> None:
        self._maps: dict[str, mmap.mmap] = {}

    def pixels(self, path: str, width: int, height: int) -> np.ndarray:
        if path not in self._maps:
            with open(path, "r+b") as file:
                self._maps[path] = mmap.mmap(file.fileno(), 0)
            while len(self._maps) > self.KEPT:
                del self._maps[next(iter(self._maps))]  # unmapped once no array uses it
        return frame_pixels(self._maps[path], width, height)

    def close(self) -> None:
        self._maps.clear()


def serve(connection, stop_event) -> None:
    """Render process entry point (top-level so that ``spawn`` can import it)."""
    prefer_unthreaded_software_gl()
    try:
        _serve(connection, stop_event)
    except Exception as error:  # said to the GUI, which falls back to drawing itself
        try:
            connection.send(RenderFailed(f"{type(error).__name__}: {error}", traceback.format_exc()))
        except OSError:
            pass
    finally:
        connection.close()


def _serve(connection, stop_event) -> None:
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (the OpenGL back end)
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonCore import vtkUnsignedCharArray
    from vtkmodules.vtkRenderingCore import vtkRenderWindow

    from mimucap.gui.scene.environment import Stage, scene_renderer
    from mimucap.gui.scene.scene_state import FigureLayout, apply_scene
    from mimucap.gui.scene.skeleton_actor import SkeletonActor

    window = vtkRenderWindow()
    window.SetMultiSamples(0)
    window.OffScreenRenderingOn()
    window.SetFrameBlitModeToNoBlit()  # the picture is read from the render framebuffer
    window.SwapBuffersOff()
    renderer = scene_renderer()
    window.AddRenderer(renderer)
    stage = Stage(renderer)
    skeleton: SkeletonActor | None = None
    frame_files = _FrameFiles()
    read_back = vtkUnsignedCharArray()
    try:
        while not stop_event.is_set():
            if not connection.poll(0.25):
                continue
            try:
                message = connection.recv()
            except EOFError:
                return
            if message is None:
                return
            if isinstance(message, (FigureLayout, NoFigure)):
                if skeleton is not None:
                    skeleton.remove()
                skeleton = SkeletonActor(renderer, message) if isinstance(message, FigureLayout) else None
            elif isinstance(message, FrameRequest):
                apply_scene(message.state, renderer, stage, skeleton)
                width, height = message.state.size_px
                window.Render()
                window.GetRGBACharPixelData(0, 0, width - 1, height - 1, 0, read_back, 0)
                rgba = vtk_to_numpy(read_back).reshape(height, width, 4)[::-1]  # VTK's rows run bottom-up
                out = frame_files.pixels(message.frame_path, width, height)
                if message.bgra:
                    for channel, source in enumerate((2, 1, 0, 3)):
                        out[..., channel] = rgba[..., source]
                else:
                    np.copyto(out, rgba)
                out = rgba = None  # a replaced frame file is unmapped once unused
                connection.send(FrameDone(message.request_id, width, height))
            else:
                raise ValueError(f"the render process got a message it does not know: {type(message).__name__}")
    finally:
        frame_files.close()
        window.Finalize()
