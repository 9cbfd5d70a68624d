"""Compile the fusion kernels ahead of time into a Python extension module (numba's ``pycc``).

The module exports the entry points of :data:`~mimucap.core.fusion.aot.ENTRY_POINTS`, the
per-sensor loops :func:`~.kernels.ekf_sensors` and :func:`~.kernels.rts_smooth_sensors`. Their
bodies do no arithmetic (``pycc`` compiles them with its own options); what they call, the
filter :func:`~.kernels.ekf_block` and the smoother :func:`~.kernels.rts_smooth`, are the numba
dispatchers compiled with the options of :mod:`.jit`, linked in as the JIT compiled them. So the
compiled code is the JIT kernel itself, lowered by the same LLVM into a shared library that
needs neither numba nor LLVM at run time. ``pycc`` also needs a C
compiler (for the module's small C wrapper); it is marked "pending deprecation" since numba
0.57 and still works in 0.68.

Targets: ``host`` compiles for this machine's CPU, like the JIT (what ``make install`` builds:
bitwise the JIT's results); ``generic`` for any CPU of the architecture (a module to ship).
The file goes to :data:`~mimucap.core.fusion.aot.COMPILED_DIR` under the name that
:func:`~mimucap.core.fusion.aot.module_name` gives the current sources, layouts and target;
modules of older sources there are removed.

``python -m mimucap.core.fusion.aot_build [--target host|generic] [--out DIR]``; installation
runs it through :mod:`.warmup`.
"""

from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

from mimucap.core.fusion import aot, kernels

TARGETS = ("host", "generic")


def signature(name: str) -> str:
    """numba signature of entry point ``name``: ``void(f8[:, ::1], ...)`` (C-contiguous arrays)."""
    args = []
    for _, code, ndim in aot.ENTRY_POINTS[name]:
        args.append(code if ndim == 0 else f"{code}[{', '.join([':'] * (ndim - 1) + ['::1'])}]")
    return f"void({', '.join(args)})"


def target_id(target: str) -> str:
    """The target id of :mod:`.aot` for ``host`` or ``generic`` on this machine."""
    if target not in TARGETS:
        raise ValueError(f"unknown target {target!r}; choose one of {', '.join(TARGETS)}")
    wanted = "host:" if target == "host" else "generic:"
    for candidate in aot.target_ids():
        if candidate.startswith(wanted):
            return candidate
    raise ValueError("the host target needs this CPU's identity (/proc/cpuinfo), which this "
                     "system does not give: build the generic target")


def build(target: str = "host", directory: Path | None = None) -> Path:
    """Compile the module for ``target`` into ``directory`` (default
    :data:`~mimucap.core.fusion.aot.COMPILED_DIR`, created if needed) and remove the other
    modules there; returns its path. ``OSError`` if the folder is not writable or the C
    compiler fails."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # pycc's pending deprecation, said in the module doc
        from numba.pycc import CC

    tid = target_id(target)
    directory = aot.COMPILED_DIR if directory is None else Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    path = aot.module_path(tid, directory)
    name = aot.module_name(tid)
    with tempfile.TemporaryDirectory(dir=directory, prefix=".build-") as scratch:
        cc = CC(name)
        cc.output_dir = scratch
        cc.verbose = False
        if target == "host":
            cc.target_cpu = "host"
        for entry in aot.ENTRY_POINTS:
            cc.export(entry, signature(entry))(getattr(kernels, entry).py_func)
        try:
            cc.compile()
        except Exception as error:  # distutils and the C compiler raise their own kinds
            raise OSError(f"compiling {name} failed: {error}") from error
        built = Path(scratch) / path.name
        if not built.is_file():
            raise OSError(f"compiling {name} left no {path.name} in {scratch}")
        built.replace(path)
    current = {aot.module_path(other, directory) for other in aot.target_ids()} | {path}
    for old in directory.glob(aot.MODULE_PREFIX + "*"):
        if old not in current:  # compiled from older sources: never loaded again
            old.unlink(missing_ok=True)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Compile the fusion kernels ahead of time.")
    parser.add_argument("--target", choices=TARGETS, default="host")
    parser.add_argument("--out", type=Path, default=None, help=f"folder (default {aot.COMPILED_DIR})")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    path = build(args.target, args.out)
    print(f"fusion kernels compiled ahead of time ({args.target}) into {path} in "
          f"{time.perf_counter() - started:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
