"""Runtime hook of the MimuCap desktop bundle: runs in the bundled program before ``mimucap``.

**numba is not in the bundle.** The fusion kernels come compiled ahead of time (target
``generic``, ``packaging/mimucap.spec``); numba's JIT, the fallback of a source installation
(:mod:`mimucap.core.fusion.aot`), would only be reached if that module did not load, and numba
and its LLVM (about 170 MB) are left out. Any import of ``numba`` or ``llvmlite`` therefore
fails at once with an ``ImportError`` saying so, instead of a bare "No module named 'numba'":
the command prints it, and the main window's status bar shows it when the live view stops.

**Qt draws on X11.** VTK's 3D view needs an X11 window, so the bundle ships Qt's ``xcb``
platform and not its Wayland one (XWayland serves on Wayland desktops): a ``QT_QPA_PLATFORM``
asking for Wayland is turned into ``xcb`` rather than making Qt abort for a missing plugin.
"""

import importlib.abc
import os
import sys

NO_NUMBA = (
    "this MimuCap bundle runs its orientation filter from the kernels compiled ahead of time "
    "(mimucap/core/fusion/_compiled) and ships no numba to compile them; they did not load here "
    "(the log says why: mimucap.log in MimuCap's log folder, ~/.local/state/mimucap on Linux). "
    "Install MimuCap again, or use the Python "
    "package (pip install mimucap), which compiles them on this computer.")


class _NoNumba(importlib.abc.MetaPathFinder):
    """Refuses ``numba`` and ``llvmlite`` with :data:`NO_NUMBA`."""

    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in ("numba", "llvmlite"):
            raise ImportError(f"cannot import {name}: {NO_NUMBA}", name=name)
        return None


sys.meta_path.insert(0, _NoNumba())

if "wayland" in os.environ.get("QT_QPA_PLATFORM", "").lower():
    os.environ["QT_QPA_PLATFORM"] = "xcb"
