"""The bundle's build helpers (packaging/bundle.py), runtime hook and Linux install script,
checked without PyInstaller or a built bundle (``make bundle-check`` tests the bundle itself)."""

from __future__ import annotations

import importlib.util
import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PACKAGING = REPO / "packaging"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, PACKAGING / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


bundle = _load("bundle")


@pytest.mark.parametrize("name", [
    "PyQt5/Qt5/plugins/platforms/libqxcb.so",
    "PyQt5/Qt5/plugins/platforms/libqoffscreen.so",
    "PyQt5/Qt5/plugins/platforms/libqminimal.so",
    "PyQt5/Qt5/lib/libQt5Widgets.so.5",
    "PyQt5/Qt5/lib/libQt5Gui.so.5",
    "PyQt5/Qt5/lib/libQt5Svg.so.5",
    "PyQt5/Qt5/lib/libQt5XcbQpa.so.5",
    "PyQt5/Qt5/plugins/imageformats/libqsvg.so",
    "vtkmodules/libvtkRenderingOpenGL2-9.3.so",
    "mimucap/_resources/icons/mimucap.svg",
])
def test_what_the_program_runs_ships(name):
    entry = (name, "/somewhere/" + name, "BINARY")
    assert bundle.shipped([entry]) == [entry]
    assert bundle.shipped([(name.replace("/", "\\"), "x", "BINARY")])  # Windows separators


@pytest.mark.parametrize("name", [
    "PyQt5/Qt5/translations/qtbase_de.qm",
    "PyQt5/Qt5/lib/libQt5Qml.so.5",
    "PyQt5/Qt5/lib/libQt5Quick.so.5",
    "PyQt5/Qt5/lib/libQt5Network.so.5",
    "PyQt5/Qt5/lib/libQt5WaylandClient.so.5",
    "PyQt5/Qt5/plugins/platforms/libqwayland-egl.so",
    "PyQt5/Qt5/plugins/platforms/libqeglfs.so",
    "PyQt5/Qt5/plugins/platforms/libqwebgl.so",
    "PyQt5/Qt5/plugins/platforms/libqvnc.so",
    "PyQt5/Qt5/plugins/wayland-shell-integration/libxdg-shell.so",
    "PyQt5/Qt5/plugins/egldeviceintegrations/libqeglfs-kms-integration.so",
])
def test_what_nothing_uses_stays_out(name):
    assert bundle.shipped([(name, "x", "BINARY")]) == []


def _fake_repo(root: Path) -> Path:
    for item in bundle.SOURCE_INPUTS:
        path = root / item
        if Path(item).suffix:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(f"# {item}\n", encoding="utf-8")
        else:
            (path / "sub").mkdir(parents=True)
            (path / "sub" / "module.py").write_text("x = 1\n", encoding="utf-8")
    return root


def test_the_sources_fingerprint_follows_the_sources_and_nothing_else(tmp_path):
    repo = _fake_repo(tmp_path)
    first = bundle.sources_fingerprint(repo)
    # caches and machine-specific compiled kernels are not sources
    for ignored in ("__pycache__", "_compiled"):
        (repo / "app" / "mimucap" / ignored).mkdir()
        (repo / "app" / "mimucap" / ignored / "blob.so").write_bytes(b"\0")
    (repo / "app" / "mimucap" / "sub" / "module.pyc").write_bytes(b"\0")
    assert bundle.sources_fingerprint(repo) == first
    (repo / "app" / "mimucap" / "sub" / "module.py").write_text("x = 2\n", encoding="utf-8")
    changed = bundle.sources_fingerprint(repo)
    assert changed != first
    (repo / "app" / "mimucap" / "sub" / "module.py").rename(repo / "app" / "mimucap" / "sub" / "renamed.py")
    assert bundle.sources_fingerprint(repo) not in (first, changed)  # names count, not only contents
    (repo / "packaging" / "mimucap.spec").write_text("# edited\n", encoding="utf-8")
    assert bundle.sources_fingerprint(repo) != changed


def test_a_bundle_without_fingerprints_is_never_taken_for_a_current_one(tmp_path):
    assert bundle.read_fingerprints(tmp_path) == {}
    (tmp_path / bundle.FINGERPRINT_FILE).parent.mkdir()
    (tmp_path / bundle.FINGERPRINT_FILE).write_text("sources abc\nenvironment def\n", encoding="utf-8")
    assert bundle.read_fingerprints(tmp_path) == {"sources": "abc", "environment": "def"}


def test_sizes_are_counted_per_component_and_links_once(tmp_path):
    internal = tmp_path / "_internal"
    (internal / "vtkmodules").mkdir(parents=True)
    (internal / "vtkmodules" / "lib.so").write_bytes(b"\0" * 3000)
    (internal / "libpython.so").write_bytes(b"\0" * 200)
    (internal / "linked.so").symlink_to(internal / "libpython.so")
    (tmp_path / "mimucap").write_bytes(b"\0" * 50)
    assert bundle.folder_size(tmp_path) == 3250
    assert bundle.component_sizes(tmp_path) == [
        ("vtkmodules", 3000), ("(other libraries and files)", 200),
        ("(executable with the Python modules, install script)", 50)]


def _hooked(code: str, **env: str) -> subprocess.CompletedProcess:
    """``code`` run after the bundle's runtime hook, in a fresh interpreter."""
    script = (PACKAGING / "pyi_rth_mimucap.py").read_text(encoding="utf-8") + "\n" + code
    environment = {k: v for k, v in os.environ.items() if k != "QT_QPA_PLATFORM"} | env
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=environment,
                          timeout=60)


def test_the_bundle_refuses_numba_with_a_message_saying_why():
    done = _hooked("import numba")
    assert done.returncode == 1
    assert "ImportError: cannot import numba: this MimuCap bundle runs its orientation filter from the " \
           "kernels compiled ahead of time" in done.stderr
    assert _hooked("import llvmlite.binding").returncode == 1
    assert _hooked("import json").returncode == 0  # everything else imports as usual


def test_the_bundle_asks_qt_for_x11_where_wayland_was_asked_for():
    show = "import os; print(os.environ.get('QT_QPA_PLATFORM'))"
    assert _hooked(show, QT_QPA_PLATFORM="wayland").stdout.strip() == "xcb"
    assert _hooked(show, QT_QPA_PLATFORM="offscreen").stdout.strip() == "offscreen"
    assert _hooked(show).stdout.strip() == "None"


def _fake_bundle(folder: Path) -> Path:
    """A bundle folder as ``make bundle`` lays it out, with a stand-in program."""
    icons = folder / "_internal" / "mimucap" / "_resources" / "icons"
    icons.mkdir(parents=True)
    for name in ("mimucap.svg", "mimucap.png"):
        shutil.copy(REPO / "resources" / "icons" / name, icons / name)
    shutil.copy(PACKAGING / "mimucap.desktop", folder / "_internal" / "mimucap.desktop")
    shutil.copy(PACKAGING / "install-linux.sh", folder / "install.sh")
    program = folder / "mimucap"
    program.write_text("#!/bin/sh\n", encoding="utf-8")
    program.chmod(program.stat().st_mode | stat.S_IXUSR)
    return folder


def _install(folder: Path, data: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "XDG_DATA_HOME": str(data), "PATH": "/usr/bin:/bin"}
    return subprocess.run(["sh", str(folder / "install.sh"), *args], capture_output=True, text=True, env=env,
                          timeout=60)


def test_install_puts_the_entry_and_icon_in_the_menu_and_uninstall_removes_them(tmp_path):
    folder = _fake_bundle(tmp_path / "Motion capture" / "mimucap")  # a path with a space
    data = tmp_path / "share"
    done = _install(folder, data)
    assert done.returncode == 0, done.stderr
    entry = (data / "applications" / "mimucap.desktop").read_text(encoding="utf-8").splitlines()
    assert f'Exec="{folder / "mimucap"}" gui %f' in entry
    assert f"TryExec={folder / 'mimucap'}" in entry
    assert "Icon=mimucap" in entry and "Type=Application" in entry
    svg = data / "icons" / "hicolor" / "scalable" / "apps" / "mimucap.svg"
    png = data / "icons" / "hicolor" / "256x256" / "apps" / "mimucap.png"
    assert svg.read_bytes() == (REPO / "resources" / "icons" / "mimucap.svg").read_bytes()
    assert png.read_bytes() == (REPO / "resources" / "icons" / "mimucap.png").read_bytes()
    done = _install(folder, data, "--uninstall")
    assert done.returncode == 0, done.stderr
    assert not (data / "applications" / "mimucap.desktop").exists() and not svg.exists() and not png.exists()


def test_install_outside_a_bundle_folder_says_where_to_run_it(tmp_path):
    shutil.copy(PACKAGING / "install-linux.sh", tmp_path / "install.sh")
    done = _install(tmp_path, tmp_path / "share")
    assert done.returncode == 1
    assert "run the install.sh inside the MimuCap bundle folder" in done.stderr
    assert not (tmp_path / "share").exists()


@pytest.mark.parametrize(("name", "stripped"), [
    ("vtkmodules/libvtkCommonCore-9.3.so", True),
    ("PyQt5/Qt5/lib/libQt5Gui.so.5", True),
    ("libpython3.11.so.1.0", True),
    ("numpy.libs/libscipy_openblas64_-32a4b2a6.so", False),  # patched by auditwheel: must stay as it is
    ("scipy/linalg/_flapack.cpython-311-x86_64-linux-gnu.so", False),
    ("h5py.libs/libhdf5-9e18f0c6.so.320.0.0", False),
    ("somewhere/libpython3.11.so.1.0", False),
])
def test_only_libraries_that_load_stripped_are_stripped(name, stripped):
    assert bundle.is_stripped(name) is stripped
