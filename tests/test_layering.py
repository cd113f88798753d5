"""The layering the next capabilities build on, checked in fresh interpreters: what each module pulls in
when imported alone (after the package's own light __init__). Lower floors never import a view; file
readers never import algorithms."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

#: module -> modules it must not load (prefixes).
FORBIDDEN = {
    "pipeline.geometry": ("pydrake", "matplotlib", "pipeline.views", "pipeline.drake_model"),
    "pipeline.kinematics": ("pydrake", "matplotlib", "pipeline.views"),
    "pipeline.drake_model": ("pipeline.views", "matplotlib", "pipeline.ik", "pipeline.timing"),
    "pipeline.schema": ("pydrake", "pipeline.ik", "pipeline.timing", "pipeline.drake_model"),
    "pipeline.robot_spec": ("pydrake", "pipeline.ik", "pipeline.timing", "pipeline.drake_model"),
    "pipeline.jobs": ("pydrake", "pipeline.ik", "pipeline.timing", "pipeline.drake_model", "toppra", "ruckig"),
    "pipeline.views": ("pydrake", "matplotlib"),
    "pipeline.urdf": ("pydrake", "matplotlib", "pipeline.ik", "pipeline.timing"),   # URDF is text and NumPy          # both only when a figure or a view is made
}


def loaded_by(module: str) -> list[str]:
    code = (f"import sys, json; before = set(sys.modules); import {module}; "
            "print(json.dumps(sorted(set(sys.modules) - before)))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return json.loads(result.stdout)


@pytest.mark.parametrize("module", list(FORBIDDEN))
def test_module_imports_only_its_floor(module):
    loaded = loaded_by(module)
    assert module in loaded
    offending = sorted({name for name in loaded for bad in FORBIDDEN[module]
                        if name == bad or name.startswith(bad + ".")})
    assert not offending, f"{module} loads {offending}"


def imported_modules(module: str) -> set[str]:
    """Every pipeline module ``module``'s source imports, at the top or inside functions."""
    import ast
    import importlib.util

    path = importlib.util.find_spec(module).origin
    package = module.rsplit(".", 1)[0] if not path.endswith("__init__.py") else module
    names = set()
    for node in ast.walk(ast.parse(open(path).read())):
        if isinstance(node, ast.ImportFrom):
            base = importlib.util.resolve_name("." * node.level + (node.module or ""), package) if node.level \
                else node.module
            names.add(base)
            names.update(f"{base}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return {name for name in names if name.startswith("pipeline")}


@pytest.mark.parametrize("module, never", [
    ("pipeline.drake_model", "pipeline.views"),          # the old cycle: views -> drake_model -> views
    ("pipeline.geometry", "pipeline.views"),
    ("pipeline.geometry", "pipeline.drake_model"),
    ("pipeline.jobs", "pipeline.ik"),
    ("pipeline.jobs", "pipeline.timing"),
])
def test_no_import_even_inside_functions(module, never):
    assert never not in imported_modules(module)
