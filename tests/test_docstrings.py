"""Every public function of obsnl that takes two or more arguments documents them, in one dialect (numpydoc).

Public: listed in its module's ``__all__``, or, in a module without ``__all__``, any top-level
function whose name does not start with ``_``. Such a function needs a docstring with a
``Parameters`` section. Every entry of a ``Parameters`` section anywhere in the package reads
``name : type`` (numpydoc), and a function whose method comes from a paper cites it in a
``References`` section, with its DOI where the paper has one. The checks read the source (``ast``),
so they import nothing.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "obsnl"


def _overload(node: ast.FunctionDef) -> bool:
    """A ``@typing.overload`` signature: its function's docstring is on the implementation that follows it."""
    return any(ast.unparse(d) in ("overload", "typing.overload") for d in node.decorator_list)


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
            if (isinstance(node, ast.FunctionDef) and not node.name.startswith("_") and not _overload(node)
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
    # overloads: documented on the implementation, which is still checked
    ('@overload\ndef f(a: int, b: int) -> int: ...\n@overload\ndef f(a: str, b: str) -> str: ...\ndef f(a, b):\n'
     '    """Sum."""\n', ["pkg/m.py:f"]),
])
def test_the_check_catches_an_undocumented_function(tmp_path: Path, source: str, expected: list[str]) -> None:
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "m.py").write_text(source, encoding="utf-8")
    assert undocumented(pkg) == expected


_SECTION = re.compile(r"(Parameters|Returns|Yields|Raises|Warns|Examples?|Notes|Attributes|See Also|References|"
                      r"Other Parameters)")


def _positional(entry: str) -> bool:
    """``a, b : T1, T2`` (one type per name, by position): not numpydoc, where ``a, b`` share one type."""
    names, kind = entry.split(" : ", 1)
    return "," in names and "," in re.sub(r"\([^()]*\)|\[[^\[\]]*\]", "", kind)


def untyped(root: Path) -> list[str]:
    """``file:function: entry`` for each ``Parameters`` entry not of the form ``name : type`` (or ``a, b : type``),
    anywhere in ``root``."""
    found = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                continue
            lines = (ast.get_docstring(node) or "").splitlines()
            for i, line in enumerate(lines[:-1]):
                if line != "Parameters" or not re.fullmatch(r"-{3,}", lines[i + 1]):
                    continue
                for j in range(i + 2, len(lines)):
                    entry = lines[j]
                    if j + 1 < len(lines) and _SECTION.fullmatch(entry) and re.fullmatch(r"-{3,}", lines[j + 1]):
                        break
                    if entry and not entry[0].isspace() and (" : " not in entry or _positional(entry)):
                        found.append(f"{path.relative_to(root.parent).as_posix()}:{node.name}: {entry}")
    return found


def test_parameters_name_their_types() -> None:
    missing = untyped(PACKAGE)
    assert not missing, f"{len(missing)} Parameters entries without 'name : type': {'; '.join(missing)}"


@pytest.mark.parametrize("source, expected", [
    ('def f(a, b):\n    """S.\n\n    Parameters\n    ----------\n    a, b\n        Terms.\n    """\n', ["pkg/m.py:f: a, b"]),
    ('def f(a, b):\n    """S.\n\n    Parameters\n    ----------\n    a, b : int, str\n        Terms.\n    """\n',
     ["pkg/m.py:f: a, b : int, str"]),
    ('def f(a, b):\n    """S.\n\n    Parameters\n    ----------\n    a, b : int\n        Terms.\n\n    Returns\n'
     '    -------\n    int\n    """\n', []),
])
def test_the_dialect_check_catches_an_untyped_entry(tmp_path: Path, source: str, expected: list[str]) -> None:
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "m.py").write_text(source, encoding="utf-8")
    assert untyped(pkg) == expected


#: Functions whose method comes from a paper: ``module:function`` -> the DOI its References give (None: the
#: paper has no DOI, and the reference gives authors, venue and year).
FROM_PAPERS = {
    "observability/engines/smooth.py:orc": "10.1109/TAC.1977.1101601",  # Hermann & Krener 1977
    "observability/engines/orc.py:orc_block": "10.1109/TAC.1977.1101601",
    "observability/engines/smooth.py:sedoglavic": "10.1006/jsco.2002.0532",  # Sedoglavic 2002
    "observability/engines/sedoglavic.py:sedoglavic_block": "10.1006/jsco.2002.0532",
    "algebra/bounds.py:failure_bound": "10.1006/jsco.2002.0532",
    "observability/certificates/symmetry.py:symmetries": "10.1006/jsco.2002.0532",
    "observability/analyze.py:analyze": "10.1002/stc.1690",  # Chatzis, Chatzi & Smyth 2015
    "model/branching/branches.py:split_branches": "10.1002/stc.1690",
    "observability/joint/verdict.py:joint_verdict": None,  # Tanwani, Shim & Liberzon 2013
    "recombination/reparametrize.py:reparametrize": "10.1007/s10208-013-9165-9",  # Hubert & Labahn 2013
    "recombination/scalings.py:scaling_section": "10.1007/s10208-013-9165-9",
    "linear/systems.py:kalman_rank": "10.1137/0301010",  # Kalman 1963
    "linear/hautus.py:hautus": None,  # Hautus 1969
    "linear/gains.py:riccati_gain": "10.1115/1.3658902",  # Kalman & Bucy 1961
    "linear/gains.py:place_gain": "10.1109/9.539425",  # Tits & Yang 1996
    "estimation/ukf.py:UKF": "10.1109/JPROC.2003.823141",  # Julier & Uhlmann 2004
    "estimation/dukf.py:DUKF": "10.3389/fbuil.2017.00056",  # Chatzis & Chatzi 2017
    "estimation/numeric.py:step": "10.1137/S1064827597326651",  # Verwer et al. 1999 (ROS2)
    "estimation/crossing.py:located_substep": "10.1007/978-94-015-7793-9",  # Filippov 1988
    "identification/profile.py:profile": "10.1093/bioinformatics/btp358",  # Raue et al. 2009
    "identification/profile.py:profiles": "10.1093/bioinformatics/btp358",
    "identification/likelihood.py:levenberg_marquardt": "10.1137/0111030",  # Marquardt 1963
    "design/ranking.py:effective_independence": "10.2514/3.20635",  # Kammer 1991
    "design/ranking.py:rank_sensor_sets": "10.2514/3.20635",
    "studies/buildings.py:bouc_wen_building": "10.1061/JMCEA3.0002106",  # Bouc 1967, Wen 1976
}


@pytest.mark.parametrize("where", sorted(FROM_PAPERS))
def test_a_method_from_a_paper_cites_it(where: str) -> None:
    module, name = where.split(":")
    tree = ast.parse((PACKAGE / module).read_text(encoding="utf-8"))
    (node,) = [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.ClassDef)) and n.name == name
               and not (isinstance(n, ast.FunctionDef) and _overload(n))]
    doc = ast.get_docstring(node) or ""
    assert "\nReferences\n----------\n" in doc, where
    references = doc.split("\nReferences\n----------\n", 1)[1]
    assert ".. [1] " in references
    if FROM_PAPERS[where] is not None:
        assert f"doi:{FROM_PAPERS[where]}" in " ".join(references.split()), where
