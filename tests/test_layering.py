"""The layering rule of ``docs/architecture.md``, made executable.

``cli → gui → session → (acquisition | io) → core``: arrows point down only (the commands stand
on top: ``mimucap gui`` starts the window); acquisition and io do not import each other; core imports no Qt, VTK, pyqtgraph, serial, socket, multiprocessing or
file-format libraries. Imports are read from the source with ``ast`` (including those inside
functions), so a lazy import cannot slip through.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE_DIR = Path(__file__).resolve().parents[1] / "app" / "mimucap"

#: Which MimuCap layers each layer may import.
ALLOWED_LAYERS = {
    "core": {"core"},
    "io": {"io", "core"},
    "acquisition": {"acquisition", "core"},
    "session": {"session", "acquisition", "io", "core"},
    "gui": {"gui", "session", "acquisition", "io", "core"},
    "cli": {"cli", "gui", "session", "acquisition", "io", "core"},
}

#: Third-party and standard modules a layer must never import.
FORBIDDEN_MODULES = {
    "core": {
        "PyQt5", "PySide2", "PySide6", "qtpy", "vtk", "vtkmodules", "pyqtgraph", "serial",
        "socket", "multiprocessing", "h5py", "subprocess", "threading",
    },
    "io": {"PyQt5", "PySide2", "PySide6", "qtpy", "vtk", "vtkmodules", "pyqtgraph"},
    "acquisition": {"PyQt5", "PySide2", "PySide6", "qtpy", "vtk", "vtkmodules", "pyqtgraph", "h5py"},
    "session": {"PyQt5", "PySide2", "PySide6", "qtpy", "vtk", "vtkmodules", "pyqtgraph"},
}


def imported_modules(path: Path) -> set[str]:
    """Absolute dotted names of every module imported by the file at ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package_parts = path.relative_to(PACKAGE_DIR.parent).with_suffix("").parts
    if package_parts[-1] == "__init__":
        package_parts = package_parts[:-1]
    else:
        package_parts = package_parts[:-1]
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package_parts[: len(package_parts) - node.level + 1]
                module = ".".join(base + ((node.module,) if node.module else ()))
            else:
                module = node.module or ""
            names.add(module)
            names.update(f"{module}.{alias.name}" for alias in node.names)
    return names


def layer_files(layer: str) -> list[Path]:
    return sorted((PACKAGE_DIR / layer).rglob("*.py"))


@pytest.mark.parametrize("layer", sorted(ALLOWED_LAYERS))
def test_layer_imports_only_lower_layers(layer: str) -> None:
    violations = []
    for path in layer_files(layer):
        for name in imported_modules(path):
            parts = name.split(".")
            if parts[0] != "mimucap" or len(parts) < 2:
                continue
            target = parts[1]
            if target in ALLOWED_LAYERS and target not in ALLOWED_LAYERS[layer]:
                violations.append(f"{path.relative_to(PACKAGE_DIR)} imports {name}")
            if target in {"cli", "__main__"} and layer != "cli":
                violations.append(f"{path.relative_to(PACKAGE_DIR)} imports {name}")
    assert not violations, "layering rule broken:\n" + "\n".join(violations)


@pytest.mark.parametrize("layer", sorted(FORBIDDEN_MODULES))
def test_layer_avoids_forbidden_modules(layer: str) -> None:
    violations = []
    for path in layer_files(layer):
        for name in imported_modules(path):
            if name.split(".")[0] in FORBIDDEN_MODULES[layer]:
                violations.append(f"{path.relative_to(PACKAGE_DIR)} imports {name}")
    assert not violations, "forbidden imports:\n" + "\n".join(violations)


def test_the_checker_sees_a_violation(tmp_path: Path) -> None:
    """The scanner must catch a core module importing Qt inside a function."""
    fake = PACKAGE_DIR / "core" / "_layering_probe.py"
    source = "def f():\n    from PyQt5 import QtWidgets\n    from ..gui import x\n"
    fake.write_text(source, encoding="utf-8")
    try:
        names = imported_modules(fake)
    finally:
        fake.unlink()
    assert "PyQt5" in names
    assert "mimucap.gui" in names


#: Calls that read or write files; none may appear in ``core`` (pure numerics).
FILE_CALLS = {"open", "read_text", "write_text", "read_bytes", "write_bytes", "load", "loads_file", "save",
              "savez", "savez_compressed", "loadtxt", "savetxt", "genfromtxt", "dump", "mkdir", "unlink",
              "resources_root", "resource_path", "tofile", "fromfile"}


def file_calls(path: Path) -> list[str]:
    """``name (line)`` of every call in the file at ``path`` whose function name is in FILE_CALLS."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            func = node.func
            name = func.id if isinstance(func, ast.Name) else func.attr if isinstance(func, ast.Attribute) else ""
            if name in FILE_CALLS:
                found.append(f"{name} (line {node.lineno})")
    return found


#: The only file access core may make, and why: the fusion kernels' compiled code, built at
#: installation and looked up by a fingerprint of their sources and of the CPU (the same kind of
#: thing as numba's on-disk cache, which the kernels use too), never data.
CORE_FILE_EXEMPTIONS = {
    "core/fusion/aot.py": {"open", "read_bytes"},   # /proc/cpuinfo, the kernels' sources
    "core/fusion/aot_build.py": {"mkdir", "unlink"},  # the compiled-module folder, older modules
    "core/fusion/warmup.py": {"unlink"},              # a module that disagrees with the JIT kernels
}


def test_core_reads_and_writes_no_files() -> None:
    offenders = {}
    for path in layer_files("core"):
        name = str(path.relative_to(PACKAGE_DIR))
        allowed = CORE_FILE_EXEMPTIONS.get(name, set())
        offenders[name] = [call for call in file_calls(path) if call.split(" ")[0] not in allowed]
    assert {k: v for k, v in offenders.items() if v} == {}
    imports = {str(p.relative_to(PACKAGE_DIR)): sorted(n for n in imported_modules(p) if n.startswith("mimucap.resources"))
               for p in layer_files("core")}
    assert {k: v for k, v in imports.items() if v} == {}


def test_the_file_checker_sees_a_file_read(tmp_path: Path) -> None:
    probe = tmp_path / "probe.py"
    probe.write_text("import json\n\ndef f(p):\n    return json.loads(p.read_text())\n", encoding="utf-8")
    assert file_calls(probe) == ["read_text (line 4)"]
