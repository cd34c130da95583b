"""The public API as type checkers see it.

Every package of obsnl that exports its names lazily (a ``_LAZY`` table read by ``obsnl._exports.lazy_exports``)
also imports each of them plainly under ``if TYPE_CHECKING:``, so that mypy and pyright see the types while the
run time stays lazy. These tests read that block from the source (a type checker reads it; the interpreter
never runs it) and check that it names exactly the table's names, each from the module the table gives, and that
each name, loaded lazily, is the very object the block imports.
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import importlib.util
import inspect
import pkgutil
from pathlib import Path

import pytest

import obsnl

#: Packages whose __init__ is edited in other changes under way; each gets its TYPE_CHECKING block there. Strict:
#: the test fails as soon as one has it, to be taken off this list (every room has its block now).
PENDING: set[str] = set()


def _lazy_packages() -> list[str]:
    """Every package of obsnl with a ``_LAZY`` table in its ``__init__`` (found in the source, nothing imported)."""
    found = []
    root = Path(obsnl.__file__).parent
    for path in sorted(root.rglob("__init__.py")):
        if "_LAZY" in path.read_text(encoding="utf-8"):
            rel = path.parent.relative_to(root.parent)
            found.append(".".join(rel.parts))
    return found


def _type_checking_imports(tree: ast.Module) -> list[tuple[str, str, str | None]]:
    """``(module, name, asname)`` of each ``from M import N as A`` inside a module-level ``if TYPE_CHECKING:``."""
    out = []
    for node in tree.body:
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            for stmt in node.body:
                assert isinstance(stmt, ast.ImportFrom) and stmt.level == 0, ast.dump(stmt)
                out += [(str(stmt.module), a.name, a.asname) for a in stmt.names]
    return out


def _params(packages: list[str]) -> list:
    return [pytest.param(p, marks=pytest.mark.xfail(strict=True, reason="its TYPE_CHECKING block is to come"))
            if p in PENDING else p for p in packages]


def test_the_lazy_packages_are_found():
    # the rooms named in the package's docstrings, at least: a search that found none would check nothing
    assert {"obsnl", "obsnl.model", "obsnl.observability", "obsnl.estimation", "obsnl.linear"} <= set(_lazy_packages())


@pytest.mark.parametrize("package", _params(_lazy_packages()))
def test_each_lazy_name_is_imported_plainly_for_type_checkers(package):
    module = importlib.import_module(package)
    table: dict[str, str] = module._LAZY
    source = Path(module.__file__).read_text(encoding="utf-8")
    imports = _type_checking_imports(ast.parse(source))
    seen = {name: (where, alias) for where, name, alias in imports}
    assert len(seen) == len(imports), f"{package}: a name imported twice under TYPE_CHECKING"
    missing = sorted(set(table) - set(seen))
    extra = sorted(set(seen) - set(table))
    assert not missing and not extra, f"{package}: not under TYPE_CHECKING {missing}; not in _LAZY {extra}"
    for name, (where, alias) in seen.items():
        # `as name`: an explicit re-export (a type checker's strict mode does not re-export a bare import)
        assert alias == name, f"{package}: import {name} as {name}"
        assert where == f"{package}.{table[name]}", f"{package}.{name}: _LAZY says {table[name]}, the block {where}"
        assert getattr(module, name) is getattr(importlib.import_module(where), name), f"{package}.{name}"


def test_no_package_under_obsnl_is_missed():
    # a package with a __getattr__ of lazy_exports hides its names from type checkers unless it is checked above
    lazy = set(_lazy_packages())
    for info in pkgutil.walk_packages(obsnl.__path__, "obsnl."):
        if info.ispkg:
            init = Path(importlib.util.find_spec(info.name).origin).read_text(encoding="utf-8")
            assert ("lazy_exports(" in init) <= (info.name in lazy), info.name


def _model_init_stub() -> ast.FunctionDef:
    from obsnl.model import core

    tree = ast.parse(Path(core.__file__).read_text(encoding="utf-8"))
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Model")
    block = next(n for n in cls.body if isinstance(n, ast.If) and ast.unparse(n.test) == "TYPE_CHECKING")
    return next(n for n in block.body if isinstance(n, ast.FunctionDef) and n.name == "__init__")


def test_the_model_constructor_type_checkers_see_is_the_dataclass_constructor():
    # Model's fields hold read values (tuples of symbols); its __init__ for type checkers takes what a caller writes
    # (names in any iterable). Both must list the same parameters, in the same order, the same ones required.
    from obsnl.model.core import Model

    stub = _model_init_stub()
    args = stub.args.args[1:]  # without self
    defaults = [None] * (len(args) - len(stub.args.defaults)) + list(stub.args.defaults)
    declared = [(a.arg, d is not None) for a, d in zip(args, defaults)]
    real = inspect.signature(Model).parameters.values()
    assert declared == [(p.name, p.default is not inspect.Parameter.empty) for p in real]
    fields = [f.name for f in dataclasses.fields(Model) if f.init]
    assert [name for name, _ in declared] == fields
    assert not stub.args.kwonlyargs and stub.args.vararg is None and stub.args.kwarg is None
