"""The import-layer contract of the code base: no cycle, no import from a higher layer.

The graph is read from the source (every ``import`` and ``from ... import``, also those inside
functions; only imports under ``if TYPE_CHECKING:`` are left out, since they never run). A
cycle or an upward import added anywhere makes one of these tests fail and names it.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Layers of ``beam``, lowest first: a module may import only from its own layer or below.
#: ``beam.io`` (records, configs, simulation, text and caps) sits above the physics: it builds
#: models, and the physics imports nothing from it.
BEAM_LAYERS: tuple[tuple[str, ...], ...] = (
    ("beam.errors",),
    ("beam.physics",),
    ("beam.io",),
    ("beam.inference",),
    ("beam.residuals",),
    ("beam.calibration", "beam.toy"),
    ("beam.discovery", "beam.study"),
    ("beam.cli", "beam", "beam.__main__"),
)

#: Layers of ``dashboard``, lowest first.
DASHBOARD_LAYERS: tuple[tuple[str, ...], ...] = (
    ("dashboard.runtime",),
    ("dashboard.jobs",),
    ("dashboard.outputs",),
    ("dashboard.state",),
    ("dashboard.plots",),
    ("dashboard.views",),
    ("dashboard", "dashboard.app"),
)


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def imported_modules(path: Path, known: set[str]) -> set[str]:
    """The project modules ``path`` imports (``from pkg import sub`` counts as ``pkg.sub`` when that is a module)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import):
            for alias in node.names:
                found.add(alias.name)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            for alias in node.names:
                candidate = f"{node.module}.{alias.name}"
                if candidate in known:
                    found.add(candidate)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return {name for name in found if name in known}


def import_graph() -> dict[str, set[str]]:
    files = [p for top in ("beam", "dashboard") for p in (ROOT / top).rglob("*.py")]
    known = {module_name(p) for p in files}
    return {module_name(p): imported_modules(p, known) - {module_name(p)} for p in files}


def layer_of(module: str, layers: tuple[tuple[str, ...], ...]) -> int:
    """Index of the layer with the longest prefix matching ``module``."""
    best, best_len = -1, -1
    for index, prefixes in enumerate(layers):
        for prefix in prefixes:
            if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > best_len:
                best, best_len = index, len(prefix)
    return best


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle of ``graph`` as a list of modules, or None (iterative depth-first search)."""
    state: dict[str, int] = {}
    for root in sorted(graph):
        if state.get(root):
            continue
        stack = [(root, iter(sorted(graph[root])))]
        path = [root]
        state[root] = 1
        while stack:
            node, children = stack[-1]
            for child in children:
                if state.get(child) == 1:
                    return path[path.index(child):] + [child]
                if not state.get(child):
                    state[child] = 1
                    path.append(child)
                    stack.append((child, iter(sorted(graph.get(child, ())))))
                    break
            else:
                state[node] = 2
                path.pop()
                stack.pop()
    return None


def upward_imports(graph: dict[str, set[str]], layers: tuple[tuple[str, ...], ...], top: str) -> list[str]:
    bad = []
    for module, imports in sorted(graph.items()):
        if module != top and not module.startswith(top + "."):
            continue
        own = layer_of(module, layers)
        for target in sorted(imports):
            if not target.startswith(top):
                continue
            if layer_of(target, layers) > own:
                bad.append(f"{module} imports {target}")
    return bad


GRAPH = import_graph()


def test_every_module_has_a_layer():
    for module in GRAPH:
        layers = BEAM_LAYERS if module.split(".")[0] == "beam" else DASHBOARD_LAYERS
        assert layer_of(module, layers) >= 0, f"{module} is in no layer of tests/test_architecture.py"


def test_no_import_cycle():
    cycle = find_cycle(GRAPH)
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


@pytest.mark.parametrize("top, layers", [("beam", BEAM_LAYERS), ("dashboard", DASHBOARD_LAYERS)])
def test_no_upward_import(top, layers):
    assert upward_imports(GRAPH, layers, top) == []


def test_physics_knows_nothing_of_inference_or_analysis():
    forbidden = ("beam.io", "beam.inference", "beam.calibration", "beam.discovery", "beam.cli", "beam.residuals",
                 "beam.toy")
    for module, imports in GRAPH.items():
        if module.startswith("beam.physics"):
            assert not [t for t in imports if t.startswith(forbidden)], module


def test_library_never_imports_the_dashboard():
    for module, imports in GRAPH.items():
        if module.split(".")[0] == "beam":
            assert not [t for t in imports if t.split(".")[0] == "dashboard"], module


def test_checker_sees_a_cycle_and_an_upward_import():
    """The checks above would fail on a cycle or an upward import (the checker itself, on a made-up graph)."""
    graph = {"beam.physics.model": {"beam.physics.modal"}, "beam.physics.modal": {"beam.physics.model"}}
    assert find_cycle(graph) in (["beam.physics.model", "beam.physics.modal", "beam.physics.model"],
                                 ["beam.physics.modal", "beam.physics.model", "beam.physics.modal"])
    graph = {"beam.physics.model": {"beam.calibration.run"}, "beam.calibration.run": set()}
    assert upward_imports(graph, BEAM_LAYERS, "beam") == ["beam.physics.model imports beam.calibration.run"]
    graph = {"dashboard.runtime.scheduler": {"dashboard.jobs.beam"}, "dashboard.jobs.beam": set()}
    assert upward_imports(graph, DASHBOARD_LAYERS, "dashboard") == [
        "dashboard.runtime.scheduler imports dashboard.jobs.beam"]


def test_public_entry_points_resolve():
    import beam
    from beam.calibration import calibrate
    from beam.discovery.report import diagnose
    from beam.io.measurement import read_measurement
    from beam.physics.model import BeamModel
    from beam.toy import run_toy

    assert (beam.BeamModel, beam.read_measurement, beam.calibrate, beam.diagnose, beam.run_toy) == (
        BeamModel, read_measurement, calibrate, diagnose, run_toy)
    with pytest.raises(AttributeError):
        beam.not_a_name  # noqa: B018
