"""The house rules a newcomer relies on, read from the code's own imports and definitions: no import cycles, no
private names used across modules, one direction between I/O and physics, functions of one screen, and a driver
that talks to the parts of a run through their interface (no attribute probing)."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "ngs_geomech"
PHYSICS = {"heat", "stefan", "mechanics", "contact", "dynamics", "coupling", "adapt", "run", "uncertainty",
           "verification"}
MAX_FUNCTION_LINES = 80


def modules() -> dict[str, ast.Module]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        out[name] = ast.parse(path.read_text(), filename=str(path))
    return out


def imports(name: str, tree: ast.Module, known: set[str]) -> set[str]:
    """The package modules ``name`` imports (a name imported from a package counts as its submodule when there is
    one)."""
    package = name if (PACKAGE.parent / name.replace(".", "/") / "__init__.py").exists() else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                out.add(sub if sub in known else target)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return {m for m in out if m in known and m != name}


def test_no_import_cycles():
    mods = modules()
    graph = {n: imports(n, t, set(mods)) for n, t in mods.items()}
    index, low, stack, on, cycles = {}, {}, [], set(), []

    def visit(v):                                     # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    assert cycles == []


def test_no_private_names_across_modules():
    found = []
    for name, tree in modules().items():
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                found += [f"{name}: {a.name}" for a in node.names if a.name.startswith("_") and a.name != "__future__"
                          and not a.name.startswith("__")]
    assert found == []


def test_io_imports_no_physics():
    mods = modules()
    bad = [(n, m) for n, t in mods.items() if n.startswith("ngs_geomech.io.")
           for m in imports(n, t, set(mods)) if m.count(".") and m.split(".")[1] in PHYSICS]
    assert bad == []


def test_functions_fit_one_screen():
    long = []
    for name, tree in modules().items():
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1
                if lines > MAX_FUNCTION_LINES:
                    long.append(f"{name}.{node.name}: {lines} lines")
    assert long == []


def test_the_driver_does_not_probe_its_parts():
    """The run's driver, output and checkpoints speak the parts' and mesh policies' interfaces: no attribute
    probing, and only the model that builds the parts knows their classes."""
    mods = modules()
    parts = {"ngs_geomech.heat.run", "ngs_geomech.stefan.problem", "ngs_geomech.mechanics.run",
             "ngs_geomech.dynamics.problem", "ngs_geomech.coupling.run"}
    found = []
    for name, tree in mods.items():
        if not (name.startswith("ngs_geomech.run") or name == "ngs_geomech.parts"):
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and \
                    node.func.id in ("hasattr", "getattr"):
                found.append(f"{name}:{node.lineno} {node.func.id}")
        if name != "ngs_geomech.run.model":
            found += [f"{name} imports {m}" for m in imports(name, tree, set(mods)) & parts]
    assert found == []
