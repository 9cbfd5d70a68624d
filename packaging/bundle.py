"""Build the desktop bundle (``dist/mimucap``) when what it is made from has changed.

``python packaging/bundle.py build [--dist DIR] [--work DIR]`` runs PyInstaller on
``packaging/mimucap.spec`` with the interpreter it is started with (``make bundle`` uses the
bundle's own environment, ``build/bundle-venv``), unless the bundle in ``DIST/mimucap`` was built
from the same inputs: the same files (:func:`sources_fingerprint`: ``app/mimucap``,
``resources``, the spec and its helpers, ``pyproject.toml``) and the same installed packages
(:func:`environment_fingerprint`). The two fingerprints are written into the bundle
(:data:`FINGERPRINT_FILE`) after a successful build, so a failed or interrupted build is never
taken for a current one, and the smoke test (``tests/packaging/test_bundle.py``) can tell a
bundle of older sources. ``python packaging/bundle.py sizes DIR`` prints a bundle's size per
component, largest first.

The spec imports this module for what the bundle leaves out (:data:`EXCLUDED_PACKAGES`,
:func:`shipped`) and for the fusion kernels compiled ahead of time (:func:`kernel_datas`).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SPEC = REPO / "packaging" / "mimucap.spec"
#: Inside the bundle folder: the fingerprints of the sources and of the build environment.
FINGERPRINT_FILE = Path("_internal") / "mimucap-build-inputs.txt"
#: Files of the bundle folder's top level besides the executable, copied from packaging/.
TOP_LEVEL_FILES = {"install-linux.sh": "install.sh"}
#: Files and folders the sources' fingerprint covers (folders recursively).
SOURCE_INPUTS = ("app/mimucap", "resources", "packaging/mimucap.spec", "packaging/bundle.py",
                 "packaging/pyi_rth_mimucap.py", "packaging/install-linux.sh", "packaging/mimucap.desktop",
                 "packaging/bundle-constraints.txt", "pyproject.toml")
#: Never part of the sources: caches, and kernels compiled for this machine (the spec builds its own).
IGNORED_PARTS = {"__pycache__", "_compiled", "_resources"}

#: Python packages the bundle never ships: numba and its LLVM (the bundle runs the kernels
#: compiled ahead of time), the benchmarks' peer libraries and the test tools (optional in
#: ``mimucap bench``, never imported by the application), other Qt bindings and GUI toolkits,
#: build tools, and the Qt modules nothing imports (pyqtgraph's optional OpenGL widget among them).
EXCLUDED_PACKAGES = (
    "numba", "llvmlite",
    "vqf", "imufusion", "ahrs",
    "pytest", "_pytest", "pytestqt", "hypothesis", "opensim", "c3d", "bvhio",
    "tkinter", "_tkinter", "PySide2", "PySide6", "PyQt6", "matplotlib", "PIL", "IPython",
    "setuptools", "pkg_resources", "_distutils_hack", "pip",
    "PyQt5.QtOpenGL", "PyQt5.QtNetwork", "PyQt5.QtQml", "PyQt5.QtQuick", "PyQt5.QtWebSockets",
)

#: Files of the Qt installation the bundle leaves out (matched against paths inside the bundle,
#: with forward slashes): Qt's own translations (the program speaks English), the QML/Quick,
#: network, OpenGL-widget, Wayland and EGLFS libraries that only the plugins below need, and the
#: platforms MimuCap cannot draw its 3D view on: VTK's render window needs X11 on Linux (XWayland
#: under Wayland desktops), so of Linux's platforms the bundle keeps ``xcb``, and ``offscreen``
#: and ``minimal`` for windowless work (the PDF report).
QT_LEFT_OUT = re.compile(
    r"/translations/"
    r"|(^|/)(lib)?Qt5?(Qml|Quick|WebSockets|Network|EglFSDeviceIntegration|WaylandClient|OpenGL)[^/]*$"
    r"|/plugins/(generic|wayland-[^/]*|egldeviceintegrations)/"
    r"|/plugins/platforms/(lib)?q(eglfs|linuxfb|vnc|webgl|wayland[^/]*|minimalegl)\.[^/]*$",
    re.IGNORECASE)


def shipped(toc):
    """The entries of a PyInstaller table of contents (``(name in bundle, source, kind)``) that
    the bundle keeps (all but :data:`QT_LEFT_OUT`)."""
    return [entry for entry in toc if not QT_LEFT_OUT.search(entry[0].replace("\\", "/"))]


#: Bundle folders whose libraries are stripped of their symbol tables on Linux (a fifth of
#: VTK's size, an eighth of Qt's). Not the others: the libraries that auditwheel vendored and
#: patched (``numpy.libs``, ``scipy.libs``…, and the extension modules pointing at them) no
#: longer load once stripped ("ELF load command address/offset not page-aligned").
STRIPPED_FOLDERS = ("vtkmodules/", "PyQt5/")
#: Libraries of the bundle's top level stripped too: Python's own, which a Python built from
#: source (pyenv) leaves with its symbols (23 MB instead of 6).
STRIPPED_LIBRARIES = ("libpython",)


def is_stripped(name: str) -> bool:
    """Whether the library ``name`` (its path inside the bundle) is stripped on Linux."""
    name = name.replace("\\", "/")
    return name.startswith(STRIPPED_FOLDERS) or ("/" not in name and name.startswith(STRIPPED_LIBRARIES))


def stripped(toc, folder: Path):
    """``toc`` (binaries) with the libraries :func:`is_stripped` names replaced by stripped
    copies made in ``folder`` (kept there, outside the folder PyInstaller cleans: a rebuild
    strips only what changed)."""
    result = []
    for name, source, kind in toc:
        target = folder / name
        if is_stripped(name) and not Path(source).is_symlink():
            if not target.is_file() or target.stat().st_mtime < Path(source).stat().st_mtime:
                target.parent.mkdir(parents=True, exist_ok=True)
                partial = target.with_name(target.name + ".partial")
                shutil.copyfile(source, partial)
                subprocess.run(["strip", str(partial)], check=True)
                partial.replace(target)
            source = str(target)
        result.append((name, source, kind))
    return result


def kernel_datas(directory: Path) -> list[tuple[str, str]]:
    """The fusion kernels compiled ahead of time for the ``generic`` target of this machine's
    architecture (built into ``directory`` unless a module of the current sources is there),
    with the kernel sources :mod:`mimucap.core.fusion.aot` computes the module's name from: the
    spec's ``datas`` entries. ``SystemExit`` when they cannot be compiled (no C compiler): a
    bundle without them would have no kernels at all."""
    sys.path.insert(0, str(REPO / "app"))
    from mimucap.core.fusion import aot
    from mimucap.core.fusion.aot_build import build, target_id

    path = aot.module_path(target_id("generic"), directory)
    if path.is_file():
        print(f"fusion kernels compiled ahead of time: {path.name} is current")
    else:
        started = time.perf_counter()
        try:
            path = build("generic", directory)
        except (ImportError, OSError, ValueError) as error:
            raise SystemExit(f"the fusion kernels could not be compiled ahead of time ({error}); the bundle "
                             "has no numba to compile them at run time: install a C compiler and numba "
                             "in the build environment (docs/packaging.md)") from error
        print(f"fusion kernels compiled ahead of time (generic) in {time.perf_counter() - started:.0f} s")
    return [(str(path), "mimucap/core/fusion/_compiled")] + [
        (str(aot.PACKAGE_DIR / name), "mimucap/core/fusion") for name in aot.KERNEL_SOURCES]


def _files(root: Path):
    if root.is_file():
        yield root
        return
    for folder, folders, names in os.walk(root):
        folders[:] = sorted(f for f in folders if f not in IGNORED_PARTS and not f.endswith(".egg-info"))
        for name in sorted(names):
            if not name.endswith((".pyc", ".pyo")):
                yield Path(folder) / name


def sources_fingerprint(repo: Path = REPO) -> str:
    """SHA-256 of the names and contents of every file the bundle is built from
    (:data:`SOURCE_INPUTS`, without caches and compiled kernels)."""
    digest = hashlib.sha256()
    for item in SOURCE_INPUTS:
        for path in _files(repo / item):
            digest.update(path.relative_to(repo).as_posix().encode() + b"\0")
            digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


def environment_fingerprint() -> str:
    """SHA-256 of this interpreter's version and platform and of every installed distribution
    with its version (the packages the bundle takes its libraries from)."""
    from importlib import metadata

    packages = sorted({f"{d.metadata['Name']}=={d.version}".lower() for d in metadata.distributions()})
    text = "\n".join([sys.version, sys.platform, *packages])
    return hashlib.sha256(text.encode()).hexdigest()


def read_fingerprints(bundle: Path) -> dict[str, str]:
    """The fingerprints written into ``bundle`` (a bundle folder) at its build; empty if none."""
    try:
        lines = (bundle / FINGERPRINT_FILE).read_text(encoding="utf-8").splitlines()
    except OSError:
        return {}
    return dict(line.split(" ", 1) for line in lines if " " in line)


def executable(bundle: Path) -> Path:
    """The program in a bundle folder (``mimucap``, ``mimucap.exe`` on Windows)."""
    return bundle / ("mimucap.exe" if sys.platform == "win32" else "mimucap")


def build(dist: Path, work: Path) -> Path:
    """Build ``dist/mimucap`` unless it is current (module doc); returns the bundle folder."""
    bundle = dist / "mimucap"
    wanted = {"sources": sources_fingerprint(), "environment": environment_fingerprint()}
    if executable(bundle).is_file() and read_fingerprints(bundle) == wanted:
        print(f"{bundle} is up to date (same sources and build environment)")
        return bundle
    started = time.perf_counter()
    # The sources are taken from this tree, not from an installed mimucap: the spec's
    # collect_submodules imports them in a child process, which inherits this path.
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO / "app"), os.environ.get("PYTHONPATH", "")]))
    # --clean: PyInstaller's own cache decides by modification times whether to compile a module
    # again, and takes a module edited while an earlier build read it for a current one.
    subprocess.run([sys.executable, "-m", "PyInstaller", str(SPEC), "--noconfirm", "--clean", "--log-level", "WARN",
                    "--distpath", str(dist), "--workpath", str(work)], check=True, env=env)
    if sources_fingerprint() != wanted["sources"]:
        raise SystemExit(f"the sources changed while {bundle} was built: it is not marked current; "
                         "run the build again")
    for source, name in TOP_LEVEL_FILES.items():
        shutil.copy2(REPO / "packaging" / source, bundle / name)
    (bundle / FINGERPRINT_FILE).write_text("".join(f"{k} {v}\n" for k, v in wanted.items()), encoding="utf-8")
    print(f"built {bundle} in {time.perf_counter() - started:.0f} s: {folder_size(bundle) / 1e6:.0f} MB")
    return bundle


def folder_size(folder: Path) -> int:
    """Bytes of the files under ``folder`` (links not followed: each file counted once)."""
    total = 0
    for root, _folders, names in os.walk(folder):
        for name in names:
            path = Path(root) / name
            if not path.is_symlink():
                total += path.stat().st_size
    return total


def component_sizes(bundle: Path) -> list[tuple[str, int]]:
    """``(component, bytes)`` of a bundle, largest first: each folder of ``_internal`` (a
    package) and the rest of its files together."""
    internal = bundle / "_internal"
    sizes: dict[str, int] = {}
    for item in internal.iterdir():
        if item.is_symlink():
            continue
        key = item.name if item.is_dir() else "(other libraries and files)"
        sizes[key] = sizes.get(key, 0) + (folder_size(item) if item.is_dir() else item.stat().st_size)
    outside = folder_size(bundle) - folder_size(internal)
    sizes["(executable with the Python modules, install script)"] = outside
    return sorted(sizes.items(), key=lambda kv: -kv[1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Build the MimuCap desktop bundle, or print its sizes.")
    commands = parser.add_subparsers(dest="command", required=True)
    make = commands.add_parser("build", help="build dist/mimucap unless it is current")
    make.add_argument("--dist", type=Path, default=REPO / "dist")
    make.add_argument("--work", type=Path, default=REPO / "build" / "pyinstaller")
    sizes = commands.add_parser("sizes", help="a bundle's size per component")
    sizes.add_argument("bundle", type=Path, nargs="?", default=REPO / "dist" / "mimucap")
    args = parser.parse_args(argv)
    if args.command == "build":
        build(args.dist, args.work)
        return 0
    total = folder_size(args.bundle)
    print(f"{args.bundle}: {total / 1e6:.0f} MB")
    for name, size in component_sizes(args.bundle):
        if size >= 1e6:
            print(f"  {size / 1e6:6.1f} MB  {name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
