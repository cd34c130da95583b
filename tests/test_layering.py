"""Import layering (style anchors part (c)): the numeric layer never imports sympy; codegen is the only
module that imports both sympy and casadi."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "obsnl"
NUMERIC = ["numeric", "ukf", "ukf_step", "trajectory", "dukf", "data", "identify", "reproduction", "simulate", "plots"]


def _imports(module: str) -> set[str]:
    tree = ast.parse((PKG / f"{module}.py").read_text(encoding="utf-8"))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


@pytest.mark.parametrize("module", NUMERIC)
def test_numeric_modules_never_import_sympy(module):
    assert "sympy" not in _imports(module)


def test_only_codegen_imports_both_sympy_and_casadi():
    both = sorted(p.stem for p in PKG.glob("*.py") if {"sympy", "casadi"} <= _imports(p.stem))
    assert both == ["codegen"]
