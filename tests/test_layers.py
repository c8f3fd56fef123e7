"""The package's imports go one way: no import circle, and no module imports a higher layer.

Every import counts, also those inside functions (a deferred import hides a circle, it does not
remove it). Imports are read from the source (AST), nothing is executed.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "flightlog_fd"

#: Lowest first. A module may import its own layer (no circle, tested apart) or any below it. The
#: longest matching name wins ("training.experiment" before "training"); a module that matches no
#: entry fails the test: place it.
LAYERS: list[tuple[str, ...]] = [
    ("errors", "util", "filters", "flight", "frames", "flights"),  # the Flight and its helpers (flights: one per take-off)
    ("logs", "sim", "", "vehicle"),                               # what makes a Flight ("": the package's __init__); vehicle: logs pulled over MAVLink
    ("streams",),                                                 # cleaned streams, thrust proxy, airborne grid
    ("prepared",),                                                # one prepared flight per diagnosis
    ("windows", "hover", "phases", "stopped", "timeline", "model"),  # views of a prepared flight, the model
    ("checks", "analyzers"),                                      # per-motor estimation and findings
    ("decision", "profile", "advice", "cause"),                   # the verdict (its cause); the calibration profile; advice
    ("diagnose",),                                                # one flight, end to end
    ("training",),                                                # model training and adaptation
    ("calibration", "batch", "store", "database", "drift", "history", "report", "watch"),
    ("serve", "cli", "training.experiment", "training.build_default", "training.variants"),  # entry points
]


def _modules() -> dict[str, tuple[Path, bool]]:
    """{dotted name without the package prefix: (file, is a package __init__)} of flightlog_fd and
    of training/ (installed as flightlog_fd.training)."""
    out = {}
    for base, prefix in ((ROOT / PACKAGE, ""), (ROOT / "training", "training")):
        for p in base.rglob("*.py"):
            parts = list(p.relative_to(base).with_suffix("").parts)
            is_pkg = parts[-1] == "__init__"
            if is_pkg:
                parts = parts[:-1]
            name = ".".join(([prefix] if prefix else []) + parts)
            out[name] = (p, is_pkg)
    return out


def _imports(name: str, path: Path, is_pkg: bool, modules: dict) -> set[str]:
    """The package modules ``name`` imports anywhere in its source: each named module, and the
    packages above it (importing a.b runs a's __init__), except the importer's own packages."""
    own = {".".join(name.split(".")[:k]) for k in range(len(name.split(".")))}
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                here = [PACKAGE] + (name.split(".") if name else [])
                if not is_pkg:
                    here = here[:-1]
                here = here[:len(here) - (node.level - 1)]
                mod = ".".join(here + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            targets = [f"{mod}.{a.name}" if f"{mod}.{a.name}"[len(PACKAGE) + 1:] in modules else mod
                       for a in node.names]
        else:
            continue
        for t in targets:
            if t != PACKAGE and not t.startswith(PACKAGE + "."):
                continue
            t = t[len(PACKAGE) + 1:] if t != PACKAGE else ""
            while t and t not in modules:
                t = t.rpartition(".")[0]
            if t == name:
                continue
            found.add(t)
            parts = t.split(".") if t else []
            found |= {".".join(parts[:k]) for k in range(1, len(parts))} - own - {name}
    return found


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {m: _imports(m, p, is_pkg, modules) for m, (p, is_pkg) in modules.items()}


def _layer(name: str) -> int:
    best, where = -1, None
    for i, names in enumerate(LAYERS):
        for entry in names:
            if (entry == "" and name == "") or (entry and (name == entry or name.startswith(entry + "."))):
                if len(entry) > best:
                    best, where = len(entry), i
    if where is None:
        pytest.fail(f"module {name!r} has no layer: add it to LAYERS in tests/test_layers.py")
    return where


def _cycle(graph: dict[str, set[str]]) -> list[str]:
    """One import circle as [a, b, ..., a], or [] (depth-first search)."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(v: str) -> list[str]:
        state[v] = 1
        stack.append(v)
        for w in sorted(graph[v]):
            if state.get(w) == 1:
                return stack[stack.index(w):] + [w]
            if w not in state:
                found = visit(w)
                if found:
                    return found
        stack.pop()
        state[v] = 2
        return []

    for v in sorted(graph):
        if v not in state:
            found = visit(v)
            if found:
                return found
    return []


def test_no_import_circle():
    cycle = _cycle(_graph())
    assert not cycle, "import circle: " + " -> ".join(c or PACKAGE for c in cycle)


def test_no_upward_import():
    bad = [f"{m or PACKAGE} (layer {_layer(m)}) imports {d or PACKAGE} (layer {_layer(d)})"
           for m, deps in sorted(_graph().items()) for d in sorted(deps) if _layer(d) > _layer(m)]
    assert not bad, "upward imports:\n" + "\n".join(bad)


def test_the_checks_can_fail():
    """The circle finder finds a circle, and the layer of a package module is its own."""
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) == []
    assert _layer("streams") < _layer("prepared") < _layer("windows")
    assert _layer("training.experiment") > _layer("training")
