"""The house: one folder per stage, importing only downward, no cycle between files or folders, and what each
light module pulls in when imported alone (in fresh interpreters).

Every import counts, at the top of a module, inside a function or under ``TYPE_CHECKING``: a lazy import is
still a dependency the reader has to know about."""

from __future__ import annotations

import ast
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(importlib.util.find_spec("pipeline").origin).parent

#: The stages, lowest first: a module imports only from its own stage and the stages before it. A stage is a
#: folder of ``pipeline/`` or one of the few modules at its root (``__init__``: the front door, on top).
STAGES = ("errors", "progress", "files", "model", "urdf", "timing", "cell", "program", "outputs", "runner",
          "scale", "ui", "bench", "__main__", "__init__")
#: At most this many modules at the root of ``pipeline/``: everything else lives in a stage folder.
MAX_ROOT_MODULES = 6


def package_modules() -> dict[str, Path]:
    """Every module of the package: dotted name -> file (a package is its ``__init__.py``)."""
    modules = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def import_graph(modules: dict[str, Path]) -> dict[str, set[str]]:
    """module -> the package modules its source imports (``from pkg import module`` names the module itself)."""
    graph = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        targets = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = (importlib.util.resolve_name("." * node.level + (node.module or ""), package) if node.level
                        else node.module)
                for alias in node.names:
                    targets.add(f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base)
            elif isinstance(node, ast.Import):
                targets.update(alias.name for alias in node.names)
        graph[name] = {target for target in targets if target in modules and target != name}
    return graph


def stage_of(module: str) -> str:
    parts = module.split(".")
    return "__init__" if len(parts) == 1 else parts[1]


def folder_of(module: str, modules: dict[str, Path]) -> str:
    """The folder a module lives in; a module at the root is a node of its own (it is a stage)."""
    if len(module.split(".")) == 2 and modules[module].name != "__init__.py":
        return module
    return module if modules[module].name == "__init__.py" else module.rpartition(".")[0]


def upward_imports(graph: dict[str, set[str]]) -> list[tuple[str, str]]:
    """(importer, imported) pairs where a stage imports a later stage."""
    rank = {stage: k for k, stage in enumerate(STAGES)}
    return sorted((a, b) for a, targets in graph.items() for b in targets if rank[stage_of(b)] > rank[stage_of(a)])


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node (Tarjan), each sorted."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for other in graph.get(node, ()):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in on_stack:
                low[node] = min(low[node], index[other])
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

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return sorted(found)


def folder_graph(graph: dict[str, set[str]], modules: dict[str, Path]) -> dict[str, set[str]]:
    out: dict[str, set[str]] = {}
    for a, targets in graph.items():
        out.setdefault(folder_of(a, modules), set()).update(
            folder_of(b, modules) for b in targets if folder_of(b, modules) != folder_of(a, modules))
    return out


@pytest.fixture(scope="module")
def modules():
    return package_modules()


@pytest.fixture(scope="module")
def graph(modules):
    return import_graph(modules)


def test_every_module_sits_in_a_stage_and_the_root_stays_small(modules):
    root = sorted(name for name, path in modules.items() if path.parent == PACKAGE and name != "pipeline")
    assert len(root) + 1 <= MAX_ROOT_MODULES, f"modules at the root of pipeline/: {root}"
    assert {stage_of(name) for name in modules} <= set(STAGES), "a folder or root module the stage list lacks"


def test_no_stage_imports_a_later_stage(graph):
    assert upward_imports(graph) == []


def test_no_cycle_between_files(graph):
    assert cycles(graph) == []


def test_no_cycle_between_folders(graph, modules):
    assert cycles(folder_graph(graph, modules)) == []


def test_a_planted_upward_import_or_cycle_is_found(graph, modules):
    """The checks above can fail: a file reader that imports the Program, and the cycle that closes."""
    planted = {name: set(targets) for name, targets in graph.items()}
    planted["pipeline.files.schema"].add("pipeline.program.model")
    assert ("pipeline.files.schema", "pipeline.program.model") in upward_imports(planted)
    assert any({"pipeline.files.schema", "pipeline.program.model"} <= set(c) for c in cycles(planted))
    assert any({"pipeline.files", "pipeline.program"} <= set(c) for c in cycles(folder_graph(planted, modules)))
    sideways = {name: set(targets) for name, targets in graph.items()}
    sideways["pipeline.model.chain.kinematics"].add("pipeline.model.robot")     # same stage, folders in a cycle
    assert upward_imports(sideways) == []
    assert any({"pipeline.model", "pipeline.model.chain"} <= set(c) for c in cycles(folder_graph(sideways, modules)))


#: module -> modules it must not load when imported alone (prefixes): heavy libraries and higher floors that a
#: lazy import keeps out.
FORBIDDEN = {
    "pipeline.model.chain.geometry": ("pydrake", "matplotlib", "pipeline.outputs", "pipeline.model.chain.drake_model"),
    "pipeline.model.chain.kinematics": ("pydrake", "matplotlib", "pipeline.outputs"),
    "pipeline.model.chain.drake_model": ("pipeline.outputs", "matplotlib", "pipeline.model.ik", "pipeline.timing"),
    "pipeline.files.schema": ("pydrake", "pipeline.model.ik", "pipeline.timing", "pipeline.model.chain.drake_model"),
    "pipeline.files.robot_spec": ("pydrake", "pipeline.model.ik", "pipeline.timing",
                                  "pipeline.model.chain.drake_model"),
    "pipeline.program.job": ("pydrake", "pipeline.model.ik", "pipeline.timing", "pipeline.model.chain.drake_model",
                             "toppra", "ruckig"),
    "pipeline.outputs.views": ("pydrake", "matplotlib"),          # both only when a figure or a view is made
    "pipeline.urdf": ("pydrake", "matplotlib", "pipeline.model.ik", "pipeline.timing"),   # URDF is text and NumPy
}


def loaded_by(module: str) -> list[str]:
    code = (f"import sys, json; before = set(sys.modules); import {module}; "
            "print(json.dumps(sorted(set(sys.modules) - before)))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return json.loads(result.stdout)


#: make test imports two of them in a fresh interpreter (some 1.5 s each); the slow run all.
@pytest.mark.parametrize("module", [m if k < 2 else pytest.param(m, marks=pytest.mark.slow)
                                    for k, m in enumerate(FORBIDDEN)])
def test_module_imports_only_its_floor(module):
    loaded = loaded_by(module)
    assert module in loaded
    offending = sorted({name for name in loaded for bad in FORBIDDEN[module]
                        if name == bad or name.startswith(bad + ".")})
    assert not offending, f"{module} loads {offending}"


def test_the_oracle_and_the_geometry_never_import_drake_even_lazily(graph):
    """The NumPy oracle stays independent of Drake (it is the second opinion), the stick figure too."""
    for module in ("pipeline.model.chain.kinematics", "pipeline.model.chain.geometry"):
        assert "pipeline.model.chain.drake_model" not in graph[module]
