"""Which compiled fusion kernels a process runs: the module compiled ahead of time when a
current one exists (:mod:`.aot`), else numba's JIT kernels (:mod:`.kernels`).

The choice is made at the first call of :func:`fusion_kernels` and kept. The environment
variable ``MIMUCAP_FUSION_KERNELS=jit`` makes a process use the JIT kernels even when a current
module exists (comparisons, and tests of the JIT path); :func:`kernels_in_use` changes the
choice for a block of code.

The module compiled ahead of time and the JIT kernels are chosen here rather than in
:mod:`.aot`: the JIT kernels import the layout fingerprint from :mod:`.aot` (through
:mod:`.jit`), so a choice made in :mod:`.aot` would close an import cycle.
"""

from __future__ import annotations

import contextlib
import os
from typing import Iterator

from mimucap.core.fusion.aot import FusionKernels, load_ahead_of_time

#: Environment variable choosing the kernels: ``jit`` forces numba's JIT; unset or ``auto``
#: takes the ahead-of-time module when a current one exists.
KERNELS_ENV = "MIMUCAP_FUSION_KERNELS"


def jit_kernels() -> FusionKernels:
    """The numba JIT kernels (imports numba; compiled or loaded from numba's cache at first call)."""
    from mimucap.core.fusion import kernels

    return FusionKernels(kernels.ekf_sensors, kernels.rts_smooth_sensors, "numba JIT", False)


_selected: FusionKernels | None = None


def fusion_kernels() -> FusionKernels:
    """The kernels this process uses, chosen at the first call: the current ahead-of-time
    module, else numba's JIT (see the module doc and :data:`KERNELS_ENV`)."""
    global _selected
    if _selected is None:
        choice = os.environ.get(KERNELS_ENV, "auto").strip().lower()
        if choice not in ("auto", "jit", ""):
            raise ValueError(f"environment variable {KERNELS_ENV}={choice!r}: use 'jit' or 'auto'")
        _selected = (load_ahead_of_time() if choice != "jit" else None) or jit_kernels()
    return _selected


@contextlib.contextmanager
def kernels_in_use(kernels: FusionKernels) -> Iterator[FusionKernels]:
    """Within the block, this process's fusion runs ``kernels`` (comparisons of the two kinds,
    and the installation's warm-up of the JIT kernels); the previous choice returns after it."""
    global _selected
    previous = _selected
    _selected = kernels
    try:
        yield kernels
    finally:
        _selected = previous
