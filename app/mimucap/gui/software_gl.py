"""Mesa's software OpenGL (llvmpipe) without helper threads, unless the user chose otherwise.

On llvmpipe the rasteriser's helper threads (``LP_NUM_THREADS``, one per core by default) cost
more in hand-over than they save on a 3D view of this application's size: on a 2-core machine
the main window on 17 simulated sensors took 89 % of a core with them and 79 % without (an empty
493 × 560 frame: 1.74 ms against 0.89 ms of CPU), and a full-screen 1920 × 1200 window drew 38
frames per second with them and 47 without. Mesa reads the variable when a process makes its
first OpenGL context; a GPU driver ignores it. Every process that draws calls
:func:`prefer_unthreaded_software_gl` before its first context: the GUI process (for its own
views) and the render process.
"""

from __future__ import annotations

import os

#: ``LP_NUM_THREADS`` when the user did not set it: no helper threads.
SOFTWARE_GL_THREADS = "0"


def prefer_unthreaded_software_gl() -> None:
    """Set ``LP_NUM_THREADS`` to :data:`SOFTWARE_GL_THREADS` unless it is set already."""
    os.environ.setdefault("LP_NUM_THREADS", SOFTWARE_GL_THREADS)
