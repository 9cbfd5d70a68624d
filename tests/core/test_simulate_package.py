"""The simulator is one package, ``mimucap.core.simulate``, whose modules import each other
without a cycle (imports inside functions count: a late import that dodges a cycle at run
time still leaves the cycle), and the flat ``core/simulate_*.py`` modules it replaced are gone."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parents[2] / "app" / "mimucap"


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE_DIR.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(path: Path, known: set[str]) -> set[str]:
    """The MimuCap modules (of ``known``) that the file at ``path`` imports, anywhere in it."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = module_name(path) if path.name == "__init__.py" else module_name(path).rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(tree):
        candidates: list[str] = []
        if isinstance(node, ast.Import):
            candidates = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            candidates = [module] + [f"{module}.{alias.name}" for alias in node.names]
        for name in candidates:
            # "a.b.c" imports module a.b.c if it exists, else the package a.b (c is a name in it).
            while name and name not in known:
                name = name.rpartition(".")[0]
            if name:
                found.add(name)
    return found


def import_graph() -> dict[str, set[str]]:
    paths = sorted(PACKAGE_DIR.rglob("*.py"))
    known = {module_name(p) for p in paths}
    return {module_name(p): imports_of(p, known) - {module_name(p)} for p in paths}


def cycles_through(graph: dict[str, set[str]], prefix: str) -> list[list[str]]:
    """Every import cycle (as a path back to its start) that passes a module named ``prefix...``."""
    found = []
    for start in sorted(m for m in graph if m.startswith(prefix)):
        stack = [(start, [start])]
        seen: set[str] = set()
        while stack:
            node, path = stack.pop()
            for target in graph.get(node, ()):
                if target == start:
                    found.append(path + [start])
                elif target not in seen:
                    seen.add(target)
                    stack.append((target, path + [target]))
    return found


def test_no_import_cycle_passes_through_the_simulator() -> None:
    graph = import_graph()
    assert any(m.startswith("mimucap.core.simulate.") for m in graph)
    assert cycles_through(graph, "mimucap.core.simulate") == []


def test_the_cycle_finder_sees_a_cycle() -> None:
    """The check above can fail: a late import back into the package is a cycle."""
    graph = import_graph()
    graph["mimucap.core.simulate.names"] = graph["mimucap.core.simulate.names"] | {"mimucap.core.simulate.suit"}
    cycles = cycles_through(graph, "mimucap.core.simulate.names")
    assert cycles and cycles[0][0] == cycles[0][-1] == "mimucap.core.simulate.names"


def test_the_flat_simulator_modules_are_gone() -> None:
    core = PACKAGE_DIR / "core"
    assert sorted(p.name for p in core.glob("simulate*.py")) == []
    assert (core / "simulate" / "__init__.py").is_file()
    package_init = ast.parse((core / "simulate" / "__init__.py").read_text(encoding="utf-8"))
    # The package's own module imports nothing: importing its numpy-free names stays cheap.
    assert not [n for n in ast.walk(package_init) if isinstance(n, (ast.Import, ast.ImportFrom))]
