"""Wheels of MimuCap carry the fusion kernels compiled ahead of time (everything else is in
pyproject.toml).

When a wheel is built (``make wheel``: ``pip wheel --no-build-isolation`` in an environment with
numba and a C compiler), the kernels are compiled for the ``generic`` target of the building
machine's architecture (any CPU of it: the wheel is installed on other computers) into the
wheel's ``mimucap/core/fusion/_compiled``, under the name :mod:`mimucap.core.fusion.aot` computes
from the very sources the wheel carries; the wheel is then a platform wheel
(``cp311-cp311-linux_x86_64``…), and its first start has nothing to compile. Where the build
environment has no numba (pip's default isolated build) or no C compiler, the wheel is pure
Python and says so; an installation of it compiles the kernels in the background at its first
start while the window is usable (:mod:`mimucap.session.kernel_preparation`). Editable installs
(``make install``) compile the host CPU's kernels after installing (:mod:`mimucap.core.fusion.warmup`).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.dist import Distribution

try:
    from setuptools.command.bdist_wheel import bdist_wheel  # setuptools >= 70.1
except ImportError:  # older setuptools: the wheel package's command
    from wheel.bdist_wheel import bdist_wheel

#: Inside the package: where the compiled module goes (mimucap.core.fusion.aot.COMPILED_DIR).
COMPILED = Path("mimucap", "core", "fusion", "_compiled")


class BuildWithKernels(build_py):
    """``build_py`` that also compiles the fusion kernels into the built package (module doc)."""

    def run(self) -> None:
        super().run()
        self.distribution.kernels_compiled = False
        if getattr(self, "editable_mode", False):
            return  # an editable install runs the sources in place; make install compiles there
        lib = Path(self.build_lib).resolve()
        # In a child interpreter reading the built package: the module's name is computed from
        # the files the wheel carries, and this process need not import numba.
        # numba's cache and Python's bytecode go elsewhere: they are not part of the wheel.
        with tempfile.TemporaryDirectory() as cache:
            done = subprocess.run(
                [sys.executable, "-m", "mimucap.core.fusion.aot_build", "--target", "generic",
                 "--out", str(lib / COMPILED)],
                env={**os.environ, "PYTHONPATH": str(lib), "NUMBA_CACHE_DIR": cache,
                     "PYTHONDONTWRITEBYTECODE": "1"},
                capture_output=True, text=True)
        if done.returncode == 0:
            self.distribution.kernels_compiled = True
            print(done.stdout.strip())
        else:
            reason = (done.stderr.strip().splitlines() or ["no output"])[-1]
            print(f"WARNING: the fusion kernels were not compiled ahead of time ({reason}); this wheel "
                  "is pure Python and compiles them at its first start (build it with "
                  "`make wheel` for a platform wheel)", file=sys.stderr)


class PlatformWheel(bdist_wheel):
    """A platform-specific wheel when the compiled kernels are in it, else a pure one."""

    def finalize_options(self) -> None:
        super().finalize_options()
        self.root_is_pure = True

    def run(self) -> None:
        self.run_command("build_py")
        self.root_is_pure = not getattr(self.distribution, "kernels_compiled", False)
        super().run()


class KernelDistribution(Distribution):
    """Has extension modules (installs into platlib) once the kernels are compiled."""

    kernels_compiled = False

    def has_ext_modules(self) -> bool:
        return self.kernels_compiled or super().has_ext_modules()


setup(distclass=KernelDistribution, cmdclass={"build_py": BuildWithKernels, "bdist_wheel": PlatformWheel})
