"""The package layout is the data flow: no lower stage imports a higher one.

Stages, lowest first (README "Layout"):
    base (errors, resources, report's tables) → models (the registry) → render/ → device/ → pipeline
    → verify/ → bench/, compare, report/, view/ → cli
and no import cycle between modules, in clshade and in the benchmarks package.
Every import in every module, at top level or inside a function, is checked.
"""
from __future__ import annotations

import pytest

import ast
from pathlib import Path

import clshade

PACKAGE = Path(clshade.__file__).resolve().parent

RANK = {
    "clshade": 0, "clshade.errors": 0, "clshade.resources": 0, "clshade.report.tables": 0,
    "clshade.models": 1, "clshade.models.lobe": 1, "clshade.models.model": 1, "clshade.models.glsl": 1,
    "clshade.models.brdf_file": 1, "clshade.models.registry": 1,
    "clshade.render": 2,
    "clshade.device": 3,
    "clshade.pipeline": 4,
    "clshade.verify": 5,
    "clshade.bench": 6, "clshade.compare": 6, "clshade.report": 6, "clshade.view": 6,
    "clshade.cli": 7, "clshade.__main__": 7,
}


def rank(module: str) -> int:
    parts = module.split(".")
    for n in range(len(parts), 0, -1):
        key = ".".join(parts[:n])
        if key in RANK:
            return RANK[key]
    raise KeyError(module)


def module_name(path: Path, package: Path = PACKAGE) -> str:
    rel = path.relative_to(package.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports(path: Path, me: str | None = None, submodules: bool = False,
            top: str = "clshade") -> list[tuple[int, str]]:
    """(line, module) of every import of the package `top` in the file; `me` is its dotted name. With `submodules`,
    `from pkg import name` also yields `pkg.name` (the caller keeps it where it is a module)."""
    me = me or module_name(path)
    tree = ast.parse(path.read_text(), str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = me.split(".")
                if path.name != "__init__.py":
                    base = base[:-1]
                base = base[: len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target == top:  # `from clshade import x`: x is the module
                found += [(node.lineno, f"{top}.{a.name}") for a in node.names if a.name != "__version__"]
            elif target.startswith(top + "."):
                found.append((node.lineno, target))
                if submodules:
                    found += [(node.lineno, f"{target}.{a.name}") for a in node.names]
        elif isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names if a.name.split(".")[0] == top]
    return found


@pytest.mark.text
def test_every_module_has_a_stage() -> None:
    for path in PACKAGE.rglob("*.py"):
        rank(module_name(path))


@pytest.mark.text
def test_no_upward_imports() -> None:
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        me = module_name(path)
        for line, target in imports(path):
            if rank(target) > rank(me):
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {me} (stage {rank(me)}) imports "
                           f"{target} (stage {rank(target)})")
    assert not bad, "upward imports:\n" + "\n".join(bad)


def test_checker_sees_upward_imports(tmp_path: Path) -> None:
    """The checker itself can fail: relative, absolute and function-local upward imports are seen."""
    fake = tmp_path / "probe.py"
    fake.write_text("from ..device import shade\nimport clshade.verify.reference\n"
                    "def f():\n    from clshade.bench.run import Bench\n")
    found = imports(fake, "clshade.render.probe")
    assert found == [(1, "clshade.device"), (2, "clshade.verify.reference"), (4, "clshade.bench.run")]
    assert all(rank(target) > rank("clshade.render.probe") for _, target in found)


def import_graph(package: Path = PACKAGE) -> dict[str, set[str]]:
    """Module → the modules of `package` it imports (top level or inside a function). An import of a
    package counts as an import of its __init__; `from pkg import mod` as one of `pkg.mod`."""
    names = {module_name(p, package) for p in package.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for path in sorted(package.rglob("*.py")):
        me = module_name(path, package)
        targets = set()
        for _, target in imports(path, me, submodules=True, top=package.name):
            while target not in names and "." in target:   # `clshade.x.y.Name` → the module clshade.x.y
                target = target.rsplit(".", 1)[0]
            if target in names and target != me:
                targets.add(target)
        graph[me] = targets
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


@pytest.mark.text
def test_no_import_cycles() -> None:
    """No two modules import each other, directly or through others, lazily or not."""
    found = cycles(import_graph())
    assert not found, "import cycles:\n" + "\n".join(" ↔ ".join(c) for c in found)


@pytest.mark.text
def test_no_import_cycles_in_benchmarks(checkout: Path) -> None:
    """The same for the benchmarks package (generators, publishing, mutation testing)."""
    found = cycles(import_graph(checkout / "benchmarks"))
    assert not found, "import cycles:\n" + "\n".join(" ↔ ".join(c) for c in found)


def test_cycle_checker_sees_a_lazy_cycle(tmp_path: Path) -> None:
    """An injected cycle through a function-local import fails the check; a one-way pair passes."""
    pkg = tmp_path / "clshade"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from clshade.sub import b\n")
    (pkg / "sub" / "b.py").write_text("import clshade.sub.c\n")
    (pkg / "sub" / "c.py").write_text("def f():\n    from clshade.a import g\n")
    (pkg / "d.py").write_text("from clshade import a\n")
    assert cycles(import_graph(pkg)) == [["clshade.a", "clshade.sub.b", "clshade.sub.c"]]
    (pkg / "sub" / "c.py").write_text("def f():\n    return 1\n")
    assert cycles(import_graph(pkg)) == []
