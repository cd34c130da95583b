"""The package's import graph (built from the source with ``ast``): layers along the data flow, no
circles between modules or between subpackages (``import_module`` calls and lazy-export tables included), an
inner order inside the wide rooms; the numeric layer never imports sympy and codegen is the only module that imports both sympy and casadi.

A module's or a room's size is a question for review, not a test (ruff and mypy keep the form)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import networkx as nx
import pytest

PKG = Path(__file__).resolve().parents[1] / "obsnl"

#: Rank of each room along the data flow: a module may import only rooms of a lower rank, or its own room.
LAYERS = {
    "errors": 0, "_progress": 0, "_text": 0, "_exports": 0, "_display": 0, "_types": 0, "_files": 0,
    "executor": 1,
    "model": 1,
    "algebra": 2,
    "observability": 3,
    "recombination": 4, "estimation": 4, "linear": 4,
    "report": 5,
    "identification": 6,
    "studies": 7, "design": 7,
    "batch": 8,
    "commands": 9,
    "cli": 10, "__init__": 10, "__main__": 11,
}
#: The inner order of a room that has sub-rooms (each subpackage ``__init__`` states it): a module imports
#: only a lower rank of its own room, or its own sub-room. A top-level module of the room is its own unit.
INNER = {
    "observability": {
        "limits": 0, "verdicts": 0, "assumptions": 0,
        "engines": 1,
        "joint": 2,
        "certificates": 3,
        "results": 4,
        "analyze": 5,
        "contract": 6,
    },
    "model": {
        "bounds": 0,
        "reading": 1,
        "core": 2,
        "files": 3, "branching": 3,
    },
}
#: What the estimators may read of the observability room (docs/architecture.md: only through the branch table).
ESTIMATION_READS = {"obsnl.observability.contract.branch_table"}


def _module_name(path: Path) -> str:
    parts = path.relative_to(PKG.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for p in sorted(PKG.rglob("*.py"))}


def _room(module: str) -> str:
    parts = module.split(".")
    if len(parts) == 1:
        return "__init__"
    return parts[1]


#: Calls that import a module by name at run time: their target is read from a literal string, so that no import
#: hides from the graph; a call whose target is not a literal is reported by :func:`test_no_import_by_a_computed_name`.
DYNAMIC = {"import_module", "__import__"}


def _dynamic_target(node: ast.Call) -> str | None:
    """The module a call to ``import_module``/``__import__`` names, "" when it is computed, None for another call."""
    f = node.func
    name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else None
    if name not in DYNAMIC:
        return None
    arg = node.args[0] if node.args else None
    return arg.value if isinstance(arg, ast.Constant) and isinstance(arg.value, str) else ""


def _lazy_table(node: ast.Assign, package: str) -> set[str]:
    """The modules of a package's lazy-export table (``_LAZY = {name: "module"}``, :mod:`obsnl._exports`)."""
    if not (any(isinstance(t, ast.Name) and t.id == "_LAZY" for t in node.targets) and isinstance(node.value, ast.Dict)):
        return set()
    return {f"{package}.{v.value}" for v in node.value.values if isinstance(v, ast.Constant) and isinstance(v.value, str)}


def _imports(module: str, modules: dict[str, Path] | None = None) -> set[str]:
    """Every obsnl module (and third-party top-level package) that ``module`` imports, at any depth: ``import``
    statements, literal ``import_module("...")``/``__import__("...")`` calls and lazy-export tables."""
    path = (modules or MODULES)[module]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and _dynamic_target(node):
            out.add(_dynamic_target(node))
        elif isinstance(node, ast.Assign):
            out.update(_lazy_table(node, package))
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            for a in node.names:
                full = f"{mod}.{a.name}"
                out.add(full if full in (modules or MODULES) else mod)
    return out


def _graph(modules: dict[str, Path] | None = None, top: str = "obsnl") -> nx.DiGraph:
    modules = modules or MODULES
    g = nx.DiGraph()
    g.add_nodes_from(modules)
    for m in modules:
        for target in _imports(m, modules):
            if target in modules and target != m and not m.startswith(target + "."):
                g.add_edge(m, target)
            elif target.startswith(top + ".") and target not in modules:
                raise AssertionError(f"{m} imports {target}, which does not exist")
    return g


def test_the_graph_sees_a_circle_made_by_import_module(tmp_path):
    # a planted package: a imports b plainly; b loads a back by name at run time (the hidden circle of a plug-in
    # registry). The graph must hold the edge b -> a, and so the circle.
    pkg = tmp_path / "planted"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from planted import b\n")
    (pkg / "b.py").write_text("def later():\n    import importlib\n    return importlib.import_module('planted.a')\n")
    modules = {f"planted.{p.stem}" if p.stem != "__init__" else "planted": p for p in sorted(pkg.glob("*.py"))}
    cycles = list(nx.simple_cycles(_graph(modules, top="planted")))
    assert sorted(map(sorted, cycles)) == [["planted.a", "planted.b"]]


def test_every_command_reaches_its_door_by_a_plain_import():
    # each command has its module in the commands room, imported plainly by the command line's runner; the module
    # holds the command's frozen request, its run and what it prints
    import dataclasses
    import importlib

    from obsnl.cli import COMMANDS

    assert {f"obsnl.commands.{c}" for c in COMMANDS} <= set(MODULES)
    assert {f"obsnl.commands.{c}" for c in COMMANDS} <= _imports("obsnl.cli.commands")
    for c in COMMANDS:
        module = importlib.import_module(f"obsnl.commands.{c}")
        request = getattr(module, f"{c.capitalize()}Request")
        assert dataclasses.is_dataclass(request) and request.__dataclass_params__.frozen
        assert callable(getattr(module, f"run_{c}")) and callable(getattr(module, f"{c}_printed"))


def test_the_libraries_hold_no_command_line_job():
    # design/ and studies/ are libraries: no module of theirs is the command line's job
    assert {m for m in MODULES if m.split(".")[-1] == "jobs"} == set()


def test_no_import_by_a_computed_name():
    # an import whose module is computed at run time is invisible to the graph: none in the package, but the lazy
    # exports' one loader (its tables are read above)
    allowed = {"obsnl._exports"}
    hidden = []
    for m, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and _dynamic_target(node) == "" and m not in allowed:
                hidden.append(f"{m}:{node.lineno}")
    assert hidden == []


def test_no_circles_between_modules():
    g = _graph()
    cycles = list(nx.simple_cycles(g))
    assert cycles == [], f"import circles: {cycles[:3]}"


def test_no_circles_between_rooms():
    g = _graph()
    rooms = nx.DiGraph()
    for a, b in g.edges:
        if _room(a) != _room(b):
            rooms.add_edge(_room(a), _room(b))
    assert list(nx.simple_cycles(rooms)) == []


def test_imports_point_down_the_data_flow():
    g = _graph()
    wrong = []
    for a, b in g.edges:
        ra, rb = _room(a), _room(b)
        if ra == rb or a == "obsnl" or b == "obsnl":
            continue
        if LAYERS[rb] >= LAYERS[ra]:
            wrong.append(f"{a} -> {b}")
        if ra == "estimation" and rb == "observability" and b not in ESTIMATION_READS:
            wrong.append(f"{a} -> {b} (the estimators read the analysis only through the branch table)")
    assert wrong == []


def test_every_room_has_a_layer():
    assert {_room(m) for m in MODULES} <= set(LAYERS)


def _unit(module: str) -> str | None:
    """The sub-room (or top-level module) of ``module`` inside a room with an inner order, else None."""
    parts = module.split(".")
    if len(parts) < 3 or parts[1] not in INNER:
        return None
    return parts[2]


def test_every_unit_of_an_ordered_room_has_a_rank():
    units = {(m.split(".")[1], _unit(m)) for m in MODULES if _unit(m) is not None}
    assert {u for r, u in units if u not in INNER[r]} == set()


def test_imports_inside_a_room_point_down_its_inner_order():
    g = _graph()
    wrong = []
    for a, b in g.edges:
        ua, ub = _unit(a), _unit(b)
        if _room(a) != _room(b) or ua is None or ub is None or ua == ub:
            continue
        order = INNER[_room(a)]
        if order[ub] >= order[ua]:
            wrong.append(f"{a} -> {b}")
    assert wrong == []


def test_no_circles_between_sub_rooms():
    g = _graph()
    units = nx.DiGraph()
    for a, b in g.edges:
        ua, ub = _unit(a), _unit(b)
        if _room(a) == _room(b) and ua is not None and ub is not None and ua != ub:
            units.add_edge((_room(a), ua), (_room(b), ub))
    assert list(nx.simple_cycles(units)) == []


def test_the_package_is_grouped_into_subpackages():
    rooms = {p.name for p in PKG.iterdir() if (p / "__init__.py").is_file()}
    assert {"model", "algebra", "observability", "recombination", "estimation", "linear", "report",
            "studies"} <= rooms


def _third_party(module: str) -> set[str]:
    return {n.split(".")[0] for n in _imports(module)}


NUMERIC = sorted(m for m in MODULES if _room(m) == "estimation" and m != "obsnl.estimation.codegen")


@pytest.mark.parametrize("module", NUMERIC)
def test_numeric_modules_never_import_sympy(module):
    assert "sympy" not in _third_party(module)


def test_only_codegen_imports_both_sympy_and_casadi():
    both = sorted(m for m in MODULES if {"sympy", "casadi"} <= _third_party(m))
    assert both == ["obsnl.estimation.codegen"]


def _charter(package: str) -> tuple[list[str], list[str]]:
    """The rooms that a package's charter (its ``__init__`` docstring) says it may and must never import."""
    doc = " ".join((ast.get_docstring(ast.parse(MODULES[package].read_text(encoding="utf-8"))) or "").split())
    doc = re.sub(r"\([^()]*\)", "", doc)  # explanations in parentheses name no rule
    may = re.search(r"May import:?(.*?)(?:Must never import|$)", doc)
    never = re.search(r"Must never import:?(.*?)(?:[.;](?:\s|$)|$)", doc)
    if may is None or never is None:
        return [], []
    names = re.compile(r"``([A-Za-z_][\w.]*)``")
    return names.findall(may.group(1)), names.findall(never.group(1))


#: Packages whose charter states no import rule: the top level and the command line, which sit above every room.
UNRULED = {"obsnl", "obsnl.cli"}
#: The ground floor (rank 0 in LAYERS): every room may use it, whatever its charter lists.
GROUND = [r for r, rank in LAYERS.items() if rank == 0]


def _under(target: str, rooms: list[str]) -> bool:
    return any(target == f"obsnl.{r}" or target.startswith(f"obsnl.{r}.") for r in rooms)


def test_every_room_states_its_charter():
    packages = [m for m, p in MODULES.items() if p.name == "__init__.py" and m not in UNRULED]
    missing = {p for p in packages if _charter(p) == ([], [])}
    assert missing == set(), "rooms whose __init__ says no 'May import:' / 'Must never import:'"


def test_imports_follow_each_rooms_charter():
    packages = sorted((m for m, p in MODULES.items() if p.name == "__init__.py" and m not in UNRULED),
                      key=len, reverse=True)
    broken = []
    for module in MODULES:
        unit = next((p for p in packages if module == p or module.startswith(p + ".")), None)
        if unit is None:
            continue
        may, never = _charter(unit)
        for target in _imports(module):
            if not target.startswith("obsnl.") or target == unit or target.startswith(unit + "."):
                continue
            if _under(target, never) or not _under(target, may + GROUND):
                broken.append(f"{module} imports {target} ({unit} may import {may}, never {never})")
    assert broken == []


def _private_imports(modules: dict[str, Path]) -> list[str]:
    """``importer imports module.name`` for each private name (one leading underscore, not a module) that a module
    imports from another module of the package, at any depth. A helper that two modules share is a documented
    public name of the module that defines it; a private module (``obsnl._text``) is imported by its public names,
    and importing a private module itself (``from obsnl import _display``) is not counted."""
    found = []
    for module, path in modules.items():
        package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.ImportFrom):
                continue
            if node.level:
                base = package.split(".")
                source = ".".join(base[: len(base) - node.level + 1] + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            if source not in modules or source == module:
                continue
            for a in node.names:
                private = a.name.startswith("_") and not a.name.startswith("__")
                if private and f"{source}.{a.name}" not in modules:
                    found.append(f"{module} imports {source}.{a.name}")
    return found


def test_the_private_import_check_catches_a_planted_one(tmp_path):
    # a planted package: b borrows a's private helper (caught, however it is renamed on import, and from a relative
    # import too); c imports a's public name and the private module _util (both fine)
    pkg = tmp_path / "planted"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "_util.py").write_text("def tidy():\n    pass\n")
    (pkg / "a.py").write_text("def _helper():\n    pass\n\ndef helper():\n    pass\n")
    (pkg / "b.py").write_text("from planted.a import _helper as h\n\ndef f():\n    from .a import _helper\n")
    (pkg / "c.py").write_text("from planted import _util\nfrom planted.a import helper\n")
    modules = {f"planted.{p.stem}" if p.stem != "__init__" else "planted": p for p in sorted(pkg.glob("*.py"))}
    assert _private_imports(modules) == ["planted.b imports planted.a._helper", "planted.b imports planted.a._helper"]


def test_no_module_imports_another_modules_private_name():
    assert _private_imports(MODULES) == []
