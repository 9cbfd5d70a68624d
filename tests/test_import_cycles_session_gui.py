"""No import cycle among the modules of ``mimucap.session`` and ``mimucap.gui``.

Imports are read from the source with ``ast``, those inside functions included: a late import
that dodges a cycle at start-up still leaves the two modules depending on each other, which is
the cycle this test refuses. A cycle is a strongly connected group of modules (Tarjan's
algorithm); the test names each group found.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parents[1] / "app" / "mimucap"
CHECKED = ("mimucap.session", "mimucap.gui")


def module_files() -> dict[str, Path]:
    """Dotted module name → file, for every module of the package (``__init__`` names its package)."""
    found = {}
    for path in PACKAGE_DIR.rglob("*.py"):
        parts = path.relative_to(PACKAGE_DIR.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        found[".".join(parts)] = path
    return found


def imports_of(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The modules of ``modules`` that the file at ``path`` (module ``name``) imports: for
    ``from a.b import c``, ``a.b.c`` when it is a module, else ``a.b``."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    targets = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            candidates = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package[: len(package) - node.level + 1] + ([base] if base else []))
            candidates = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base for alias in node.names]
        else:
            continue
        for candidate in candidates:
            while candidate and candidate not in modules:
                candidate = candidate.rpartition(".")[0]
            if candidate and candidate != name:
                targets.add(candidate)
    return targets


def import_cycles(prefixes: tuple[str, ...]) -> list[list[str]]:
    """The groups of modules under ``prefixes`` that import each other (directly or through
    others under ``prefixes``), each sorted; empty when there is none."""
    modules = module_files()
    inside = {name for name in modules if name.startswith(prefixes)}
    graph = {name: sorted(imports_of(name, modules[name], modules) & inside) for name in sorted(inside)}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups: list[list[str]] = []

    def visit(node: str) -> None:  # Tarjan's strongly connected components
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for successor in graph[node]:
            if successor not in index:
                visit(successor)
                low[node] = min(low[node], low[successor])
            elif successor in on_stack:
                low[node] = min(low[node], index[successor])
        if low[node] == index[node]:
            group = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                group.append(member)
                if member == node:
                    break
            if len(group) > 1:
                groups.append(sorted(group))

    for node in graph:
        if node not in index:
            visit(node)
    return groups


def test_session_and_gui_have_no_import_cycle():
    cycles = import_cycles(CHECKED)
    assert not cycles, "import cycles: " + "; ".join(" ↔ ".join(group) for group in cycles)


def test_the_check_finds_a_cycle_made_by_a_late_import(tmp_path, monkeypatch):
    """Two modules that import each other, one of them inside a function, form a cycle."""
    package = tmp_path / "mimucap" / "session"
    package.mkdir(parents=True)
    (tmp_path / "mimucap" / "__init__.py").write_text("")
    (package / "__init__.py").write_text("")
    (package / "first.py").write_text("from mimucap.session.second import thing\n")
    (package / "second.py").write_text("def thing():\n    from mimucap.session import first\n")
    (package / "third.py").write_text("from mimucap.session import first\n")
    monkeypatch.setattr(sys.modules[__name__], "PACKAGE_DIR", tmp_path / "mimucap")
    assert import_cycles(CHECKED) == [["mimucap.session.first", "mimucap.session.second"]]
