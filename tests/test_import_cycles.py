"""No import cycle, counting the imports inside functions.

A late import (inside a function) that dodges a cycle at load time still leaves the cycle: the
two modules still need each other, and which one may be read first depends on who imports
first. The graph is built from the source with ``ast`` over every module of ``app/mimucap``:
``import a.b`` and ``from a.b import c`` are edges to ``a.b`` and, when ``c`` is a module, to
``a.b.c``; a package that exports names lazily (a ``_EXPORTS`` table of name → submodule, read
by its ``__getattr__``) gives an edge to the submodule that defines the name imported. Cycles
are the strongly connected components of more than one module (Tarjan's algorithm).
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Mapping
from pathlib import Path

import pytest

APP_DIR = Path(__file__).resolve().parents[1] / "app"

#: The packages of ``mimucap`` whose modules must take part in no cycle: ``""`` is every module
#: of the application (core, io, acquisition, session, gui, cli).
CHECKED_PACKAGES = ("",)


def module_files(app_dir: Path, package: str = "mimucap") -> dict[str, Path]:
    """Dotted module name → source file, for every module of ``package`` under ``app_dir``."""
    found = {}
    for path in sorted((app_dir / package).rglob("*.py")):
        parts = path.relative_to(app_dir).with_suffix("").parts
        found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


def lazy_exports(tree: ast.Module) -> dict[str, str]:
    """A package's ``_EXPORTS = {"Name": "submodule", ...}`` (empty when it has none)."""
    for node in tree.body:
        if (isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "_EXPORTS" for t in node.targets)
                and isinstance(node.value, ast.Dict)):
            return {key.value: value.value for key, value in zip(node.value.keys, node.value.values)
                    if isinstance(key, ast.Constant) and isinstance(value, ast.Constant)}
    return {}


def import_graph(app_dir: Path = APP_DIR, package: str = "mimucap") -> dict[str, set[str]]:
    """Module → the modules of ``package`` it imports, anywhere in its source."""
    files = module_files(app_dir, package)
    trees = {name: ast.parse(path.read_text(encoding="utf-8"), filename=str(path)) for name, path in files.items()}
    exports = {name: lazy_exports(tree) for name, tree in trees.items() if files[name].name == "__init__.py"}

    def known(dotted: str) -> str | None:
        while dotted and dotted not in files:
            dotted = dotted.rpartition(".")[0]
        return dotted or None

    graph: dict[str, set[str]] = {name: set() for name in files}
    for name, tree in trees.items():
        is_package = files[name].name == "__init__.py"
        here = name.split(".") if is_package else name.split(".")[:-1]
        for node in ast.walk(tree):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(here[: len(here) - node.level + 1] + ([node.module] if node.module else []))
                targets.append(base)
                for alias in node.names:
                    lazy = exports.get(base, {}).get(alias.name)
                    targets.append(f"{base}.{lazy}" if lazy else f"{base}.{alias.name}")
            for target in targets:
                module = known(target) if target.split(".")[0] == package else None
                if module is not None and module != name:
                    graph[name].add(module)
    return graph


def cycles(graph: Mapping[str, Iterable[str]]) -> list[list[str]]:
    """The import cycles of ``graph``: every strongly connected component of more than one
    module, each sorted (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, successors = work[-1]
            advanced = False
            for successor in successors:
                if successor not in index:
                    index[successor] = low[successor] = counter
                    counter += 1
                    stack.append(successor)
                    on_stack.add(successor)
                    work.append((successor, iter(sorted(graph[successor]))))
                    advanced = True
                    break
                if successor in on_stack:
                    low[node] = min(low[node], index[successor])
            if advanced:
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return sorted(found)


def in_checked_packages(module: str, packages: Iterable[str] = CHECKED_PACKAGES) -> bool:
    return any(module == f"mimucap.{p}" or module.startswith(f"mimucap.{p}".rstrip(".") + ".") for p in packages)


def test_no_import_cycle_anywhere_in_the_application():
    found = [cycle for cycle in cycles(import_graph()) if any(in_checked_packages(m) for m in cycle)]
    assert found == [], "import cycles:\n" + "\n".join(" ↔ ".join(cycle) for cycle in found)


def _write(root: Path, files: Mapping[str, str]) -> None:
    for relative, source in files.items():
        path = root / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(source, encoding="utf-8")


def test_the_checker_sees_a_cycle_closed_by_an_import_inside_a_function(tmp_path):
    _write(tmp_path, {
        "mimucap/__init__.py": "",
        "mimucap/core/__init__.py": "",
        "mimucap/core/first.py": "from mimucap.core import second\n",
        "mimucap/core/second.py": "def late():\n    from .first import something\n",
        "mimucap/core/third.py": "import mimucap.core.first\n",
    })
    assert cycles(import_graph(tmp_path)) == [["mimucap.core.first", "mimucap.core.second"]]


def test_the_checker_follows_a_lazy_export_to_the_submodule_defining_the_name(tmp_path):
    _write(tmp_path, {
        "mimucap/__init__.py": "",
        "mimucap/io/__init__.py": "",
        "mimucap/io/lazy/__init__.py": '_EXPORTS = {"Reader": "reader"}\n',
        "mimucap/io/lazy/reader.py": "def f():\n    from mimucap.io import user\n",
        "mimucap/io/user.py": "from mimucap.io.lazy import Reader\n",
    })
    assert cycles(import_graph(tmp_path)) == [["mimucap.io.lazy.reader", "mimucap.io.user"]]


@pytest.mark.parametrize("packages, expected", [(("core", "io"), False), (CHECKED_PACKAGES, True)])
def test_the_checked_packages_are_the_whole_application(packages, expected):
    assert in_checked_packages("mimucap.session.live.live_session", packages) is expected
    assert in_checked_packages("mimucap.gui.main_window", packages) is expected
    assert in_checked_packages("mimucap.core.pipeline.chain", packages)
