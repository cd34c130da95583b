"""The documentation's promises that hold without building it: CI builds it with the README's command, warnings as
errors, after the tests; every room with public names has a reference page; the tutorials are there in their order."""

from __future__ import annotations

import ast
import pkgutil
import re

import obsnl

from .conftest import ROOT

DOCS_COMMAND = 'pip install -e ".[docs]" && python -m sphinx -j auto -W --keep-going -b html docs docs/_build/html'


def _rooms() -> list[str]:
    """The modules of docs/conf.py's ROOMS (read from its source: building the docs is not needed here)."""
    tree = ast.parse((ROOT / "docs" / "conf.py").read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.AnnAssign) and getattr(node.target, "id", None) == "ROOMS":
            return [module for module, _ in ast.literal_eval(node.value)]
    raise AssertionError("docs/conf.py defines no ROOMS")


def _defines_all(path) -> bool:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return any(isinstance(n, (ast.Assign, ast.AnnAssign)) and any(
        getattr(t, "id", None) == "__all__" for t in (n.targets if isinstance(n, ast.Assign) else [n.target]))
        for n in tree.body)


def test_ci_builds_the_docs_with_the_readme_command_after_the_tests():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert DOCS_COMMAND in [b.strip() for b in re.findall(r"```bash\n(.*?)```", readme, flags=re.DOTALL)]
    lines = [line.strip() for line in (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()]
    assert lines.index(DOCS_COMMAND) > lines.index('pip install -e ".[test]" && python -m pytest')


def test_every_package_with_public_names_has_a_reference_page():
    """A subpackage (a room) that declares ``__all__`` in its ``__init__`` has a page, and so do the top-level public
    modules: otherwise its names would be missing from the reference."""
    packages = {"obsnl"} | {m.name for m in pkgutil.walk_packages(obsnl.__path__, "obsnl.") if m.ispkg
                            and not any(part.startswith("_") for part in m.name.split("."))
                            and _defines_all(ROOT.joinpath(*m.name.split("."), "__init__.py"))}
    top = {f"obsnl.{p.stem}" for p in (ROOT / "obsnl").glob("*.py") if not p.stem.startswith("_") and _defines_all(p)}
    missing = (packages | top) - set(_rooms())
    assert not missing, f"no reference page for {sorted(missing)}: add them to ROOMS in docs/conf.py"


def test_the_six_tutorials_in_their_order():
    found = sorted(p.name for p in (ROOT / "docs" / "tutorials").glob("plot_*.py"))
    assert [name.split("_")[1] for name in found] == ["1", "2", "3", "4", "5", "6"], found
