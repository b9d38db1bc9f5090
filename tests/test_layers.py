"""The package's layers: a module imports only from layers below its own (or from its own package), at the
top of a file or inside a function, and no modules import each other in a circle.

A new package takes a row here; the order is what the kit is built on (the rig's facts, the device's
model, the controllers, the twin, the link, the env, the episode, the learners, deployment, the rig queue, the tools
around them, the labs and adapt, the command line). The network model sits with the rig's facts: the twin
and the link both build on it."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "pendkit"
LAYERS = (
    ("pendkit", "errors", "env_name", "backend_contract", "gl_backend"),
    ("checks",),
    ("safe_write",),
    ("rig", "encoder", "features", "wiring", "bom", "network", "timing"),
    ("device",),
    ("telemetry",),
    ("control", "firmware_constants"),
    ("sim",),
    ("link", "cad"),
    ("env",),
    ("episode",),
    ("agents",),
    ("deploy",),
    ("queue",),
    ("demo", "sweep", "grading", "widgets"),
    ("labs", "adapt"),
    ("cli",),
)
LAYER = {unit: k for k, units in enumerate(LAYERS) for unit in units}


def module_of(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def unit_of(module: str) -> str:
    """'pendkit.sim.backend' -> 'sim'; 'pendkit' -> 'pendkit'."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "pendkit"


def parsed(path: Path) -> ast.Module:
    """The file's syntax tree. CPython 3.11 keeps one AST-building depth counter per interpreter, so a
    traceback formatted at the same moment on another thread (an nbval kernel's client, say) can make
    `ast.parse` raise a spurious SystemError (cpython gh-106905); the file itself is fine, so parse again."""
    for attempt in range(3):
        try:
            return ast.parse(path.read_text(), filename=str(path))
        except SystemError as error:
            if "recursion depth mismatch" not in str(error) or attempt == 2:
                raise
    raise AssertionError("unreachable")


def imported(path: Path) -> list[tuple[str, int]]:
    """(module, line) of every pendkit import in the file, wherever it stands."""
    found = []
    for node in ast.walk(parsed(path)):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module and node.module.startswith("pendkit"):
            if node.module == "pendkit":  # `from pendkit import sim` imports the package sim
                found += [(f"pendkit.{a.name}" if a.name in LAYER else "pendkit", node.lineno) for a in node.names]
            else:
                found.append((node.module, node.lineno))
        elif isinstance(node, ast.Import):
            found += [(a.name, node.lineno) for a in node.names if a.name.split(".")[0] == "pendkit"]
    return found


MODULES = {module_of(path): path for path in sorted(PACKAGE.rglob("*.py"))}


def test_every_package_has_a_layer():
    assert {unit_of(m) for m in MODULES} - set(LAYER) == set()


def test_no_import_runs_up_or_across_a_layer():
    wrong = []
    for module, path in MODULES.items():
        here = unit_of(module)
        for target, line in imported(path):
            there = unit_of(target)
            if there != here and LAYER[there] >= LAYER[here] and here != "pendkit":
                wrong.append(f"{path.relative_to(PACKAGE.parent)}:{line} {here} -> {target}")
    assert wrong == []


def test_no_modules_import_each_other_in_a_circle():
    graph = {}
    for module, path in MODULES.items():
        targets = set()
        for target, _ in imported(path):
            while target not in MODULES and "." in target:  # `from pendkit.x.y import name`: the module x.y
                target = target.rsplit(".", 1)[0]
            if target != module and target != "pendkit" and not module.startswith(target + "."):
                targets.add(target)
        graph[module] = targets
    done, path_now = set(), []

    def visit(module: str) -> None:
        if module in path_now:
            pytest.fail("import circle: " + " -> ".join(path_now[path_now.index(module):] + [module]))
        if module in done:
            return
        path_now.append(module)
        for target in sorted(graph.get(module, ())):
            visit(target)
        path_now.pop()
        done.add(module)

    for module in sorted(graph):
        visit(module)
