"""No public result field is typed ``Any`` or a bare dict (issue 42, "typed results end to end").

Every frozen dataclass listed in the ``__all__`` of a module of obsnl (the walk imports each module) has its
fields' types resolved (``typing.get_type_hints``, with the names a module imports only under
``if TYPE_CHECKING:`` supplied from that block) and checked by :func:`loose`: a field is loose when its type,
or a member of a union or an argument of a builtin container in it, is ``Any``, a bare ``dict``/``Mapping``, or
a mapping to ``Any`` (``Mapping[str, Any]``, ``dict[str, Any]``). A callable's return type is not read (a
callback whose return is ignored is ``Callable[..., Any]`` by convention), nor the arguments of another library's
generic (``numpy.typing.ArrayLike`` is spelt with ``Any`` inside numpy). A truly free value (a user's metadata) is
typed with the recursive JSON aliases of ``obsnl._types``.

The few fields still loose for a stated reason are listed in :data:`EXEMPT`; an entry that is no longer loose
fails the test too, so that the list only shrinks.
"""

from __future__ import annotations

import ast
import collections.abc
import dataclasses
import importlib
import inspect
import json
import pkgutil
import types
import typing
from collections.abc import Callable, Mapping
from typing import Any, Optional

import pytest

import obsnl
from obsnl._types import FileValue, JSONValue

#: ``module.Class.field`` -> why it is still loose. Keep it short; each entry is checked to be still loose.
EXEMPT: dict[str, str] = {}

#: Generic origins whose arguments are read (builtin and standard containers); any other generic is a leaf.
_CONTAINERS = {
    dict,
    list,
    tuple,
    set,
    frozenset,
    type,
    collections.abc.Mapping,
    collections.abc.MutableMapping,
    collections.abc.Sequence,
    collections.abc.MutableSequence,
    collections.abc.Set,
    collections.abc.Iterable,
    collections.abc.Collection,
}
_MAPPINGS = (dict, collections.abc.Mapping, collections.abc.MutableMapping)


def loose(hint: object) -> str | None:
    """Why the type ``hint`` is loose (``"Any"``, ``"bare dict"``, ``"mapping to Any"``), or None when it is not.

    A union is loose when a member is; a builtin container when an argument is. Callables and other libraries'
    generics are not looked into.
    """
    if hint is Any:
        return "Any"
    if hint in _MAPPINGS or hint in (typing.Dict, typing.Mapping, typing.MutableMapping):  # noqa: UP006
        return "bare dict"
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        return next((why for why in map(loose, args) if why), None)
    if origin in _MAPPINGS and len(args) == 2 and args[1] is Any:
        return "mapping to Any"
    if origin in _CONTAINERS:
        return next((why for why in map(loose, args) if why), None)
    return None  # a class, a Callable, a ForwardRef of a recursive alias, another library's generic


def _type_checking_names(cls: type) -> dict[str, object]:
    """The names the modules of ``cls`` and of its bases import under ``if TYPE_CHECKING:`` (imported here)."""
    names: dict[str, object] = {}
    for klass in cls.__mro__:
        module = inspect.getmodule(klass)
        if module is None or not module.__name__.startswith("obsnl"):
            continue
        tree = ast.parse(inspect.getsource(module))
        for node in tree.body:
            if isinstance(node, ast.If) and ast.unparse(node.test) in ("TYPE_CHECKING", "typing.TYPE_CHECKING"):
                block = ast.Module(body=[n for n in node.body if isinstance(n, (ast.Import, ast.ImportFrom))],
                                   type_ignores=[])
                scope = {"__name__": module.__name__, "__package__": module.__package__}
                exec(compile(block, module.__file__ or module.__name__, "exec"), scope, names)
    return names


def loose_fields(cls: type) -> dict[str, str]:
    """``{field: why}`` for the loose fields of the dataclass ``cls`` (private fields, ``_name``, aside)."""
    hints = typing.get_type_hints(cls, localns=_type_checking_names(cls))
    out = {}
    for f in dataclasses.fields(cls):
        why = loose(hints[f.name])
        if why is not None and not f.name.startswith("_"):
            out[f.name] = why
    return out


def public_frozen_dataclasses() -> dict[str, type]:
    """``{module.Class: class}`` of every frozen dataclass named in the ``__all__`` of a module of obsnl."""
    found: dict[str, type] = {}
    for info in pkgutil.walk_packages(obsnl.__path__, "obsnl."):
        if info.name.endswith(".__main__"):  # importing it runs the command line
            continue
        module = importlib.import_module(info.name)
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name)
            if isinstance(obj, type) and dataclasses.is_dataclass(obj) and obj.__dataclass_params__.frozen:
                found[f"{obj.__module__}.{obj.__qualname__}"] = obj
    return found


@pytest.fixture(scope="module")
def classes() -> dict[str, type]:
    return public_frozen_dataclasses()


def test_no_public_frozen_dataclass_has_a_loose_field(classes):
    # the walk reaches the result values of every room (not an empty pass)
    for name in ("obsnl.model.core.Model", "obsnl.observability.results.AnalysisResult",
                 "obsnl.observability.assumptions.Assumptions", "obsnl.estimation.ukf.UKF",
                 "obsnl.design.sensor_search.SensorSearch", "obsnl.design.experiment.ExperimentDesign",
                 "obsnl.observability.contract.branch_table.BranchTable"):
        assert name in classes, name
    assert len(classes) > 80, len(classes)
    found = {f"{q}.{field}": why for q, cls in classes.items() for field, why in loose_fields(cls).items()}
    unexpected = {k: v for k, v in found.items() if k not in EXEMPT}
    assert not unexpected, f"fields typed loosely (give them a real type): {unexpected}"
    stale = sorted(set(EXEMPT) - set(found))
    assert not stale, f"typed now: take {stale} off EXEMPT"


# ----------------------------------------------------------------------------- the checker can fail
@dataclasses.dataclass(frozen=True)
class _Loose:
    anything: Any
    table: dict
    abc_table: Mapping
    options: Mapping[str, Any]
    extras: dict[str, Any]
    maybe: Optional[Mapping[str, Any]]  # noqa: UP045 (the typing spelling is read too)
    maybe_new: dict[str, Any] | None
    rows: tuple[Mapping[str, Any], ...]
    pairs: list[tuple[str, Any]]


@dataclasses.dataclass(frozen=True)
class _Typed:
    numbers: Mapping[str, float]
    names: tuple[str, ...]
    pairs: Mapping[str, tuple[float, float]] | None
    callback: Callable[[int], Any] | None
    free: JSONValue
    metadata: Mapping[str, FileValue]
    _cache: dict  # private: not read


def test_the_checker_flags_every_loose_spelling_and_nothing_typed():
    assert loose_fields(_Loose) == {
        "anything": "Any", "table": "bare dict", "abc_table": "bare dict", "options": "mapping to Any",
        "extras": "mapping to Any", "maybe": "mapping to Any", "maybe_new": "mapping to Any",
        "rows": "mapping to Any", "pairs": "Any",
    }
    assert loose_fields(_Typed) == {}


def test_a_name_imported_only_for_type_checkers_is_resolved():
    # NumericModel.source names the symbolic Model under TYPE_CHECKING (sympy stays out of the estimators)
    from obsnl.estimation.numeric import NumericModel
    from obsnl.model.core import Model

    hints = typing.get_type_hints(NumericModel, localns=_type_checking_names(NumericModel))
    assert typing.get_args(typing.get_args(hints["source"])[0])[0] is Model


# ----------------------------------------------------------------------------- the split's memo
def test_the_memo_of_a_split_holds_each_kind_of_value_under_its_kind_of_key():
    # Switching.memo is typed as the union obsnl.model.branching.feasibility.Memo spells out: a switching function
    # -> (sign, factors); ("affine", g, unknowns) -> coefficients or None; ("relax", pattern) -> bool;
    # ("never", g, s) -> str. A split of sign(x*v - k) and sign((x*v - 2k) v), then the pattern x*v > k,
    # x*v < 2k, k < 0 (empty only by the monomial relaxation: x*v is an unknown between k and 2k < k) fills all four.
    import numpy as np
    import sympy as sp

    from obsnl.model.branching.feasibility import feasible
    from obsnl.model.branching.switching import Switching

    x, v, k = sp.symbols("x v k", real=True)
    level = Switching.of([v, -k * x - sp.sign(x * v - k) - sp.sign((x * v - 2 * k) * v)], [])
    level.field_at([1] * len(level.functions))
    point, _, proved = feasible([(x * v - k, 1), (x * v - 2 * k, -1), (k, -1)], np.random.default_rng(0), level.memo)
    assert point is None and proved
    kinds = set()
    for key, value in level.memo.items():
        kind = key[0] if isinstance(key, tuple) else "factored"
        kinds.add(kind)
        if kind == "factored":
            assert isinstance(key, sp.Expr) and value[0] in (1, -1) and all(isinstance(f, sp.Expr) for f in value[1])
        elif kind == "affine":
            assert value is None or (all(isinstance(c, float) for c in value[0]) and isinstance(value[1], float))
        elif kind == "relax":
            assert isinstance(value, bool)
        else:
            assert kind == "never" and isinstance(value, str), (key, value)
    assert kinds == {"factored", "affine", "relax", "never"}


# ----------------------------------------------------------------------------- the typed assumptions
def _model():
    from obsnl import Model

    # x unknown at t = 0, v known with the value 0, z known but generic; an unknown input w, a known input u;
    # fy declared positive, so the JSON writes its upper end as the text "inf" (JSON has no infinity)
    return Model(name="m", states=["x", "v", "z"], parameters=["k", "fy"], inputs=["u"], unknown_inputs=["w"],
                 equations={"x": "v", "v": "u + w - k*x - fy*v", "z": "-z"}, outputs={"y": "x", "q": "z"},
                 known_initial_conditions=["v", "z"], initial_condition_values={"v": "0"},
                 bounds={"fy": "positive"})


def test_the_assumptions_of_an_analysis_write_the_json_they_always_did():
    from obsnl.observability.analyze import assumptions
    from obsnl.observability.assumptions import Assumptions

    a = assumptions(_model(), 2, None)
    # written out from the model above, in the key order of `obsnl analyze --format json`
    expected = {
        "unknown_input_derivatives": 2,
        "known_inputs": "generic",
        "initial_conditions": {"unknown": ["x"], "known_generic": ["z"], "known_values": {"v": "0"}},
        "bounds": {"fy": [0.0, "inf"]},
    }
    assert json.dumps(a.to_dict()) == json.dumps(expected)
    assert Assumptions.from_dict(json.loads(json.dumps(a.to_dict()))) == a


@pytest.mark.parametrize("change, words", [
    ({"unknown_input_derivatives": "sometimes"}, "unknown_input_derivatives is 'sometimes'"),
    ({"known_inputs": 3}, "known_inputs is 3"),
    ({"initial_conditions": {"unknown": "x", "known_generic": [], "known_values": {}}},
     "initial_conditions.unknown is 'x'"),
    ({"initial_conditions": {"unknown": ["x"]}}, "initial_conditions has no 'known_generic'"),
    ({"bounds": {"fy": [0, "huge"]}}, "the end 'huge'"),
    ({"extra": 1}, "unknown key 'extra'"),
])
def test_a_branch_table_with_wrong_assumptions_is_refused_in_one_line(coulomb_table, change, words):
    from obsnl.errors import TableError
    from obsnl.observability.contract.branch_table import BranchTable

    _, data = coulomb_table
    assumed = {**data["assumptions"], **change}
    with pytest.raises(TableError, match="regenerate it") as info:
        BranchTable.from_dict({**data, "assumptions": assumed})
    assert words in str(info.value) and "\n" not in str(info.value)


def test_a_branch_table_reads_its_assumptions_back(coulomb_table):
    from obsnl.observability.assumptions import Assumptions
    from obsnl.observability.contract.branch_table import BranchTable

    _, data = coulomb_table
    again = BranchTable.from_dict(json.loads(json.dumps(data)))
    assert isinstance(again.assumptions, Assumptions)
    assert json.dumps(again.to_dict()) == json.dumps(data)  # the same document, key for key
