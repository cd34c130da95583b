"""Every public function of obsnl that takes two or more arguments documents them (numpydoc).

Public: listed in its module's ``__all__``, or, in a module without ``__all__``, any top-level
function whose name does not start with ``_``. Such a function needs a docstring with a
``Parameters`` section. The check reads the source (``ast``), so it imports nothing.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "obsnl"


def undocumented(root: Path) -> list[str]:
    """``file:function`` for each public function of two or more arguments without ``Parameters``."""
    missing = []
    for path in sorted(root.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        names = None
        for node in tree.body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
                try:
                    names = set(ast.literal_eval(node.value))
                except ValueError:
                    pass
        for node in tree.body:
            if (isinstance(node, ast.FunctionDef) and not node.name.startswith("_")
                    and (names is None or node.name in names)
                    and len(node.args.args) + len(node.args.kwonlyargs) >= 2
                    and "Parameters" not in (ast.get_docstring(node) or "")):
                missing.append(f"{path.relative_to(root.parent).as_posix()}:{node.name}")
    return missing


def test_public_functions_document_their_parameters() -> None:
    assert PACKAGE.is_dir()
    missing = undocumented(PACKAGE)
    assert not missing, (f"{len(missing)} public functions of two or more arguments have no numpydoc "
                         f"'Parameters' section: {', '.join(missing)}")


@pytest.mark.parametrize("source, expected", [
    # a module with __all__: only the listed function counts, and it lacks Parameters
    ('__all__ = ["f"]\ndef f(a, b):\n    """Sum."""\ndef g(a, b):\n    pass\n', ["pkg/m.py:f"]),
    # without __all__: every non-underscore top-level function; keyword-only arguments count
    ('def f(a, *, b):\n    pass\ndef _h(a, b):\n    pass\ndef one(a):\n    pass\n', ["pkg/m.py:f"]),
    # documented: nothing missing
    ('def f(a, b):\n    """Sum.\n\n    Parameters\n    ----------\n    a, b : int\n        Terms.\n    """\n', []),
])
def test_the_check_catches_an_undocumented_function(tmp_path: Path, source: str, expected: list[str]) -> None:
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "m.py").write_text(source, encoding="utf-8")
    assert undocumented(pkg) == expected
