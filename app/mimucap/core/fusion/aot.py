"""The fusion kernels compiled ahead of time: where their module is, whether it is current, and
how it is loaded (which kernels a process then runs: :mod:`.kernel_selection`).

The numba kernels of :mod:`.kernels` (the forward EKF :func:`~.kernels.ekf_sensors` and the
Rauch-Tung-Striebel backward pass :func:`~.kernels.rts_smooth_sensors`) are also compiled ahead
of time, at installation, into a Python extension module (:mod:`.aot_build`, numba's ``pycc``):
the same source, the same dispatchers, the same compiler. A process that loads that module does
not import numba at all: numba's import and the loading of its cached kernels are a fixed cost
in every process, larger than the filter's own work on a long recording; and the GUI's first
start has nothing to compile.

**A stale module is never used.** The module's file name carries a fingerprint of everything
its machine code was made from: the source text of the modules compiled into it
(:data:`KERNEL_SOURCES`), the exported signatures (:data:`ENTRY_POINTS`), the settings and
state layouts the kernels read as constants (:data:`LAYOUT_FINGERPRINT`), and its target:
``host`` (the installing machine's CPU, identified by :func:`cpu_signature`; what a local
install builds) or ``generic`` (any CPU of the architecture). After an edit of a kernel, a
layout change or a move to another CPU, the name looked for is another one, so the old file is
simply not found, and the kernels come from numba's JIT (:mod:`.kernels`, compiled once into
numba's on-disk cache; :mod:`.kernel_selection`) until the next installation builds a current module. Where the sources
cannot be read, no fingerprint can be checked and the JIT kernels serve; the desktop bundle
therefore ships the kernel sources beside its ``generic`` module (``packaging/mimucap.spec``).

With the ``host`` target the module gives bitwise the orientations of the JIT kernels as
numba's cache holds them (both are LLVM's code for this CPU from the same source; numba's JIT
itself can round the last bits differently from one compilation to the next). The ``generic``
target may differ in the last bits (no fused multiply-add). Installation checks the agreement
(:mod:`.warmup`).
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import logging
import platform
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from mimucap.core.fusion import params, state

log = logging.getLogger(__name__)

PACKAGE_DIR = Path(__file__).resolve().parent
#: Where installation writes the compiled module (not under version control).
COMPILED_DIR = PACKAGE_DIR / "_compiled"
#: Modules whose source is compiled into the module: the kernels, the functions they call,
#: the numba options, and the exported signatures.
KERNEL_SOURCES = ("kernels.py", "disturbance.py", "hard_iron.py", "propagation.py", "jit.py", "aot_build.py")
#: File names of compiled modules start with this (followed by the fingerprint).
MODULE_PREFIX = "fusion_kernels_"
#: Fields of ``/proc/cpuinfo`` that identify a CPU's instruction set (not its clock or load).
CPU_FIELDS = ("vendor_id", "cpu family", "model", "model name", "flags", "CPU implementer",
              "CPU architecture", "CPU variant", "CPU part", "Features", "isa")

#: The exported entry points and their arguments in order: (name, numpy type code, number of
#: dimensions; 0 for the one boolean). Every array is C-contiguous and writeable. The build
#: (:mod:`.aot_build`) makes the compiled signatures from this table, and :func:`checked` checks
#: every call against it: a compiled module converts its arguments without looking at their type,
#: so a wrong array would be read as raw memory instead of being refused.
ENTRY_POINTS: dict[str, tuple[tuple[str, str, int], ...]] = {
    "ekf_sensors": (
        ("p", "f8", 1), ("t", "f8", 2), ("gyr", "f8", 3), ("acc", "f8", 3), ("mag", "f8", 3),
        ("q", "f8", 2), ("b", "f8", 2), ("P", "f8", 3), ("aux", "f8", 2), ("out_q", "f8", 3),
        ("out_bias", "f8", 3), ("out_flags", "u1", 2), ("store", "b1", 0), ("st_q", "f8", 3),
        ("st_b", "f8", 3), ("st_pp", "f8", 4), ("st_pu", "f8", 4), ("st_a", "f8", 4),
    ),
    "rts_smooth_sensors": (
        ("q_post", "f8", 3), ("b_post", "f8", 3), ("q_prior", "f8", 3), ("b_prior", "f8", 3),
        ("p_prior", "f8", 4), ("p_post", "f8", 4), ("a_blk", "f8", 4), ("out_q", "f8", 3),
        ("out_b", "f8", 3),
    ),
}


def _layout_fingerprint() -> int:
    items = sorted(
        (name, value)
        for module in (params, state)
        for name, value in vars(module).items()
        if name.startswith(("PI_", "AX_", "FLAG_", "AUX_")) and isinstance(value, int)
    )
    return zlib.crc32(repr(items).encode())


#: Checksum of the settings and state layouts (``PI_*``, ``AX_*``, ``FLAG_*``) the kernels are
#: compiled against.
LAYOUT_FINGERPRINT = _layout_fingerprint()


@dataclass(frozen=True)
class FusionKernels:
    """The compiled entry points (signatures of :func:`~.kernels.ekf_sensors` and
    :func:`~.kernels.rts_smooth_sensors`; every array C-contiguous, writeable float64, flags
    uint8) and where they come from (``origin``: the module's file name, or ``"numba JIT"``)."""

    ekf_sensors: Callable
    rts_smooth_sensors: Callable
    origin: str
    ahead_of_time: bool


def cpu_signature() -> str | None:
    """The instruction-set identity of this machine's first CPU (vendor, model, feature flags
    from ``/proc/cpuinfo``), or ``None`` where that file does not exist (then only the
    ``generic`` target is built and looked for)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as handle:
            first = handle.read(1 << 16).split("\n\n", 1)[0]
    except OSError:
        return None
    lines = []
    for line in first.splitlines():
        key, _, value = line.partition(":")
        if key.strip() in CPU_FIELDS:
            lines.append(f"{key.strip()}:{value.strip()}")
    return "\n".join(lines) or None


def target_ids() -> list[str]:
    """The targets this machine can run, best first: ``host:<CPU signature>`` (when known) and
    ``generic:<architecture>``."""
    ids = []
    signature = cpu_signature()
    if signature is not None:
        ids.append(f"host:{signature}")
    ids.append(f"generic:{platform.machine()}")
    return ids


def module_name(target_id: str) -> str:
    """Name of the compiled module for ``target_id`` and the current kernel sources and layouts
    (``OSError`` when a source cannot be read)."""
    data = b"".join(name.encode() + b"\0" + (PACKAGE_DIR / name).read_bytes() for name in KERNEL_SOURCES)
    data += f"entry points {ENTRY_POINTS} layout {LAYOUT_FINGERPRINT} target {target_id}".encode()
    # two 32-bit checksums (zlib is loaded already; hashlib would be one more import at every start)
    return f"{MODULE_PREFIX}{zlib.crc32(data):08x}{zlib.adler32(data):08x}"


def module_path(target_id: str, directory: Path | None = None) -> Path:
    """Where the module for ``target_id`` is (or would be) in ``directory`` (default
    :data:`COMPILED_DIR`)."""
    directory = COMPILED_DIR if directory is None else Path(directory)
    return directory / (module_name(target_id) + importlib.machinery.EXTENSION_SUFFIXES[0])


def checked(function: Callable, name: str) -> Callable:
    """``function`` (a compiled entry point of :data:`ENTRY_POINTS`) behind a check of its
    arguments: ``TypeError`` naming the argument instead of a crash or garbage when one is not
    exactly what the compiled code reads."""
    spec = [(arg, np.dtype(code), ndim) for arg, code, ndim in ENTRY_POINTS[name]]

    def call(*args):
        if len(args) != len(spec):
            raise TypeError(f"{name}: {len(spec)} arguments expected, got {len(args)}")
        for value, (arg, dtype, ndim) in zip(args, spec):
            if ndim == 0:
                if not isinstance(value, (bool, np.bool_)):
                    raise TypeError(f"{name}: argument {arg} must be a bool, got {type(value).__name__}")
                continue
            flags = getattr(value, "flags", None) if isinstance(value, np.ndarray) else None
            if not (flags is not None and value.dtype == dtype and value.ndim == ndim
                    and flags.c_contiguous and flags.writeable and flags.aligned):
                got = (f"{value.dtype} {value.shape}, flags C={value.flags.c_contiguous} "
                       f"W={value.flags.writeable}" if isinstance(value, np.ndarray) else type(value).__name__)
                raise TypeError(f"{name}: argument {arg} must be a C-contiguous, writeable {dtype} array "
                                f"of {ndim} dimensions, got {got}")
        function(*args)

    call.__name__ = call.__qualname__ = name
    call.__doc__ = f"Compiled ahead of time: {name}{tuple(arg for arg, _, _ in spec)}, arguments checked."
    return call


def load_ahead_of_time(directory: Path | None = None) -> FusionKernels | None:
    """The kernels of the current compiled module in ``directory`` (default
    :data:`COMPILED_DIR`), or ``None`` when there is none (never built, stale, or the sources
    are unreadable) or it does not load."""
    try:
        candidates = [module_path(target, directory) for target in target_ids()]
    except OSError:
        return None
    for path in candidates:
        if not path.is_file():
            continue
        spec = importlib.util.spec_from_file_location(path.name.split(".")[0], path)
        try:
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
        except ImportError as error:  # e.g. built against another numpy ABI
            log.warning("%s does not load (%s); using numba's JIT kernels", path, error)
            continue
        return FusionKernels(checked(module.ekf_sensors, "ekf_sensors"),
                             checked(module.rts_smooth_sensors, "rts_smooth_sensors"), path.name, True)
    return None
